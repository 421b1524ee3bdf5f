// A person's dynamic texture library (paper 001 Sec. 5.2-5.3) in one file that is also a
// textured rig: /rig (the person's rig), /texture/albedo (the neutral albedo, so every reader
// of a textured rig sees the static texture), and
//   /dynamic_texture/neutral, compress, stretch [S, S, 5]   T_N, T_C, T_S: albedo R, G, B
//        (linear), specular, displacement (mm), in the rig's UV layout, row 0 at v = 1
//   /dynamic_texture/reference [S, S, 2]   R_C, R_S: the compress and stretch influence (cm)
//        that T_C and T_S stand for (textures/compress_stretch.h)
//   /dynamic_texture/influence [N, V, 2]   per rig shape and vertex, eq. 10-11's compress and
//        stretch influence (cm) of the shape at weight 1 against the rig's neutral (the input
//        of eq. 14 as the paper prints it)
//   attribute sharpness_per_cm on /dynamic_texture/compress: b of eq. 12 and 14
// `render` draws such a rig with the strain texture's albedo at its weights; `export textures`
// writes a tracked take's maps per frame. The scan database's skin maps use the same five
// channels.
#ifndef FACECAP_IO_DYNAMIC_TEXTURE_FILE_H_
#define FACECAP_IO_DYNAMIC_TEXTURE_FILE_H_

#include <string>
#include <vector>

#include "io/hdf5.h"
#include "util/image.h"

namespace facecap::io {

// The channels of skin maps, and their names as the files' `channels` attributes list them.
inline constexpr int kSkinMapChannels = 5;
inline constexpr const char* kSkinMapChannelNames = "albedo_r albedo_g albedo_b specular displacement_mm";

struct DynamicTextureLibrary {
  int size = 0;                    // S
  float sharpness = 300.f;         // b, per cm
  std::vector<float> neutral, compress, stretch;  // S x S x 5 each
  int num_shapes = 0, num_vertices = 0;           // N, V
  std::vector<float> influence;    // N x V x 2
  std::vector<float> reference;    // S x S x 2
};

// Writes the /dynamic_texture group and /texture/albedo (the rig itself is written by the
// caller). InvalidInputError when the maps or influences are not of the library's sizes.
void WriteDynamicTextureLibrary(H5File* file, const DynamicTextureLibrary& library);

// Whether the file at `path` carries a dynamic texture library.
bool HasDynamicTexture(const std::string& path);

// Reads the library of `path` for a rig of `num_shapes` shapes and `num_vertices` vertices;
// FileIOError naming the file when a dataset is missing, of the wrong shape, not finite or
// (influences) negative.
DynamicTextureLibrary ReadDynamicTextureLibrary(const std::string& path, int num_shapes, int num_vertices);

// One layer of S x S x 5 skin maps as an image: channels [first, first + count).
ImageF SkinMapLayer(const std::vector<float>& maps, int size, int first, int count);

}  // namespace facecap::io

#endif  // FACECAP_IO_DYNAMIC_TEXTURE_FILE_H_
