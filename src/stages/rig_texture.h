// The albedo texture a textured rig file carries (io/texture_file.h), as the exports embed it,
// and the generic texture an untextured rig is drawn with.
#ifndef FACECAP_STAGES_RIG_TEXTURE_H_
#define FACECAP_STAGES_RIG_TEXTURE_H_

#include <memory>
#include <string>

#include "rig/rig.h"
#include "textures/compress_stretch.h"
#include "util/image.h"

namespace facecap::stages {

// The rig file's /texture/albedo encoded as 8-bit sRGB (what glTF's base colour holds), or an
// empty image when the file carries no texture. FileIOError for a malformed texture.
Image8 ReadRigTextureSrgb(const std::string& rig_path);

// The generic skin texture `render` draws a rig without its own texture with: the procedural
// albedo of the wild clips' first person (skin tone, blotches, pores, redder cheeks, lips,
// brows, lash lines), linear RGB. InvalidInputError when the rig has no UVs or 68 landmarks.
ImageF GenericSkinTexture(const rig::Rig& rig);

// Eq. 14 of the dynamic texture library that the rig file at `path` carries
// (io/dynamic_texture_file.h) for `rig`, with the maps' size in *size; null when the file
// carries none. FileIOError for a malformed library.
std::unique_ptr<textures::DynamicTexture> ReadRigDynamicTexture(const std::string& path, const rig::Rig& rig,
                                                                int* size);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RIG_TEXTURE_H_
