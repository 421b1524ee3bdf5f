#include "textures/compress_stretch.h"

#include <algorithm>
#include <cmath>
#include <string>

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
  out.compress = BlendTextures(NormalizeInfluence(influence_maps, n, 2, 0, sharpness), textures, n, channels);
  out.stretch = BlendTextures(NormalizeInfluence(influence_maps, n, 2, 1, sharpness), textures, n, channels);
  return out;
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

DynamicTexture DynamicTextureForRig(const rig::Rig& rig, int size, int channels, std::vector<float> neutral,
                                    const CompressStretchMaps& maps, const std::vector<float>& vertex_influence,
                                    float sharpness) {
  const int N = rig.NumShapes(), V = rig.NumVertices();
  if (vertex_influence.size() != static_cast<size_t>(N) * V * 2) {
    throw InvalidInputError("dynamic texture: the influences are not " + std::to_string(N) + " shapes x " +
                            std::to_string(V) + " vertices x 2");
  }
  const TexelInterpolator texels(rig, size);
  std::vector<std::vector<float>> texel_maps;
  for (int i = 0; i < N; ++i) {
    VertexInfluence inf;
    inf.compress.resize(V);
    inf.stretch.resize(V);
    for (int v = 0; v < V; ++v) {
      inf.compress[v] = vertex_influence[(static_cast<size_t>(i) * V + v) * 2];
      inf.stretch[v] = vertex_influence[(static_cast<size_t>(i) * V + v) * 2 + 1];
    }
    texel_maps.push_back(InfluenceMap(texels, inf));
  }
  std::vector<const float*> pointers;
  for (const auto& m : texel_maps) pointers.push_back(m.data());
  return DynamicTexture(static_cast<size_t>(size) * size, channels, std::move(neutral), maps, pointers, sharpness);
}

}  // namespace facecap::textures
