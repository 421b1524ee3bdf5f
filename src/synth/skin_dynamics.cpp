#include "synth/skin_dynamics.h"

#include <algorithm>
#include <cmath>

#include "synth/noise.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {

namespace {

float Ease(float x, float scale) {
  const float t = std::clamp(x / scale, 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

// The person's wrinkle pattern at p (cm on the neutral head): sharp ridges along the zero
// set of value noise stretched sideways, so lines run mostly horizontally.
float Ridge(const Eigen::Vector3f& p, const SkinDynamics& skin) {
  const float f = skin.wrinkle_frequency;
  const float n = ValueNoise(0.3f * f * p.x(), f * p.y(), 0.3f * f * p.z(), skin.seed);
  return std::pow(1.f - std::abs(n), 6.f);
}

}  // namespace

SkinDynamics DrawSkinDynamics(uint64_t seed) {
  Rng rng(seed, 0x5C1Du);
  SkinDynamics s;
  s.age = static_cast<float>(rng.Uniform());
  s.wrinkle_depth_mm = 0.2f + 0.8f * s.age;
  s.wrinkle_frequency = 2.2f - 1.0f * s.age + static_cast<float>(rng.Uniform(-0.2, 0.2));
  s.flush = static_cast<float>(rng.Uniform());
  s.blanch = static_cast<float>(rng.Uniform());
  s.seed = static_cast<uint32_t>(rng.NextU64());
  return s;
}

std::vector<float> NeutralSkinMaps(const rig::Rig& head, const textures::TexelInterpolator& texels,
                                   const PersonColors& colors, const SkinDynamics& skin, uint64_t seed) {
  SkinTextureOptions o;
  o.texture_size = texels.size();
  o.cheek_redness = 0.15f + 0.4f * skin.flush;
  const ImageF albedo = MakeSkinTexture(head, colors, seed, o);
  const int n = texels.NumTexels();
  std::vector<float> maps(static_cast<size_t>(n) * kSkinChannels, 0.f);
  for (int t = 0; t < n; ++t) {
    const int x = t % texels.size(), y = t / texels.size();
    float* m = &maps[static_cast<size_t>(t) * kSkinChannels];
    for (int c = 0; c < 3; ++c) m[c] = albedo.at(x, y, c);
    const Eigen::Vector3f& p = texels.positions()[t];
    if (!texels.Covered(t)) {
      m[3] = 0.3f;
      continue;
    }
    const float r = Ridge(p, skin);
    const float line = 0.15f * skin.wrinkle_depth_mm * r;
    for (int c = 0; c < 3; ++c) m[c] *= 1.f - 0.35f * 0.15f * r;
    m[3] = std::clamp(0.3f + 0.12f * Fbm(p, 0.4f, 2, skin.seed + 7u), 0.f, 1.f);
    m[4] = 0.03f * ValueNoise(6.f * p.x(), 6.f * p.y(), 6.f * p.z(), skin.seed + 11u) - line;
  }
  return maps;
}

void RelativeStrain(const textures::OneRing& ring, const textures::TexelInterpolator& texels,
                    const Eigen::VectorXf& e_neutral, const rig::Vertices& expression,
                    std::vector<float>* compress, std::vector<float>* stretch) {
  const Eigen::VectorXf ep = textures::MeanEdgeLength(ring, expression);
  const Eigen::VectorXf safe = e_neutral.cwiseMax(1e-6f);
  const Eigen::VectorXf rel = (ep - e_neutral).cwiseQuotient(safe);
  *compress = texels.Interpolate(Eigen::VectorXf((-rel).cwiseMax(0.f)));
  *stretch = texels.Interpolate(Eigen::VectorXf(rel.cwiseMax(0.f)));
}

std::vector<float> ExpressionSkinMaps(const std::vector<float>& neutral, const textures::TexelInterpolator& texels,
                                      const SkinDynamics& skin, const std::vector<float>& compress,
                                      const std::vector<float>& stretch, float strain_scale) {
  const size_t n = static_cast<size_t>(texels.NumTexels());
  if (neutral.size() != n * kSkinChannels || compress.size() != n || stretch.size() != n) {
    throw InvalidInputError("expression skin maps: neutral or strain maps of the wrong size");
  }
  static const float kFlush[3] = {0.15f, -0.03f, -0.03f};
  static const float kBlanch[3] = {0.12f, -0.02f, -0.02f};
  std::vector<float> out = neutral;
  for (size_t t = 0; t < n; ++t) {
    if (!texels.Covered(static_cast<int>(t))) continue;
    const float c = Ease(compress[t], strain_scale), s = Ease(stretch[t], strain_scale);
    if (c == 0.f && s == 0.f) continue;
    const float r = Ridge(texels.positions()[t], skin);
    float* m = &out[t * kSkinChannels];
    for (int k = 0; k < 3; ++k) {
      m[k] = std::clamp(m[k] * (1.f - 0.35f * c * r) * (1.f + skin.flush * c * kFlush[k]) *
                            (1.f - skin.blanch * s * kBlanch[k]),
                        0.f, 1.f);
    }
    m[3] = std::clamp(m[3] * (1.f + 0.6f * s) * (1.f - 0.5f * c * r), 0.f, 1.f);
    m[4] = m[4] * (1.f - 0.6f * s) - skin.wrinkle_depth_mm * c * r;
  }
  return out;
}

}  // namespace facecap::synth
