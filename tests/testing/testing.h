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

// The directory that holds the facecap binary and the test binaries' parent (build/).
std::string BuildDir();
// The source tree's root (for jobs/ and datasets/).
std::string SourceDir();

}  // namespace facecap::testing

#endif  // FACECAP_TESTS_TESTING_TESTING_H_
