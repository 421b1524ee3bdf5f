#include "testing/testing.h"

#include <cstdlib>
#include <filesystem>
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

std::string BuildDir() { return FACECAP_BUILD_DIR; }
std::string SourceDir() { return FACECAP_SOURCE_DIR; }

}  // namespace facecap::testing
