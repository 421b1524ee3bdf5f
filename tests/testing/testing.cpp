#include "testing/testing.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sys/wait.h>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

namespace facecap::testing {

TempDir::TempDir() {
  const char* base = std::getenv("TMPDIR");
  std::string pattern = std::string(base && *base ? base : "/tmp") + "/facecap_test_XXXXXX";
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  if (!mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed for " + pattern);
  path_ = buf.data();
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

CommandResult RunCommand(const std::string& command) {
  CommandResult r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string MpiExec(int ranks) {
  return std::string(FACECAP_MPIEXEC) +
         " --oversubscribe --allow-run-as-root --mca btl_vader_single_copy_mechanism none -n " +
         std::to_string(ranks);
}

CommandResult RunFacecap(const std::string& args, int ranks, const std::string& env) {
  std::string cmd = env.empty() ? "" : "env " + env + " ";
  if (ranks > 0) cmd += MpiExec(ranks) + " ";
  cmd += BuildDir() + "/facecap " + args;
  return RunCommand(cmd);
}

std::string BuildDir() { return FACECAP_BUILD_DIR; }
std::string SourceDir() { return FACECAP_SOURCE_DIR; }

double NestedJsonNumber(const std::string& json, const std::string& object, const std::string& key) {
  const size_t o = json.find("\"" + object + "\": {");
  if (o == std::string::npos) return std::nan("");
  const size_t at = json.find("\"" + key + "\": ", o);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

}  // namespace facecap::testing
