// Floating-point rates of this machine and of the networks' training steps, for the
// benchmarks (analysis/bench_all.sh): a single-precision matrix-multiply rate to compare
// against, and the operations torch's profiler counts in a piece of code.
#ifndef FACECAP_NN_FLOPS_H_
#define FACECAP_NN_FLOPS_H_

#include <cstdint>
#include <functional>

namespace facecap::nn {

// The best rate (GFLOP/s) of `repeats` single-precision n x n by n x n products with
// torch::mm on the current torch threads (2 n^3 operations each).
double MatmulGflops(int n, int repeats);

// The floating-point operations of the torch operators `fn` runs, as torch's profiler counts
// them: convolutions, matrix products, element-wise products and sums of the forward pass
// (backward operators are not counted).
uint64_t CountForwardFlops(const std::function<void()>& fn);

}  // namespace facecap::nn

#endif  // FACECAP_NN_FLOPS_H_
