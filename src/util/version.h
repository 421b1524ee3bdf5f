#ifndef FACECAP_UTIL_VERSION_H_
#define FACECAP_UTIL_VERSION_H_

#include <string>

namespace facecap {

std::string Version();    // "0.1.0"
std::string GitCommit();  // short hash of the commit the binary was configured at

}  // namespace facecap

#endif  // FACECAP_UTIL_VERSION_H_
