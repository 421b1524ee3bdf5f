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
//
// The runtime facecap uses, the strain texture, blends the same maps by how much the skin is
// compressed or stretched now: with I(x) the eq. 10-11 influence of the current mesh (the rig
// at the frame's weights) against the neutral, and R(x) the influence T_C or T_S was captured
// at (eq. 13 applied to the expressions' influences, R_C = sum_i I^_i,compress I_i,compress),
//   T = T_N + w_C (T_C - T_N) + w_S (T_S - T_N),   w = min(kMaxStrainWeight, I / R)
// (w = 0 where R is 0). FitCompressStretch makes T_C and T_S for it: per texel, the two maps
// that best reproduce the expressions' textures under their own strain weights (least squares,
// held near eq. 13's maps where the expressions say little).
#ifndef FACECAP_TEXTURES_COMPRESS_STRETCH_H_
#define FACECAP_TEXTURES_COMPRESS_STRETCH_H_

#include <cstddef>
#include <cstdint>
#include <memory>
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
  std::vector<float> reference;  // n x 2: R_C, R_S, the influence T_C and T_S stand for
};
// Eq. 12-13 from the expressions' influence maps (n x 2 each) and textures (n x channels), and
// the reference influences.
CompressStretchMaps ExtractCompressStretch(const std::vector<const float*>& influence_maps,
                                           const std::vector<const float*>& textures, size_t n,
                                           int channels, float sharpness);

// The strain weights saturate at this multiple of the reference influence.
inline constexpr float kMaxStrainWeight = 1.5f;

// T_C and T_S for the strain texture: eq. 12-13's references, then per texel the least-squares
// maps under the expressions' strain weights; `neutral` is T_N (n x channels).
CompressStretchMaps FitCompressStretch(const std::vector<const float*>& influence_maps,
                                       const std::vector<const float*>& textures, const std::vector<float>& neutral,
                                       size_t n, int channels, float sharpness);

// The strain texture at runtime (see the top of this file).
class StrainTexture {
 public:
  // neutral, maps.compress, maps.stretch: n x channels; maps.reference: n x 2.
  StrainTexture(size_t n, int channels, std::vector<float> neutral, const CompressStretchMaps& maps);

  size_t NumTexels() const { return n_; }
  int channels() const { return channels_; }
  const std::vector<float>& neutral() const { return neutral_; }

  // out: n x channels; influence: the current mesh's eq. 10-11 map, n x 2.
  void Evaluate(const float* influence, float* out) const;
  std::vector<float> Evaluate(const std::vector<float>& influence) const;

 private:
  size_t n_ = 0;
  int channels_ = 0;
  std::vector<float> neutral_;
  std::vector<float> compress_delta_;  // T_C - T_N
  std::vector<float> stretch_delta_;   // T_S - T_N
  std::vector<float> inverse_reference_;  // n x 2: 1 / R, 0 where R is 0
};

// The strain texture of a rig: each weight vector's mesh (the rig's shapes and jaw, unposed)
// gives the influence against the rig's neutral, interpolated over its size x size UV layout.
class RigStrainTexture {
 public:
  RigStrainTexture(const rig::Rig& rig, int size, int channels, std::vector<float> neutral,
                   const CompressStretchMaps& maps);
  ~RigStrainTexture();
  RigStrainTexture(const RigStrainTexture&) = delete;
  RigStrainTexture& operator=(const RigStrainTexture&) = delete;

  // n x channels for one weight per rig shape.
  std::vector<float> Evaluate(const std::vector<float>& weights) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Eq. 14 as the paper prints it, at runtime. The blendshapes' normalized influences are kept sparse: with
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


}  // namespace facecap::textures

#endif  // FACECAP_TEXTURES_COMPRESS_STRETCH_H_
