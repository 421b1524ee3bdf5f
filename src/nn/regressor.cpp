#include "nn/regressor.h"

#include <algorithm>

#include <torch/torch.h>

#include "nn/parameter_vector.h"
#include "util/errors.h"
#include "util/hash.h"

namespace facecap::nn {
namespace {

// Fully connected layers with leaky ReLUs between them and a sigmoid after the last.
struct PerceptronImpl : torch::nn::Module {
  PerceptronImpl(int in, int out, int hidden, int layers, double slope) : slope(slope) {
    int width = in;
    for (int l = 0; l < layers; ++l) {
      linears.push_back(register_module("linear" + std::to_string(l), torch::nn::Linear(width, hidden)));
      width = hidden;
    }
    linears.push_back(register_module("output", torch::nn::Linear(width, out)));
  }
  torch::Tensor forward(torch::Tensor x) {
    for (size_t l = 0; l + 1 < linears.size(); ++l) {
      x = torch::leaky_relu(linears[l]->forward(x), slope);
    }
    return torch::sigmoid(linears.back()->forward(x));
  }
  std::vector<torch::nn::Linear> linears;
  double slope;
};
TORCH_MODULE(Perceptron);

constexpr int kNetworks = 4;  // P, J, W, L

}  // namespace

bool RegressorOptions::Check(std::string* why) const {
  if (hidden < 1 || hidden > 4096) { *why = "hidden must be in [1, 4096]"; return false; }
  if (layers < 0 || layers > 16) { *why = "layers must be in [0, 16]"; return false; }
  if (!(leaky_slope >= 0.f && leaky_slope < 1.f)) { *why = "leaky_slope must be in [0, 1)"; return false; }
  if (!(learning_rate > 0.f && learning_rate < 1.f)) { *why = "learning_rate must be in (0, 1)"; return false; }
  if (!(landmark_margin >= 0.f && landmark_margin < 1.f)) { *why = "landmark_margin must be in [0, 1)"; return false; }
  if (!(landmark_weight >= 0.f)) { *why = "landmark_weight must be >= 0"; return false; }
  if (!(anchor_weight >= 0.f)) { *why = "anchor_weight must be >= 0"; return false; }
  return true;
}

struct Regressor::Impl {
  RegressorOptions options;
  RegressorSizes sizes;
  Perceptron net[kNetworks] = {Perceptron(nullptr), Perceptron(nullptr), Perceptron(nullptr),
                               Perceptron(nullptr)};
  std::vector<torch::Tensor> parameters;
  std::vector<int> owner;  // the network of each parameter tensor
  int64_t num_parameters = 0;
  std::vector<float> gradient, adam_m, adam_v;
  int64_t steps = 0;

  static bool Trains(Phase phase, int network) {
    return phase == Phase::kLandmarks ? network == 3 : network != 3;
  }
};

Regressor::Regressor(const RegressorOptions& options, const RegressorSizes& sizes)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("regressor: " + why);
  if (sizes.code < 1 || sizes.pose < 1 || sizes.jaw < 1 || sizes.expression < 1 || sizes.landmarks < 2 ||
      sizes.landmarks % 2 != 0) {
    throw InvalidInputError("regressor: the code, pose, jaw and expression sizes must be positive "
                            "and the landmarks an even count");
  }
  Impl& m = *impl_;
  m.options = options;
  m.sizes = sizes;
  torch::manual_seed(static_cast<uint64_t>(options.seed));
  const int h = options.hidden, l = options.layers;
  const double s = options.leaky_slope;
  m.net[0] = Perceptron(sizes.code, sizes.pose, h, l, s);
  m.net[1] = Perceptron(sizes.code + sizes.pose, sizes.jaw, h, l, s);
  m.net[2] = Perceptron(sizes.code + sizes.pose + sizes.jaw, sizes.expression, h, l, s);
  m.net[3] = Perceptron(sizes.pose + sizes.jaw + sizes.expression, sizes.landmarks, h, l, s);
  for (int k = 0; k < kNetworks; ++k) {
    for (auto& p : m.net[k]->parameters()) {
      m.parameters.push_back(p);
      m.owner.push_back(k);
      m.num_parameters += p.numel();
    }
  }
  m.gradient.assign(m.num_parameters, 0.f);
  m.adam_m.assign(m.num_parameters, 0.f);
  m.adam_v.assign(m.num_parameters, 0.f);
}

Regressor::~Regressor() = default;

const RegressorSizes& Regressor::sizes() const { return impl_->sizes; }
int64_t Regressor::NumParameters() const { return impl_->num_parameters; }
float* Regressor::Gradients() { return impl_->gradient.data(); }

void Regressor::Backward(Phase phase, const std::vector<RegressorExample>& batch, float loss_scale,
                         double losses[kNumLosses]) {
  Impl& m = *impl_;
  std::fill(m.gradient.begin(), m.gradient.end(), 0.f);
  std::fill(losses, losses + kNumLosses, 0.0);
  if (batch.empty()) return;
  for (auto& p : m.parameters) {
    if (p.grad().defined()) p.mutable_grad() = torch::Tensor();
  }
  const RegressorSizes& z = m.sizes;
  const int64_t B = static_cast<int64_t>(batch.size());
  // Each input as a [B, n] tensor, with a [B] mask of the examples that have it.
  auto gather = [&](int n, const float* RegressorExample::*field, torch::Tensor* values,
                    torch::Tensor* mask) {
    std::vector<float> v(static_cast<size_t>(B * n), 0.f), known(static_cast<size_t>(B), 0.f);
    for (int64_t b = 0; b < B; ++b) {
      const float* src = batch[b].*field;
      if (!src) continue;
      std::copy(src, src + n, v.begin() + b * n);
      known[b] = 1.f;
    }
    *values = torch::tensor(v).reshape({B, n});
    *mask = torch::tensor(known);
  };
  torch::Tensor e, p, wj, wc, lm, has_code, has_truth, has_jaw, has_expression, has_landmarks;
  gather(z.code, &RegressorExample::code, &e, &has_code);
  gather(z.pose, &RegressorExample::pose, &p, &has_truth);
  gather(z.jaw, &RegressorExample::jaw, &wj, &has_jaw);
  gather(z.expression, &RegressorExample::expression, &wc, &has_expression);
  gather(z.landmarks, &RegressorExample::landmarks, &lm, &has_landmarks);
  torch::Tensor anchor, has_anchor;
  gather(z.pose + z.jaw + z.expression, &RegressorExample::anchor, &anchor, &has_anchor);
  has_truth = has_truth * has_jaw * has_expression;

  // Per example: mean squared difference, masked.
  auto mse = [](const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
    return (a - b).pow(2).mean(1) * mask;
  };
  // Per example: sum over landmarks of max(0, distance - delta), masked.
  const float delta = m.options.landmark_margin;
  auto hinge = [&](const torch::Tensor& predicted) {
    const torch::Tensor d = (predicted - lm).reshape({B, z.landmarks / 2, 2});
    const torch::Tensor distance = (d.pow(2).sum(2) + 1e-12f).sqrt();
    return torch::relu(distance - delta).sum(1) * has_landmarks;
  };
  torch::Tensor loss_p = torch::zeros({B}), loss_j = torch::zeros({B}), loss_w = torch::zeros({B}),
                loss_l = torch::zeros({B});
  const torch::Tensor P = m.net[0]->forward(e);
  const torch::Tensor J = m.net[1]->forward(torch::cat({e, P}, 1));
  const torch::Tensor W = m.net[2]->forward(torch::cat({e, P, J}, 1));
  if (phase == Phase::kLandmarks) {
    const torch::Tensor predicted = m.net[3]->forward(torch::cat({P, J, W}, 1).detach());
    const torch::Tensor from_truth = m.net[3]->forward(torch::cat({p, wj, wc}, 1));
    loss_l = hinge(predicted) + hinge(from_truth) * has_truth;
  } else {
    loss_p = mse(P, p, has_truth);
    loss_j = mse(J, wj, has_truth) + mse(m.net[1]->forward(torch::cat({e, p}, 1)), wj, has_truth);
    loss_w = mse(W, wc, has_truth) + mse(m.net[2]->forward(torch::cat({e, p, wj}, 1)), wc, has_truth);
    if (phase == Phase::kFineTune) {
      loss_l = hinge(m.net[3]->forward(torch::cat({P, J, W}, 1)));
      const float a = m.options.anchor_weight;
      if (a > 0.f) {
        const std::vector<torch::Tensor> parts = anchor.split_with_sizes({z.pose, z.jaw, z.expression}, 1);
        loss_p = loss_p + a * mse(P, parts[0], has_anchor);
        loss_j = loss_j + a * mse(J, parts[1], has_anchor);
        loss_w = loss_w + a * mse(W, parts[2], has_anchor);
      }
    }
  }
  const torch::Tensor total =
      (loss_p + loss_j + loss_w + m.options.landmark_weight * loss_l).sum() * loss_scale;
  total.backward();
  CopyGradients(m.parameters, m.gradient.data());
  // The networks this phase does not train keep a zero gradient.
  int64_t offset = 0;
  for (size_t t = 0; t < m.parameters.size(); ++t) {
    const int64_t n = m.parameters[t].numel();
    if (!Impl::Trains(phase, m.owner[t])) {
      std::fill(m.gradient.begin() + offset, m.gradient.begin() + offset + n, 0.f);
    }
    offset += n;
  }
  losses[0] = loss_p.sum().item<double>();
  losses[1] = loss_j.sum().item<double>();
  losses[2] = loss_w.sum().item<double>();
  losses[3] = loss_l.sum().item<double>();
}

void Regressor::OptimizerStep(Phase phase) {
  Impl& m = *impl_;
  AdamStep step;
  step.step = ++m.steps;
  step.learning_rate = m.options.learning_rate;
  AdamOverTensors(step, &m.parameters, m.gradient.data(), m.adam_m.data(), m.adam_v.data(),
                  [&](size_t t) { return Impl::Trains(phase, m.owner[t]); });
}

void Regressor::StartPhase(Phase phase) {
  Impl& m = *impl_;
  int64_t offset = 0;
  for (size_t t = 0; t < m.parameters.size(); ++t) {
    const int64_t n = m.parameters[t].numel();
    if (Impl::Trains(phase, m.owner[t])) {
      std::fill(m.adam_m.begin() + offset, m.adam_m.begin() + offset + n, 0.f);
      std::fill(m.adam_v.begin() + offset, m.adam_v.begin() + offset + n, 0.f);
    }
    offset += n;
  }
  m.steps = 0;
}

std::vector<float> Regressor::State() const {
  const Impl& m = *impl_;
  return OptimizerState(m.parameters, m.adam_m, m.adam_v, m.steps);
}

void Regressor::SetState(const std::vector<float>& state) {
  Impl& m = *impl_;
  if (!SetOptimizerState(state, &m.parameters, &m.adam_m, &m.adam_v, &m.steps)) {
    throw FileIOError("regressor: a state of " + std::to_string(state.size()) + " values, the networks need " +
                      std::to_string(3 * m.num_parameters + 1));
  }
}

uint64_t Regressor::ParameterHash() const {
  const std::vector<float> p = FlattenParameters(impl_->parameters);
  return Fnv1a(p.data(), p.size() * sizeof(float));
}

void Regressor::Predict(const float* codes, int count, float* pose, float* jaw, float* expression,
                        float* landmarks) const {
  Impl& m = *impl_;  // forward passes are not const in torch
  if (count <= 0) return;
  torch::NoGradGuard no_grad;
  std::vector<float> input(codes, codes + static_cast<int64_t>(count) * m.sizes.code);
  const torch::Tensor e = torch::from_blob(input.data(), {count, m.sizes.code}, torch::kFloat32);
  const torch::Tensor P = m.net[0]->forward(e);
  const torch::Tensor J = m.net[1]->forward(torch::cat({e, P}, 1));
  const torch::Tensor W = m.net[2]->forward(torch::cat({e, P, J}, 1));
  auto out = [](const torch::Tensor& t, float* to) {
    if (!to) return;
    const torch::Tensor c = t.contiguous();
    std::copy(c.data_ptr<float>(), c.data_ptr<float>() + c.numel(), to);
  };
  out(P, pose);
  out(J, jaw);
  out(W, expression);
  if (landmarks) out(m.net[3]->forward(torch::cat({P, J, W}, 1)), landmarks);
}

}  // namespace facecap::nn
