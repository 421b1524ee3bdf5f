// The rig in HDF5 (rig.h5). Layout under `group` (default /rig), units in attributes:
//   neutral [V,3] f32 (cm)             triangles [F,3] i32        uvs [U,2] f32
//   uv_triangles [F,3] i32             triangle_region [F] i32
//   regions/names [R] str              regions/colors [R,3] f32 (RGB in [0,1])
//   jaw/weights [V] f32 (M)            jaw/pivot [3] f32 (cm)
//   shapes/names [S] str               shapes/jaw_euler [S,3] f32 (rad)   shapes/jaw_translation [S,3]
//   shapes/deltas/row_offsets [S+1] i64, shapes/deltas/vertex [nnz] i32, shapes/deltas/offset [nnz,3] f32
//   landmarks [68] i32 (iBUG 300-W order)   identity_modes [K,V,3] f32
#ifndef FACECAP_IO_RIG_IO_H_
#define FACECAP_IO_RIG_IO_H_

#include <string>

#include "io/hdf5.h"
#include "rig/rig.h"

namespace facecap::io {

void WriteRig(const rig::Rig& rig, H5File* file, const std::string& group = "/rig");
// Reads and checks (Rig::Check) a rig; FileIOError names the file and what is wrong.
rig::Rig ReadRig(const H5File& file, const std::string& group = "/rig");
rig::Rig ReadRigFile(const std::string& path, const std::string& group = "/rig");

}  // namespace facecap::io

#endif  // FACECAP_IO_RIG_IO_H_
