// Textures in HDF5: a colour texture is a float32 dataset [N, N, 3] of linear RGB, row 0 at
// the top of the texture (v = 1; texel (x, y) has its centre at u = (x + 0.5) / N,
// v = 1 - (y + 0.5) / N, as render::SampleBilinear reads it), attribute `layout`.
//
// Where textures live:
//   /texture/albedo      a captured texture (facecap appearance gather); beside it
//                        /texture/confidence [N, N] and /texture/particles [N, N]
//   /identity/albedo     the true albedo of a synthetic person (synth clip), for evaluation
//
// A rig file that carries /texture/albedo beside /rig is a textured rig (appearance gather
// writes one): render draws it with that texture, and rig export and export gltf embed it.
#ifndef FACECAP_IO_TEXTURE_FILE_H_
#define FACECAP_IO_TEXTURE_FILE_H_

#include <string>

#include "io/hdf5.h"
#include "util/image.h"

namespace facecap::io {

inline constexpr const char* kTextureAlbedoPath = "/texture/albedo";
inline constexpr const char* kTextureConfidencePath = "/texture/confidence";
inline constexpr const char* kTextureParticlesPath = "/texture/particles";
inline constexpr const char* kTrueAlbedoPath = "/identity/albedo";

// Writes a colour texture (3 channels, square) as dataset `name` with its layout attribute.
void WriteColorTexture(H5File* file, const std::string& name, const ImageF& texture);

// Reads colour texture `name` of file `path`. FileIOError naming the file when the dataset is
// missing, not [N, N, 3] with N >= 1, or holds a value that is not finite.
ImageF ReadColorTexture(const std::string& path, const std::string& name);

// The albedo texture a rig file carries (/texture/albedo), or an empty image when it has none;
// FileIOError as ReadColorTexture when it has one that is malformed.
ImageF ReadRigTexture(const std::string& path);

}  // namespace facecap::io

#endif  // FACECAP_IO_TEXTURE_FILE_H_
