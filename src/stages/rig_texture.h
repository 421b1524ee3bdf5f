// The albedo texture a textured rig file carries (io/texture_file.h), as the exports embed it,
// and the generic texture an untextured rig is drawn with.
#ifndef FACECAP_STAGES_RIG_TEXTURE_H_
#define FACECAP_STAGES_RIG_TEXTURE_H_

#include <memory>
#include <string>
#include <vector>

#include "io/dynamic_texture_file.h"
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

// The strain texture (textures/compress_stretch.h) of the dynamic texture library that the rig
// file at `path` carries (io/dynamic_texture_file.h) for `rig`, with the maps' size in *size;
// null when the file carries none. FileIOError for a malformed library.
std::unique_ptr<textures::RigStrainTexture> ReadRigDynamicTexture(const std::string& path, const rig::Rig& rig,
                                                                  int* size);

// A person's library (paper 001 eq. 10-13): the compress and stretch maps of the
// `expressions` meshes' skin maps (S x S x 5 each) under eq. 10-11's influences against
// `neutral` (the person's neutral mesh), fitted for the strain texture with their reference
// influences, and the influence of each of `rig`'s shapes at weight 1 against the rig's
// neutral (eq. 14 as printed). The rig has the expressions' topology and the maps' UV layout.
io::DynamicTextureLibrary MakeDynamicTextureLibrary(const rig::Rig& rig, const rig::Vertices& neutral,
                                                    const std::vector<rig::Vertices>& expressions,
                                                    std::vector<float> neutral_maps,
                                                    const std::vector<std::vector<float>>& expression_maps, int size,
                                                    float sharpness);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RIG_TEXTURE_H_
