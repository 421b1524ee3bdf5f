#include "io/hdf5_info.h"

#include <hdf5.h>

namespace facecap::io {

std::string Hdf5RuntimeVersion() {
  unsigned major = 0, minor = 0, release = 0;
  H5get_libversion(&major, &minor, &release);
  return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(release);
}

bool Hdf5IsParallel() {
#ifdef H5_HAVE_PARALLEL
  return true;
#else
  return false;
#endif
}

}  // namespace facecap::io
