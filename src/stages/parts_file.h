// The glTF side of an assembled rig file (facecap assemble; its /parts layout is io/parts_io.h):
// the face and its secondary parts as the exports write them.
#ifndef FACECAP_STAGES_PARTS_FILE_H_
#define FACECAP_STAGES_PARTS_FILE_H_

#include <memory>
#include <string>
#include <vector>

#include "io/mesh_io.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::stages {

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
