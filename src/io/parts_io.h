// A face rig's secondary parts (rig/parts.h) in HDF5, beside /rig in an assembled rig file
// (facecap assemble):
//   /parts/names [P] strings, /parts/shape_names [N] strings (the rig's shape order),
//   attribute iris on /parts (index of the procedural iris), /parts/iris_texture [S, S, 3]
//   (linear RGB, row 0 at v = 1, the eyeballs' front projection)
//   /parts/<name>/neutral [V, 3] (cm), triangles [F, 3], uvs [V, 2], deltas [N, V, 3] (cm),
//   follow [V] (the face vertex a part vertex is bound to, or -1); attributes material, group.
#ifndef FACECAP_IO_PARTS_IO_H_
#define FACECAP_IO_PARTS_IO_H_

#include <string>

#include "io/hdf5.h"
#include "rig/parts.h"
#include "util/image.h"

namespace facecap::io {

inline constexpr const char* kPartsGroup = "/parts";

void WriteParts(H5File* file, const rig::PartSet& parts, const ImageF& iris_texture);

// Whether the file at `path` carries /parts.
bool HasParts(const std::string& path);

// Reads /parts of the file at `path` (groups are not stored: the result has none).
// FileIOError naming the file and the dataset when one is missing, of the wrong shape, holds a
// non-finite value or an index out of range, or when its shape count is not `num_shapes`.
rig::PartSet ReadParts(const std::string& path, int num_shapes, ImageF* iris_texture);

}  // namespace facecap::io

#endif  // FACECAP_IO_PARTS_IO_H_
