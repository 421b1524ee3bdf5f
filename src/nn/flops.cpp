#include "nn/flops.h"

#include <algorithm>
#include <chrono>

#include <torch/csrc/autograd/profiler_legacy.h>
#include <torch/torch.h>

namespace facecap::nn {

double MatmulGflops(int n, int repeats) {
  torch::NoGradGuard no_grad;
  const torch::Tensor a = torch::rand({n, n});
  const torch::Tensor b = torch::rand({n, n});
  torch::Tensor c = torch::mm(a, b);  // warm-up
  double best = 0;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    c = torch::mm(a, b);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    best = std::max(best, 2.0 * n * n * static_cast<double>(n) / seconds * 1e-9);
  }
  return best;
}

uint64_t CountForwardFlops(const std::function<void()>& fn) {
  namespace profiler = torch::autograd::profiler;
  profiler::enableProfilerLegacy(profiler::ProfilerConfig(profiler::ProfilerState::CPU,
                                                          /*report_input_shapes=*/true,
                                                          /*profile_memory=*/false,
                                                          /*with_stack=*/false,
                                                          /*with_flops=*/true));
  fn();
  uint64_t flops = 0;
  for (auto& events : profiler::disableProfilerLegacy()) {
    for (auto& event : events) flops += event.flops();
  }
  return flops;
}

}  // namespace facecap::nn
