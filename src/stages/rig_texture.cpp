#include "stages/rig_texture.h"

#include "io/texture_file.h"
#include "render/shading.h"
#include "synth/appearance.h"
#include "util/errors.h"

namespace facecap::stages {

Image8 ReadRigTextureSrgb(const std::string& rig_path) {
  const ImageF linear = io::ReadRigTexture(rig_path);
  Image8 srgb;
  if (!linear.empty()) render::LinearToImage8(linear, true, &srgb);
  return srgb;
}

ImageF GenericSkinTexture(const rig::Rig& rig) {
  if (rig.uvs.rows() == 0 || rig.uv_triangles.rows() != rig.triangles.rows() ||
      rig.landmarks.size() != 68) {
    throw InvalidInputError("the generic skin texture needs a rig with UVs and 68 landmarks");
  }
  return synth::MakeSkinTexture(rig, synth::DrawPersonColors(1), 1, synth::SkinTextureOptions());
}

}  // namespace facecap::stages
