// Torch modules' parameters and gradients as one float vector, in the order of a parameter
// list. For nn/*.cpp only: it includes torch.
#ifndef FACECAP_NN_PARAMETER_VECTOR_H_
#define FACECAP_NN_PARAMETER_VECTOR_H_

#include <algorithm>
#include <cstdint>
#include <vector>

#include <torch/torch.h>

#include "nn/adam.h"

namespace facecap::nn {

inline std::vector<float> FlattenParameters(const std::vector<torch::Tensor>& parameters) {
  std::vector<float> out;
  for (const auto& p : parameters) {
    const torch::Tensor c = p.detach().contiguous();
    out.insert(out.end(), c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  }
  return out;
}

// values: as many floats as the parameters hold (the caller checks).
inline void SetFlatParameters(const std::vector<float>& values, std::vector<torch::Tensor>* parameters) {
  torch::NoGradGuard no_grad;
  int64_t offset = 0;
  for (auto& p : *parameters) {
    std::copy(values.begin() + offset, values.begin() + offset + p.numel(), p.data_ptr<float>());
    offset += p.numel();
  }
}

// Each parameter's gradient into `out` at its offset; those without one are left as they are.
inline void CopyGradients(const std::vector<torch::Tensor>& parameters, float* out) {
  int64_t offset = 0;
  for (const auto& p : parameters) {
    const int64_t n = p.numel();
    if (p.grad().defined()) {
      const torch::Tensor g = p.grad().contiguous();
      std::copy(g.data_ptr<float>(), g.data_ptr<float>() + n, out + offset);
    }
    offset += n;
  }
}

// One Adam step over parameter tensors whose gradients and moments lie in flat buffers in the
// tensors' order. Tensor t is updated when trains(t) is true and left as it is otherwise.
template <class Trains>
void AdamOverTensors(const AdamStep& step, std::vector<torch::Tensor>* parameters, const float* gradient,
                     float* first, float* second, Trains&& trains) {
  torch::NoGradGuard no_grad;
  int64_t offset = 0;
  for (size_t t = 0; t < parameters->size(); ++t) {
    torch::Tensor& p = (*parameters)[t];
    const int64_t n = p.numel();
    if (trains(t)) AdamUpdate(step, gradient + offset, p.data_ptr<float>(), first + offset, second + offset, n);
    offset += n;
  }
}

// Parameters, Adam's moments and its step count as one vector (a checkpoint)...
inline std::vector<float> OptimizerState(const std::vector<torch::Tensor>& parameters,
                                         const std::vector<float>& first, const std::vector<float>& second,
                                         int64_t steps) {
  std::vector<float> state = FlattenParameters(parameters);
  state.insert(state.end(), first.begin(), first.end());
  state.insert(state.end(), second.begin(), second.end());
  state.push_back(static_cast<float>(steps));
  return state;
}

// ... and back; false, with nothing changed, when the state's size does not fit.
inline bool SetOptimizerState(const std::vector<float>& state, std::vector<torch::Tensor>* parameters,
                              std::vector<float>* first, std::vector<float>* second, int64_t* steps) {
  const int64_t n = static_cast<int64_t>(first->size());
  if (static_cast<int64_t>(state.size()) != 3 * n + 1) return false;
  SetFlatParameters(std::vector<float>(state.begin(), state.begin() + n), parameters);
  std::copy(state.begin() + n, state.begin() + 2 * n, first->begin());
  std::copy(state.begin() + 2 * n, state.begin() + 3 * n, second->begin());
  *steps = static_cast<int64_t>(state[3 * n]);
  return true;
}

}  // namespace facecap::nn

#endif  // FACECAP_NN_PARAMETER_VECTOR_H_
