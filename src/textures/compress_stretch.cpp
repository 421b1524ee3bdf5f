#include "textures/compress_stretch.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "rig/evaluate.h"
#include "textures/influence.h"
#include "util/errors.h"

namespace facecap::textures {

std::vector<std::vector<float>> NormalizeInfluence(const std::vector<const float*>& maps, size_t n,
                                                   int stride, int channel, float sharpness) {
  const size_t M = maps.size();
  if (M == 0) throw InvalidInputError("influence normalization: no maps");
  std::vector<std::vector<float>> out(M, std::vector<float>(n));
  std::vector<double> e(M);
  for (size_t t = 0; t < n; ++t) {
    double m = -1e300;
    for (size_t i = 0; i < M; ++i) m = std::max(m, static_cast<double>(sharpness) * maps[i][t * stride + channel]);
    double z = 0;
    for (size_t i = 0; i < M; ++i) {
      e[i] = std::exp(static_cast<double>(sharpness) * maps[i][t * stride + channel] - m);
      z += e[i];
    }
    for (size_t i = 0; i < M; ++i) out[i][t] = static_cast<float>(e[i] / z);
  }
  return out;
}

std::vector<float> BlendTextures(const std::vector<std::vector<float>>& weights,
                                 const std::vector<const float*>& textures, size_t n, int channels) {
  if (weights.size() != textures.size()) throw InvalidInputError("blend: as many weight maps as textures needed");
  std::vector<float> out(n * channels, 0.f);
  for (size_t i = 0; i < textures.size(); ++i) {
    const float* w = weights[i].data();
    const float* tex = textures[i];
    for (size_t t = 0; t < n; ++t) {
      for (int c = 0; c < channels; ++c) out[t * channels + c] += w[t] * tex[t * channels + c];
    }
  }
  return out;
}

CompressStretchMaps ExtractCompressStretch(const std::vector<const float*>& influence_maps,
                                           const std::vector<const float*>& textures, size_t n,
                                           int channels, float sharpness) {
  if (influence_maps.size() != textures.size() || textures.empty()) {
    throw InvalidInputError("compress and stretch maps need one influence map per expression texture");
  }
  CompressStretchMaps out;
  const auto compress_weights = NormalizeInfluence(influence_maps, n, 2, 0, sharpness);
  const auto stretch_weights = NormalizeInfluence(influence_maps, n, 2, 1, sharpness);
  out.compress = BlendTextures(compress_weights, textures, n, channels);
  out.stretch = BlendTextures(stretch_weights, textures, n, channels);
  out.reference.assign(2 * n, 0.f);
  for (size_t i = 0; i < influence_maps.size(); ++i) {
    for (size_t t = 0; t < n; ++t) {
      out.reference[2 * t] += compress_weights[i][t] * influence_maps[i][2 * t];
      out.reference[2 * t + 1] += stretch_weights[i][t] * influence_maps[i][2 * t + 1];
    }
  }
  return out;
}

namespace {

// Below this reference influence (cm) a texel has no compress or stretch detail.
constexpr float kMinReference = 1e-4f;

float StrainWeight(float influence, float inverse_reference) {
  return std::min(kMaxStrainWeight, influence * inverse_reference);
}

float InverseReference(float reference) { return reference > kMinReference ? 1.f / reference : 0.f; }

}  // namespace

CompressStretchMaps FitCompressStretch(const std::vector<const float*>& influence_maps,
                                       const std::vector<const float*>& textures, const std::vector<float>& neutral,
                                       size_t n, int channels, float sharpness) {
  CompressStretchMaps out = ExtractCompressStretch(influence_maps, textures, n, channels, sharpness);
  if (neutral.size() != n * channels) {
    throw InvalidInputError("compress and stretch fit: the neutral texture is not " + std::to_string(n) +
                            " texels x " + std::to_string(channels) + " channels");
  }
  // Per texel and channel, d_C and d_S minimize
  //   sum_k (T_k - T_N - w_C,k d_C - w_S,k d_S)^2 + ridge (|d_C - e_C|^2 + |d_S - e_S|^2)
  // with e the eq. 13 maps' offsets from T_N: a 2 x 2 system shared by the channels.
  constexpr double kRidge = 1e-3;
  const size_t K = textures.size();
  std::vector<double> b_c(channels), b_s(channels);
  for (size_t t = 0; t < n; ++t) {
    const float inv_c = InverseReference(out.reference[2 * t]), inv_s = InverseReference(out.reference[2 * t + 1]);
    double a_cc = kRidge, a_cs = 0., a_ss = kRidge;
    for (int c = 0; c < channels; ++c) {
      const size_t k = t * channels + c;
      b_c[c] = kRidge * (out.compress[k] - neutral[k]);
      b_s[c] = kRidge * (out.stretch[k] - neutral[k]);
    }
    for (size_t e = 0; e < K; ++e) {
      const double w_c = StrainWeight(influence_maps[e][2 * t], inv_c);
      const double w_s = StrainWeight(influence_maps[e][2 * t + 1], inv_s);
      a_cc += w_c * w_c;
      a_cs += w_c * w_s;
      a_ss += w_s * w_s;
      for (int c = 0; c < channels; ++c) {
        const size_t k = t * channels + c;
        const double d = static_cast<double>(textures[e][k]) - neutral[k];
        b_c[c] += w_c * d;
        b_s[c] += w_s * d;
      }
    }
    const double det = a_cc * a_ss - a_cs * a_cs;
    for (int c = 0; c < channels; ++c) {
      const size_t k = t * channels + c;
      out.compress[k] = neutral[k] + static_cast<float>((a_ss * b_c[c] - a_cs * b_s[c]) / det);
      out.stretch[k] = neutral[k] + static_cast<float>((a_cc * b_s[c] - a_cs * b_c[c]) / det);
    }
  }
  return out;
}

StrainTexture::StrainTexture(size_t n, int channels, std::vector<float> neutral, const CompressStretchMaps& maps)
    : n_(n), channels_(channels), neutral_(std::move(neutral)) {
  const size_t size = n * channels;
  if (neutral_.size() != size || maps.compress.size() != size || maps.stretch.size() != size) {
    throw InvalidInputError("strain texture: neutral, compress and stretch maps must be " + std::to_string(n) +
                            " texels x " + std::to_string(channels) + " channels");
  }
  if (maps.reference.size() != 2 * n) {
    throw InvalidInputError("strain texture: the reference influence must be " + std::to_string(n) + " texels x 2");
  }
  compress_delta_.resize(size);
  stretch_delta_.resize(size);
  for (size_t k = 0; k < size; ++k) {
    compress_delta_[k] = maps.compress[k] - neutral_[k];
    stretch_delta_[k] = maps.stretch[k] - neutral_[k];
  }
  inverse_reference_.resize(2 * n);
  for (size_t k = 0; k < 2 * n; ++k) inverse_reference_[k] = InverseReference(maps.reference[k]);
}

void StrainTexture::Evaluate(const float* influence, float* out) const {
  const int C = channels_;
  for (size_t t = 0; t < n_; ++t) {
    const float a = StrainWeight(influence[2 * t], inverse_reference_[2 * t]);
    const float b = StrainWeight(influence[2 * t + 1], inverse_reference_[2 * t + 1]);
    for (int c = 0; c < C; ++c) {
      const size_t k = t * C + c;
      out[k] = neutral_[k] + a * compress_delta_[k] + b * stretch_delta_[k];
    }
  }
}

std::vector<float> StrainTexture::Evaluate(const std::vector<float>& influence) const {
  if (influence.size() != 2 * n_) {
    throw InvalidInputError("strain texture: an influence map of " + std::to_string(influence.size() / 2) +
                            " texels for " + std::to_string(n_));
  }
  std::vector<float> out(n_ * channels_);
  Evaluate(influence.data(), out.data());
  return out;
}

struct RigStrainTexture::Impl {
  rig::Rig rig;
  TexelInterpolator texels;
  OneRing ring;
  Eigen::VectorXf neutral_edges;
  StrainTexture texture;
};

RigStrainTexture::RigStrainTexture(const rig::Rig& rig, int size, int channels, std::vector<float> neutral,
                                   const CompressStretchMaps& maps) {
  OneRing ring = BuildOneRing(rig.triangles, rig.NumVertices());
  Eigen::VectorXf edges = MeanEdgeLength(ring, rig.neutral);
  impl_.reset(new Impl{rig, TexelInterpolator(rig, size), std::move(ring), std::move(edges),
                       StrainTexture(static_cast<size_t>(size) * size, channels, std::move(neutral), maps)});
}

RigStrainTexture::~RigStrainTexture() = default;

std::vector<float> RigStrainTexture::Evaluate(const std::vector<float>& weights) const {
  if (static_cast<int>(weights.size()) != impl_->rig.NumShapes()) {
    throw InvalidInputError("strain texture: " + std::to_string(weights.size()) + " weights for " +
                            std::to_string(impl_->rig.NumShapes()) + " shapes");
  }
  rig::Vertices mesh;
  rig::EvaluateShape(impl_->rig, Eigen::Map<const Eigen::VectorXf>(weights.data(), weights.size()), &mesh);
  const VertexInfluence now = InfluenceValues(impl_->neutral_edges, MeanEdgeLength(impl_->ring, mesh));
  return impl_->texture.Evaluate(InfluenceMap(impl_->texels, now));
}

DynamicTexture::DynamicTexture(size_t n, int channels, std::vector<float> neutral, const CompressStretchMaps& maps,
                               const std::vector<const float*>& blendshape_influence, float sharpness)
    : n_(n), channels_(channels), neutral_(std::move(neutral)) {
  const size_t size = n * channels;
  if (neutral_.size() != size || maps.compress.size() != size || maps.stretch.size() != size) {
    throw InvalidInputError("dynamic texture: neutral, compress and stretch maps must be " +
                            std::to_string(n) + " texels x " + std::to_string(channels) + " channels");
  }
  if (blendshape_influence.empty()) throw InvalidInputError("dynamic texture: no blendshape influence maps");
  compress_delta_.resize(size);
  stretch_delta_.resize(size);
  for (size_t k = 0; k < size; ++k) {
    compress_delta_[k] = maps.compress[k] - neutral_[k];
    stretch_delta_[k] = maps.stretch[k] - neutral_[k];
  }
  Build(blendshape_influence, 0, sharpness, &compress_base_, &compress_);
  Build(blendshape_influence, 1, sharpness, &stretch_base_, &stretch_);
}

void DynamicTexture::Build(const std::vector<const float*>& influence, int channel, float sharpness,
                           std::vector<float>* base, std::vector<Sparse>* sparse) const {
  const size_t M = influence.size();
  base->assign(n_, 0.f);
  sparse->assign(M, Sparse{});
  std::vector<double> e(M);
  for (size_t t = 0; t < n_; ++t) {
    double m = 0;  // max over b I_j, with the zero influences included
    for (size_t i = 0; i < M; ++i) m = std::max(m, static_cast<double>(sharpness) * influence[i][2 * t + channel]);
    const double zero_term = std::exp(-m);
    double z = 0;
    for (size_t i = 0; i < M; ++i) {
      const float I = influence[i][2 * t + channel];
      e[i] = I > 0.f ? std::exp(static_cast<double>(sharpness) * I - m) : zero_term;
      z += e[i];
    }
    (*base)[t] = static_cast<float>(zero_term / z);
    for (size_t i = 0; i < M; ++i) {
      if (influence[i][2 * t + channel] > 0.f) {
        (*sparse)[i].texel.push_back(static_cast<int32_t>(t));
        (*sparse)[i].value.push_back(static_cast<float>((e[i] - zero_term) / z));
      }
    }
  }
}

void DynamicTexture::Evaluate(const float* weights, float* out) const {
  double total = 0;
  for (int i = 0; i < NumBlendshapes(); ++i) total += weights[i];
  std::vector<float> wc(n_), ws(n_);
  const float sum = static_cast<float>(total);
  for (size_t t = 0; t < n_; ++t) {
    wc[t] = compress_base_[t] * sum;
    ws[t] = stretch_base_[t] * sum;
  }
  for (int i = 0; i < NumBlendshapes(); ++i) {
    const float a = weights[i];
    if (a == 0.f) continue;
    const Sparse& c = compress_[i];
    for (size_t k = 0; k < c.texel.size(); ++k) wc[c.texel[k]] += a * c.value[k];
    const Sparse& s = stretch_[i];
    for (size_t k = 0; k < s.texel.size(); ++k) ws[s.texel[k]] += a * s.value[k];
  }
  const int C = channels_;
  for (size_t t = 0; t < n_; ++t) {
    const float a = wc[t], b = ws[t];
    for (int c = 0; c < C; ++c) {
      const size_t k = t * C + c;
      out[k] = neutral_[k] + a * compress_delta_[k] + b * stretch_delta_[k];
    }
  }
}

std::vector<float> DynamicTexture::Evaluate(const std::vector<float>& weights) const {
  if (static_cast<int>(weights.size()) != NumBlendshapes()) {
    throw InvalidInputError("dynamic texture: " + std::to_string(weights.size()) + " weights for " +
                            std::to_string(NumBlendshapes()) + " blendshapes");
  }
  std::vector<float> out(n_ * channels_);
  Evaluate(weights.data(), out.data());
  return out;
}

size_t DynamicTexture::NumSparseEntries() const {
  size_t k = 0;
  for (const auto& s : compress_) k += s.texel.size();
  for (const auto& s : stretch_) k += s.texel.size();
  return k;
}

}  // namespace facecap::textures
