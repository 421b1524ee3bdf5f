// A face rig's secondary parts (assets/secondary_parts.h) in HDF5, beside /rig in an assembled
// rig file (facecap assemble):
//   /parts/names [P] strings, /parts/shape_names [N] strings (the rig's shape order),
//   attribute iris on /parts (index of the procedural iris), /parts/iris_texture [S, S, 3]
//   (linear RGB, row 0 at v = 1, the eyeballs' front projection)
//   /parts/<name>/neutral [V, 3] (cm), triangles [F, 3], uvs [V, 2], deltas [N, V, 3] (cm),
//   follow [V] (the face vertex a part vertex is bound to, or -1); attributes material, group.
#ifndef FACECAP_STAGES_PARTS_FILE_H_
#define FACECAP_STAGES_PARTS_FILE_H_

#include <memory>
#include <string>
#include <vector>

#include "assets/secondary_parts.h"
#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::stages {

inline constexpr const char* kPartsGroup = "/parts";

void WriteParts(io::H5File* file, const assets::PartSet& parts, const ImageF& iris_texture);

// Whether the file at `path` carries /parts.
bool HasParts(const std::string& path);

// Reads /parts of the file at `path` (groups are not stored: the result has none).
// FileIOError naming the file and the dataset when one is missing, of the wrong shape, holds a
// non-finite value or an index out of range, or when its shape count is not `num_shapes`.
assets::PartSet ReadParts(const std::string& path, int num_shapes, ImageF* iris_texture);

// What the glTF exports write for an assembled rig file: the face without its own eyeball
// spheres (the parts' eyeballs replace them) and one extra mesh per part, with a material of
// its kind and, for the eyeballs, the iris texture (`iris` owns it).
struct PartMeshes {
  rig::Rig face;
  std::vector<io::GltfExtraMesh> meshes;
  std::unique_ptr<Image8> iris;
};

// For the rig file at `path` (already read as `face`): the face alone when it has no /parts.
PartMeshes ReadPartMeshes(const std::string& path, const rig::Rig& face);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_PARTS_FILE_H_
