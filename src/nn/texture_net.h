// The expression texture networks of paper 001 Sec. 5.2 (Fig. 7): a cascade of two
// encoder / residual blocks / decoder networks in UV space. The first predicts an
// expression's albedo offset from the person's neutral maps and geometry image and the
// expression's offset geometry image; the second predicts the specular and the low- and
// high-frequency displacement offsets from the same inputs plus the first's prediction.
//
// Each network: a 3x3 convolution at full resolution, two stride-2 convolutions down to a
// quarter, residual blocks, and two nearest-upsampling convolutions back, each joined by the
// encoder's features at its resolution (U-Net skips, so that a wrinkle's texel-scale pattern
// reaches the output), then a 1x1 output convolution that starts at zero (the networks start
// at "no change from the neutral").
//
// Torch stays in texture_net.cpp; this header takes plain arrays, channels-first [C, S, S],
// already normalized by the caller. Training follows facecap's data-parallel pattern: each
// rank's Backward on its share of a step, the controller sums GradientBuffer() over the ranks,
// and OptimizerStep applies Adam, bitwise the same on every rank.
#ifndef FACECAP_NN_TEXTURE_NET_H_
#define FACECAP_NN_TEXTURE_NET_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace facecap::nn {

struct TextureNetOptions {
  int channels = 16;            // feature channels at full resolution (x2, x4 deeper)
  int residual_blocks = 3;      // residual blocks at quarter resolution
  float learning_rate = 5e-4f;  // Adam step size
  int seed = 1;                 // parameter initialization seed

  template <class V>
  void Visit(V&& v) {
    v("channels", channels, "feature channels of each network at full resolution (doubled twice deeper)");
    v("residual_blocks", residual_blocks, "residual blocks of each network at quarter resolution");
    v("learning_rate", learning_rate, "Adam step size");
    v("net_seed", seed, "parameter initialization seed");
  }
  bool Check(std::string* why) const;
};

// One training example: a person's channels, one expression's channels and the targets, each
// [C, S, S]; `mask` [S, S] weighs each texel's loss (1 where the UV layout covers it).
struct TextureExample {
  const float* person = nullptr;      // kPersonChannels
  const float* expression = nullptr;  // kExpressionChannels
  const float* target = nullptr;      // kOutputChannels: the first network's, then the second's
  const float* mask = nullptr;
};

class TextureNets {
 public:
  static constexpr int kPersonChannels = 9;      // neutral albedo RGB, specular, displacement, geometry xyz, coverage
  static constexpr int kExpressionChannels = 5;  // offset geometry xyz, compress and stretch influence
  static constexpr int kAlbedoChannels = 3;      // the first network's outputs
  static constexpr int kDetailChannels = 3;      // the second's: specular, displacement low and high frequency
  static constexpr int kOutputChannels = kAlbedoChannels + kDetailChannels;

  // size: S, a multiple of 4.
  TextureNets(const TextureNetOptions& options, int size);
  ~TextureNets();
  TextureNets(const TextureNets&) = delete;
  TextureNets& operator=(const TextureNets&) = delete;

  int size() const;
  int64_t NumParameters() const;
  // Forward and backward of the masked L1 loss over `batch` (both networks; the second sees
  // the first's prediction as it will at inference, without a gradient into the first),
  // times loss_scale (use 1 / global batch size); gradients replace GradientBuffer().
  // losses[0], [1]: the two networks' unscaled mean L1 per covered texel and channel, summed
  // over the batch.
  void Backward(const std::vector<TextureExample>& batch, float loss_scale, double losses[2]);
  float* GradientBuffer();
  // Adam on GradientBuffer().
  void OptimizerStep();

  // Parameters, Adam moments and the step count (a checkpoint), and back.
  std::vector<float> State() const;
  void SetState(const std::vector<float>& state);
  std::vector<float> Parameters() const;
  void SetParameters(const std::vector<float>& parameters);

  // The outputs [kOutputChannels, S, S] for one person and expression; safe to call from
  // several threads.
  std::vector<float> Predict(const float* person, const float* expression) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::nn

#endif  // FACECAP_NN_TEXTURE_NET_H_
