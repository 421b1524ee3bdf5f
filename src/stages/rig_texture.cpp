#include "stages/rig_texture.h"

#include "io/dynamic_texture_file.h"
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

std::unique_ptr<textures::DynamicTexture> ReadRigDynamicTexture(const std::string& path, const rig::Rig& rig,
                                                                int* size) {
  if (!io::HasDynamicTexture(path)) return nullptr;
  io::DynamicTextureLibrary library = io::ReadDynamicTextureLibrary(path, rig.NumShapes(), rig.NumVertices());
  *size = library.size;
  return std::make_unique<textures::DynamicTexture>(textures::DynamicTextureForRig(
      rig, library.size, io::kSkinMapChannels, std::move(library.neutral),
      textures::CompressStretchMaps{library.compress, library.stretch}, library.influence, library.sharpness));
}

}  // namespace facecap::stages
