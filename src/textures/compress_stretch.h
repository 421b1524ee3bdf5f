// Compress and stretch maps (paper 001 Sec. 5.2-5.3, eq. 12-14): a dynamic texture library
// of a neutral texture T_N, a compress map T_C and a stretch map T_S, blended at runtime by
// the blendshapes' influence maps.
//
// Textures are N x N texels of C interleaved channels (albedo RGB, specular, displacement, or
// any subset). Influence maps are N x N x 2 (compress, stretch) as textures/influence.h makes
// them. Eq. 12 normalizes the influences of M maps per texel with a softmax,
//   I^_i(x, y) = exp(b I_i(x, y)) / sum_j exp(b I_j(x, y)),
// where b = `sharpness` (per mesh unit; the paper's equation is b = 1). Eq. 13:
//   T_C(x, y) = sum_i I^_i,compress(x, y) T_i(x, y)   (T_S likewise)
// over the expressions' textures T_i. Eq. 14, for blendshape weights alpha:
//   T = T_N + sum_i alpha_i (I^_i,compress (T_C - T_N) + I^_i,stretch (T_S - T_N))
// with the blendshapes' normalized influences.
#ifndef FACECAP_TEXTURES_COMPRESS_STRETCH_H_
#define FACECAP_TEXTURES_COMPRESS_STRETCH_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rig/rig.h"

namespace facecap::textures {

// Eq. 12 for one channel of M influence maps: maps[i] points at channel `channel` of an
// interleaved n x stride map. Returns M normalized maps of n floats each.
std::vector<std::vector<float>> NormalizeInfluence(const std::vector<const float*>& maps, size_t n,
                                                   int stride, int channel, float sharpness);

// Eq. 13: sum_i weights[i] (n floats) * textures[i] (n x channels floats).
std::vector<float> BlendTextures(const std::vector<std::vector<float>>& weights,
                                 const std::vector<const float*>& textures, size_t n, int channels);

struct CompressStretchMaps {
  std::vector<float> compress;  // T_C, n x channels
  std::vector<float> stretch;   // T_S, n x channels
};
// Eq. 12-13 from the expressions' influence maps (n x 2 each) and textures (n x channels).
CompressStretchMaps ExtractCompressStretch(const std::vector<const float*>& influence_maps,
                                           const std::vector<const float*>& textures, size_t n,
                                           int channels, float sharpness);

// Eq. 14 at runtime. The blendshapes' normalized influences are kept sparse: with
// m = max_j b I_j and Z = sum_j exp(b I_j - m) at a texel,
//   sum_i alpha_i I^_i = exp(-m) / Z * sum_i alpha_i + sum_{i: I_i > 0} alpha_i e_i,
//   e_i = (exp(b I_i - m) - exp(-m)) / Z,
// so a frame costs the texels each active blendshape moves plus one pass over the texture.
class DynamicTexture {
 public:
  // neutral, compress, stretch: n x channels; blendshape_influence: one n x 2 map per
  // blendshape.
  DynamicTexture(size_t n, int channels, std::vector<float> neutral, const CompressStretchMaps& maps,
                 const std::vector<const float*>& blendshape_influence, float sharpness);

  size_t NumTexels() const { return n_; }
  int channels() const { return channels_; }
  int NumBlendshapes() const { return static_cast<int>(compress_.size()); }
  const std::vector<float>& neutral() const { return neutral_; }

  // out: n x channels; weights: one per blendshape.
  void Evaluate(const float* weights, float* out) const;
  std::vector<float> Evaluate(const std::vector<float>& weights) const;

  // The texels of all blendshapes' sparse influence entries (compress and stretch).
  size_t NumSparseEntries() const;

 private:
  struct Sparse {
    std::vector<int32_t> texel;
    std::vector<float> value;
  };
  void Build(const std::vector<const float*>& influence, int channel, float sharpness,
             std::vector<float>* base, std::vector<Sparse>* sparse) const;

  size_t n_ = 0;
  int channels_ = 0;
  std::vector<float> neutral_;
  std::vector<float> compress_delta_;  // T_C - T_N
  std::vector<float> stretch_delta_;   // T_S - T_N
  std::vector<float> compress_base_;   // exp(-m) / Z per texel
  std::vector<float> stretch_base_;
  std::vector<Sparse> compress_;       // per blendshape
  std::vector<Sparse> stretch_;
};

// Eq. 14 for a rig: `vertex_influence` (N x V x 2: each of the rig's N shapes' compress and
// stretch influence per vertex) interpolated over the rig's size x size UV layout, with the
// library's maps (size^2 x channels).
DynamicTexture DynamicTextureForRig(const rig::Rig& rig, int size, int channels, std::vector<float> neutral,
                                    const CompressStretchMaps& maps, const std::vector<float>& vertex_influence,
                                    float sharpness);

}  // namespace facecap::textures

#endif  // FACECAP_TEXTURES_COMPRESS_STRETCH_H_
