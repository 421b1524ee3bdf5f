#ifndef FACECAP_IO_HDF5_INFO_H_
#define FACECAP_IO_HDF5_INFO_H_

#include <string>

namespace facecap::io {

std::string Hdf5RuntimeVersion();  // "1.10.8"
bool Hdf5IsParallel();             // built with MPI-IO (H5_HAVE_PARALLEL)

}  // namespace facecap::io

#endif  // FACECAP_IO_HDF5_INFO_H_
