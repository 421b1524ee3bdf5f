// Expression-dependent skin detail for the textured scan database (paper 001 Sec. 5): the
// truth that expression texture networks learn and dynamic textures are scored against.
//
// A person's skin maps are five interleaved channels per texel of the rig's UV layout:
// albedo R, G, B (linear), specular intensity in [0, 1], displacement in mm along the normal.
// An expression changes them by the skin's local strain: with E_N(x), E_P(x) the one-ring
// mean edge lengths on the neutral and the expression (textures/influence.h), the relative
// compression c_rel = max(0, (E_N - E_P) / E_N) and stretch s_rel = max(0, (E_P - E_N) /
// E_N) are interpolated per texel and eased, c = smoothstep(0, strain_scale, c_rel) (s
// likewise), and
//   displacement = D_N (1 - 0.6 s) - depth c r(p)            (wrinkles open, pores flatten)
//   albedo       = A_N (1 - 0.35 c r(p)) (1 + flush c k_f) (1 - blanch s k_b)
//   specular     = S_N (1 + 0.6 s) (1 - 0.5 c r(p))
// where r(p) in [0, 1] is the person's wrinkle pattern: ridges of 3D value noise at the
// texel's point p on the neutral head, mostly horizontal, with the person's frequency;
// k_f = (0.15, -0.03, -0.03) reddens (blood pooling), k_b = (0.12, -0.02, -0.02) pales
// (blood pushed out). The person decides depth, frequency, flush and blanch, and the
// neutral shows them: faint static lines of depth 0.15 depth r(p) in D_N and redder cheeks
// with more flush, so a network that sees the neutral maps can predict the expressions'.
#ifndef FACECAP_SYNTH_SKIN_DYNAMICS_H_
#define FACECAP_SYNTH_SKIN_DYNAMICS_H_

#include <cstdint>
#include <vector>

#include "rig/rig.h"
#include "synth/appearance.h"
#include "textures/influence.h"

namespace facecap::synth {

constexpr int kSkinChannels = 5;  // albedo R, G, B, specular, displacement (mm)

struct SkinDynamics {
  float age = 0.5f;                // [0, 1]; sets depth and frequency
  float wrinkle_depth_mm = 0.5f;   // depth of a fully compressed wrinkle
  float wrinkle_frequency = 1.5f;  // ridges per cm across the lines
  float flush = 0.5f;              // reddening where compressed, [0, 1]
  float blanch = 0.5f;             // paling where stretched, [0, 1]
  uint32_t seed = 0;               // wrinkle pattern and pores
  static constexpr int kNumParameters = 5;  // age, depth, frequency, flush, blanch
};

// A person's skin dynamics drawn from `seed`.
SkinDynamics DrawSkinDynamics(uint64_t seed);

// The neutral maps (size^2 x kSkinChannels) of a person with `colors` on `texels`' layout;
// `head` is the rig the layout was baked from (MakeSkinTexture's needs). `seed` drives the
// albedo's noise.
std::vector<float> NeutralSkinMaps(const rig::Rig& head, const textures::TexelInterpolator& texels,
                                   const PersonColors& colors, const SkinDynamics& skin, uint64_t seed);

// Per-texel relative compression and stretch of `expression` against the neutral whose
// mean edge lengths are `e_neutral`.
void RelativeStrain(const textures::OneRing& ring, const textures::TexelInterpolator& texels,
                    const Eigen::VectorXf& e_neutral, const rig::Vertices& expression,
                    std::vector<float>* compress, std::vector<float>* stretch);

// The expression's maps from the neutral maps and its per-texel relative strain.
std::vector<float> ExpressionSkinMaps(const std::vector<float>& neutral, const textures::TexelInterpolator& texels,
                                      const SkinDynamics& skin, const std::vector<float>& compress,
                                      const std::vector<float>& stretch, float strain_scale = 0.3f);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_SKIN_DYNAMICS_H_
