#include "nn/texture_net.h"

#include <algorithm>

#include <torch/torch.h>

#include "nn/parameter_vector.h"
#include "util/errors.h"

namespace facecap::nn {
namespace {

namespace F = torch::nn::functional;

torch::nn::Conv2d Conv(int in, int out, int kernel, int stride = 1) {
  return torch::nn::Conv2d(
      torch::nn::Conv2dOptions(in, out, kernel).stride(stride).padding(kernel == 4 ? 1 : kernel / 2));
}

torch::Tensor Upsample2(const torch::Tensor& t) {
  return F::interpolate(t, F::InterpolateFuncOptions().scale_factor(std::vector<double>{2, 2}).mode(torch::kNearest));
}

struct BlockImpl : torch::nn::Module {
  explicit BlockImpl(int c) {
    first = register_module("first", Conv(c, c, 3));
    second = register_module("second", Conv(c, c, 3));
  }
  torch::Tensor forward(const torch::Tensor& x) { return x + second->forward(torch::relu(first->forward(x))); }
  torch::nn::Conv2d first{nullptr}, second{nullptr};
};
TORCH_MODULE(Block);

// One network of the cascade (see the header).
struct ImageNetImpl : torch::nn::Module {
  ImageNetImpl(int in, int out, int c, int blocks) {
    e0 = register_module("e0", Conv(in, c, 3));
    e1 = register_module("e1", Conv(c, 2 * c, 4, 2));
    e2 = register_module("e2", Conv(2 * c, 4 * c, 4, 2));
    residual = register_module("residual", torch::nn::Sequential());
    for (int b = 0; b < blocks; ++b) residual->push_back(Block(4 * c));
    d1 = register_module("d1", Conv(4 * c + 2 * c, 2 * c, 3));
    d0 = register_module("d0", Conv(2 * c + c, c, 3));
    output = register_module("output", Conv(c, out, 1));
    torch::NoGradGuard no_grad;
    output->weight.zero_();
    output->bias.zero_();
  }
  torch::Tensor forward(const torch::Tensor& x) {
    const torch::Tensor f0 = torch::relu(e0->forward(x));
    const torch::Tensor f1 = torch::relu(e1->forward(f0));
    torch::Tensor y = torch::relu(e2->forward(f1));
    if (!residual->is_empty()) y = residual->forward(y);
    y = torch::relu(d1->forward(torch::cat({Upsample2(y), f1}, 1)));
    y = torch::relu(d0->forward(torch::cat({Upsample2(y), f0}, 1)));
    return output->forward(y);
  }
  torch::nn::Conv2d e0{nullptr}, e1{nullptr}, e2{nullptr}, d1{nullptr}, d0{nullptr}, output{nullptr};
  torch::nn::Sequential residual{nullptr};
};
TORCH_MODULE(ImageNet);

}  // namespace

bool TextureNetOptions::Check(std::string* why) const {
  if (channels < 1 || channels > 256) { *why = "channels must be in [1, 256]"; return false; }
  if (residual_blocks < 0 || residual_blocks > 32) { *why = "residual_blocks must be in [0, 32]"; return false; }
  if (!(learning_rate > 0.f && learning_rate < 1.f)) { *why = "learning_rate must be in (0, 1)"; return false; }
  return true;
}

struct TextureNets::Impl {
  TextureNetOptions options;
  int size = 0;
  ImageNet albedo{nullptr}, detail{nullptr};
  std::vector<torch::Tensor> parameters;
  int64_t num_parameters = 0;
  std::vector<float> gradient, adam_m, adam_v;
  int64_t steps = 0;

};

TextureNets::TextureNets(const TextureNetOptions& options, int size) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("texture networks: " + why);
  if (size < 8 || size % 4 != 0) throw InvalidInputError("texture networks: the size must be a multiple of 4, >= 8");
  Impl& m = *impl_;
  m.options = options;
  m.size = size;
  torch::manual_seed(static_cast<uint64_t>(options.seed));
  const int in = kPersonChannels + kExpressionChannels;
  m.albedo = ImageNet(in, kAlbedoChannels, options.channels, options.residual_blocks);
  m.detail = ImageNet(in + kAlbedoChannels, kDetailChannels, options.channels, options.residual_blocks);
  for (auto& p : m.albedo->parameters()) m.parameters.push_back(p);
  for (auto& p : m.detail->parameters()) m.parameters.push_back(p);
  for (auto& p : m.parameters) m.num_parameters += p.numel();
  m.gradient.assign(m.num_parameters, 0.f);
  m.adam_m.assign(m.num_parameters, 0.f);
  m.adam_v.assign(m.num_parameters, 0.f);
}

TextureNets::~TextureNets() = default;

int TextureNets::size() const { return impl_->size; }
int64_t TextureNets::NumParameters() const { return impl_->num_parameters; }
float* TextureNets::GradientBuffer() { return impl_->gradient.data(); }

void TextureNets::Backward(const std::vector<TextureExample>& batch, float loss_scale, double losses[2]) {
  Impl& m = *impl_;
  std::fill(m.gradient.begin(), m.gradient.end(), 0.f);
  losses[0] = losses[1] = 0;
  if (batch.empty()) return;
  for (auto& p : m.parameters) {
    if (p.grad().defined()) p.mutable_grad() = torch::Tensor();
  }
  const int64_t B = static_cast<int64_t>(batch.size()), S = m.size, n = S * S;
  const int in = kPersonChannels + kExpressionChannels;
  std::vector<float> inputs(static_cast<size_t>(B * in * n)), targets(static_cast<size_t>(B * kOutputChannels * n)),
      masks(static_cast<size_t>(B * n));
  for (int64_t b = 0; b < B; ++b) {
    const TextureExample& e = batch[b];
    float* x = inputs.data() + b * in * n;
    std::copy(e.person, e.person + kPersonChannels * n, x);
    std::copy(e.expression, e.expression + kExpressionChannels * n, x + kPersonChannels * n);
    std::copy(e.target, e.target + kOutputChannels * n, targets.data() + b * kOutputChannels * n);
    std::copy(e.mask, e.mask + n, masks.data() + b * n);
  }
  auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
  const torch::Tensor x = torch::from_blob(inputs.data(), {B, in, S, S}, f32);
  const torch::Tensor target = torch::from_blob(targets.data(), {B, kOutputChannels, S, S}, f32);
  const torch::Tensor mask = torch::from_blob(masks.data(), {B, 1, S, S}, f32);
  const torch::Tensor covered = mask.sum({1, 2, 3}).clamp_min(1.f);  // [B]
  auto masked_l1 = [&](const torch::Tensor& prediction, const torch::Tensor& truth) {
    return ((prediction - truth).abs() * mask).sum({1, 2, 3}) / (covered * static_cast<float>(truth.size(1)));
  };
  const torch::Tensor albedo = m.albedo->forward(x);
  const torch::Tensor detail = m.detail->forward(torch::cat({x, albedo.detach()}, 1));
  const torch::Tensor l_albedo = masked_l1(albedo, target.narrow(1, 0, kAlbedoChannels));
  const torch::Tensor l_detail = masked_l1(detail, target.narrow(1, kAlbedoChannels, kDetailChannels));
  const torch::Tensor loss = (l_albedo + l_detail).sum() * loss_scale;
  loss.backward();
  CopyGradients(m.parameters, m.gradient.data());
  losses[0] = l_albedo.sum().item<double>();
  losses[1] = l_detail.sum().item<double>();
}

void TextureNets::OptimizerStep() {
  Impl& m = *impl_;
  AdamStep step;
  step.step = ++m.steps;
  step.learning_rate = m.options.learning_rate;
  AdamOverTensors(step, &m.parameters, m.gradient.data(), m.adam_m.data(), m.adam_v.data(),
                  [](size_t) { return true; });
}

std::vector<float> TextureNets::Parameters() const { return FlattenParameters(impl_->parameters); }

void TextureNets::SetParameters(const std::vector<float>& parameters) {
  if (static_cast<int64_t>(parameters.size()) != impl_->num_parameters) {
    throw FileIOError("texture networks: " + std::to_string(parameters.size()) + " parameters given, the networks have " +
                      std::to_string(impl_->num_parameters));
  }
  SetFlatParameters(parameters, &impl_->parameters);
}

std::vector<float> TextureNets::State() const {
  return OptimizerState(impl_->parameters, impl_->adam_m, impl_->adam_v, impl_->steps);
}

void TextureNets::SetState(const std::vector<float>& state) {
  Impl& m = *impl_;
  if (!SetOptimizerState(state, &m.parameters, &m.adam_m, &m.adam_v, &m.steps)) {
    throw FileIOError("texture networks: checkpoint state has the wrong size");
  }
}

std::vector<float> TextureNets::Predict(const float* person, const float* expression) const {
  Impl& m = *impl_;
  const int64_t S = m.size, n = S * S;
  const int in = kPersonChannels + kExpressionChannels;
  std::vector<float> input(static_cast<size_t>(in * n));
  std::copy(person, person + kPersonChannels * n, input.data());
  std::copy(expression, expression + kExpressionChannels * n, input.data() + kPersonChannels * n);
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::from_blob(input.data(), {1, in, S, S}, torch::kFloat32);
  const torch::Tensor albedo = m.albedo->forward(x);
  const torch::Tensor detail = m.detail->forward(torch::cat({x, albedo}, 1));
  const torch::Tensor out = torch::cat({albedo, detail}, 1).contiguous();
  return std::vector<float>(out.data_ptr<float>(), out.data_ptr<float>() + kOutputChannels * n);
}

}  // namespace facecap::nn
