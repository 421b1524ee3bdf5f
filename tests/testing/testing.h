// Shared test support.
#ifndef FACECAP_TESTS_TESTING_TESTING_H_
#define FACECAP_TESTS_TESTING_TESTING_H_

#include <string>

namespace facecap::testing {

// A fresh directory under $TMPDIR removed (recursively) when the object goes away.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// Result of running a command: exit code and stdout + stderr.
struct CommandResult {
  int code = -1;
  std::string output;
};
// Runs a shell command and captures its output.
CommandResult RunCommand(const std::string& command);
// Runs build/facecap with `args` (a shell word list), optionally under mpiexec with `ranks`
// ranks (0: no launcher) and with environment assignments `env` ("A=1 B=2").
CommandResult RunFacecap(const std::string& args, int ranks = 0, const std::string& env = "");
// The launcher command for `ranks` ranks (oversubscribed, allowed as root).
std::string MpiExec(int ranks);

// The whole text of file `path` (empty when it cannot be read).
std::string ReadText(const std::string& path);

// The directory that holds the facecap binary and the test binaries' parent (build/).
std::string BuildDir();
// The source tree's root (for jobs/ and datasets/).
std::string SourceDir();

// The number after "key": inside the object that follows "object": in a JSON text (an
// evaluation's output), or NaN when either is missing.
double NestedJsonNumber(const std::string& json, const std::string& object, const std::string& key);

}  // namespace facecap::testing

#endif  // FACECAP_TESTS_TESTING_TESTING_H_
