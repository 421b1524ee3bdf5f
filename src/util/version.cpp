#include "util/version.h"

namespace facecap {

std::string Version() { return FACECAP_VERSION; }
std::string GitCommit() { return FACECAP_GIT_COMMIT; }

}  // namespace facecap
