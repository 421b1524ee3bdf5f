#include "textures/network_channels.h"

#include <algorithm>
#include <cmath>

#include "util/errors.h"

namespace facecap::textures {
namespace {

constexpr int kMapChannels = 5;

// Separable Gaussian blur of an S x S channel, with the kernel renormalized over the texels
// inside the image.
std::vector<float> Blur(const std::vector<float>& in, int S, float sigma) {
  const int r = std::max(1, static_cast<int>(std::ceil(3.f * sigma)));
  std::vector<float> kernel(2 * r + 1);
  for (int k = -r; k <= r; ++k) kernel[k + r] = std::exp(-0.5f * k * k / (sigma * sigma));
  std::vector<float> tmp(in.size()), out(in.size());
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<float>& src = pass == 0 ? in : tmp;
    std::vector<float>& dst = pass == 0 ? tmp : out;
    for (int y = 0; y < S; ++y) {
      for (int x = 0; x < S; ++x) {
        double sum = 0, weight = 0;
        for (int k = -r; k <= r; ++k) {
          const int xx = pass == 0 ? x + k : x, yy = pass == 0 ? y : y + k;
          if (xx < 0 || yy < 0 || xx >= S || yy >= S) continue;
          sum += kernel[k + r] * src[static_cast<size_t>(yy) * S + xx];
          weight += kernel[k + r];
        }
        dst[static_cast<size_t>(y) * S + x] = static_cast<float>(sum / weight);
      }
    }
  }
  return out;
}

void CheckMaps(const std::vector<float>& maps, int S, const char* what) {
  if (maps.size() != static_cast<size_t>(S) * S * kMapChannels) {
    throw InvalidInputError(std::string("texture network channels: ") + what + " are not " + std::to_string(S) + "^2 x " +
                            std::to_string(kMapChannels) + " floats");
  }
}

}  // namespace

std::vector<float> PersonChannels(const TexelInterpolator& texels, const rig::Vertices& neutral,
                                  const rig::Vertices& template_neutral, const std::vector<float>& neutral_maps) {
  const int S = texels.size();
  const size_t n = static_cast<size_t>(S) * S;
  CheckMaps(neutral_maps, S, "the neutral maps");
  std::vector<float> out(kPersonChannels * n, 0.f);
  for (size_t t = 0; t < n; ++t) {
    if (!texels.Covered(static_cast<int>(t))) continue;
    for (int c = 0; c < kMapChannels; ++c) out[c * n + t] = neutral_maps[t * kMapChannels + c];
    out[8 * n + t] = 1.f;
  }
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXf d = neutral.col(c) - template_neutral.col(c);
    texels.Interpolate(d, out.data() + (5 + c) * n);
  }
  return out;
}

std::vector<float> ExpressionChannels(const TexelInterpolator& texels, const OneRing& ring,
                                      const Eigen::VectorXf& e_neutral, const rig::Vertices& neutral,
                                      const rig::Vertices& expression) {
  const int S = texels.size();
  const size_t n = static_cast<size_t>(S) * S;
  std::vector<float> out(kExpressionChannels * n, 0.f);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXf d = expression.col(c) - neutral.col(c);
    texels.Interpolate(d, out.data() + c * n);
  }
  const VertexInfluence influence = InfluenceValues(e_neutral, MeanEdgeLength(ring, expression));
  texels.Interpolate(influence.compress, out.data() + 3 * n);
  texels.Interpolate(influence.stretch, out.data() + 4 * n);
  return out;
}

std::vector<float> OutputChannels(const std::vector<float>& neutral_maps, const std::vector<float>& expression_maps,
                                  int S, float sigma) {
  CheckMaps(neutral_maps, S, "the neutral maps");
  CheckMaps(expression_maps, S, "the expression maps");
  const size_t n = static_cast<size_t>(S) * S;
  std::vector<float> out(kOutputChannels * n);
  std::vector<float> displacement(n);
  for (size_t t = 0; t < n; ++t) {
    for (int c = 0; c < 4; ++c) out[c * n + t] = expression_maps[t * kMapChannels + c] - neutral_maps[t * kMapChannels + c];
    displacement[t] = expression_maps[t * kMapChannels + 4] - neutral_maps[t * kMapChannels + 4];
  }
  const std::vector<float> low = Blur(displacement, S, sigma);
  for (size_t t = 0; t < n; ++t) {
    out[4 * n + t] = low[t];
    out[5 * n + t] = displacement[t] - low[t];
  }
  return out;
}

std::vector<float> ExpressionMapsFromOutputs(const std::vector<float>& neutral_maps, const float* outputs, int S) {
  CheckMaps(neutral_maps, S, "the neutral maps");
  const size_t n = static_cast<size_t>(S) * S;
  std::vector<float> maps = neutral_maps;
  for (size_t t = 0; t < n; ++t) {
    for (int c = 0; c < 4; ++c) maps[t * kMapChannels + c] += outputs[c * n + t];
    maps[t * kMapChannels + 4] += outputs[4 * n + t] + outputs[5 * n + t];
  }
  return maps;
}

ChannelNormalization ChannelNormalization::Fit(const std::vector<const float*>& arrays, int channels,
                                               const float* coverage, int S, const std::vector<bool>& centered) {
  if (static_cast<int>(centered.size()) != channels) throw InvalidInputError("channel normalization: one flag per channel");
  const size_t n = static_cast<size_t>(S) * S;
  ChannelNormalization out;
  for (int c = 0; c < channels; ++c) {
    double sum = 0, sum2 = 0, count = 0;
    for (const float* a : arrays) {
      for (size_t t = 0; t < n; ++t) {
        if (coverage[t] == 0.f) continue;
        const double v = a[c * n + t];
        sum += v;
        sum2 += v * v;
        count += 1;
      }
    }
    const double mean = centered[c] && count > 0 ? sum / count : 0.0;
    const double var = count > 0 ? sum2 / count - (centered[c] ? mean * mean : 0.0) : 0.0;
    out.mean.push_back(static_cast<float>(mean));
    out.scale.push_back(static_cast<float>(std::sqrt(std::max(var, 0.0)) + 1e-6));
  }
  return out;
}

void ChannelNormalization::Apply(float* x, const float* coverage, int S) const {
  const size_t n = static_cast<size_t>(S) * S;
  for (size_t c = 0; c < mean.size(); ++c) {
    for (size_t t = 0; t < n; ++t) x[c * n + t] = coverage[t] != 0.f ? (x[c * n + t] - mean[c]) / scale[c] : 0.f;
  }
}

void ChannelNormalization::Invert(float* x, const float* coverage, int S) const {
  const size_t n = static_cast<size_t>(S) * S;
  for (size_t c = 0; c < mean.size(); ++c) {
    for (size_t t = 0; t < n; ++t) x[c * n + t] = coverage[t] != 0.f ? x[c * n + t] * scale[c] + mean[c] : 0.f;
  }
}

}  // namespace facecap::textures
