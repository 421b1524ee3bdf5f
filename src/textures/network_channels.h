// What the expression texture networks (nn/texture_net.h, paper 001 Fig. 7) see and predict,
// made from meshes and skin maps: channels-first [C, S, S] arrays over a rig's S x S UV layout
// (textures/influence.h), zero where the layout has no triangle.
//
//   person      (9): the neutral's albedo R, G, B (linear), specular, displacement (mm); the
//                    neutral geometry image, the person's neutral minus the template's under
//                    each texel (cm); coverage (1 where a triangle covers the texel)
//   expression  (5): the offset geometry image, expression minus neutral (cm); eq. 10-11's
//                    compress and stretch influence (cm)
//   outputs     (6): the expression's maps minus the neutral's: albedo R, G, B, specular, and
//                    displacement split into a low-frequency part (a Gaussian blur of it) and
//                    the high-frequency rest, which sum to it
// Skin maps are S x S x 5 interleaved (io/dynamic_texture_file.h's channels).
//
// The networks see the channels normalized: ChannelNormalization subtracts a mean and divides
// by a scale per channel, fitted on the training people over covered texels.
#ifndef FACECAP_TEXTURES_NETWORK_CHANNELS_H_
#define FACECAP_TEXTURES_NETWORK_CHANNELS_H_

#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"
#include "textures/influence.h"

namespace facecap::textures {

inline constexpr int kPersonChannels = 9;
inline constexpr int kExpressionChannels = 5;
inline constexpr int kOutputChannels = 6;

std::vector<float> PersonChannels(const TexelInterpolator& texels, const rig::Vertices& neutral,
                                  const rig::Vertices& template_neutral, const std::vector<float>& neutral_maps);

std::vector<float> ExpressionChannels(const TexelInterpolator& texels, const OneRing& ring,
                                      const Eigen::VectorXf& e_neutral, const rig::Vertices& neutral,
                                      const rig::Vertices& expression);

// sigma: the low-frequency blur's standard deviation in texels.
std::vector<float> OutputChannels(const std::vector<float>& neutral_maps, const std::vector<float>& expression_maps,
                                  int size, float sigma);

// The expression's skin maps from the neutral's and the outputs (un-normalized).
std::vector<float> ExpressionMapsFromOutputs(const std::vector<float>& neutral_maps, const float* outputs, int size);

// Per channel: x' = (x - mean) / scale on covered texels, 0 elsewhere.
struct ChannelNormalization {
  std::vector<float> mean, scale;  // one per channel

  // Mean and RMS deviation of each channel over the covered texels (coverage: S x S, nonzero
  // where covered) of `arrays` ([C, S, S] each), in double. centered: subtract the mean (else
  // the mean is 0 and the scale the RMS, so that 0 stays "no change").
  static ChannelNormalization Fit(const std::vector<const float*>& arrays, int channels, const float* coverage,
                                  int size, const std::vector<bool>& centered);
  void Apply(float* channels_first, const float* coverage, int size) const;
  // The inverse on covered texels, 0 elsewhere.
  void Invert(float* channels_first, const float* coverage, int size) const;
};

}  // namespace facecap::textures

#endif  // FACECAP_TEXTURES_NETWORK_CHANNELS_H_
