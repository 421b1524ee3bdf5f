// Torch modules' parameters and gradients as one float vector, in the order of a parameter
// list. For nn/*.cpp only: it includes torch.
#ifndef FACECAP_NN_PARAMETER_VECTOR_H_
#define FACECAP_NN_PARAMETER_VECTOR_H_

#include <algorithm>
#include <cstdint>
#include <vector>

#include <torch/torch.h>

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

}  // namespace facecap::nn

#endif  // FACECAP_NN_PARAMETER_VECTOR_H_
