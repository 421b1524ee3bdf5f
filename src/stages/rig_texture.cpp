#include "stages/rig_texture.h"

#include "io/texture_file.h"
#include "render/shading.h"

namespace facecap::stages {

Image8 ReadRigTextureSrgb(const std::string& rig_path) {
  const ImageF linear = io::ReadRigTexture(rig_path);
  Image8 srgb;
  if (!linear.empty()) render::LinearToImage8(linear, true, &srgb);
  return srgb;
}

}  // namespace facecap::stages
