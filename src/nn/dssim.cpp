#include "nn/dssim.h"

#include <torch/torch.h>

#include <algorithm>

namespace facecap::nn {
namespace {

// [n - k + 1, n]: row i averages entries i .. i + k - 1 of a vector of n.
torch::Tensor WindowMeans(int64_t n, int64_t k, const torch::TensorOptions& options) {
  const torch::Tensor rows = torch::arange(n - k + 1, options).unsqueeze(1);
  const torch::Tensor columns = torch::arange(n, options).unsqueeze(0);
  return ((columns >= rows) & (columns < rows + k)).to(options.dtype()) / static_cast<double>(k);
}

}  // namespace

// The windows' means of x, y, x^2, y^2 and xy are taken at once, as products with band
// matrices down the rows and across the columns (two small matrix products instead of five
// 7 x 7 pooling passes).
torch::Tensor Dssim(const torch::Tensor& x, const torch::Tensor& y) {
  const int64_t k = std::min<int64_t>({7, x.size(2), x.size(3)});
  const int64_t c = x.size(1);
  const torch::Tensor down = WindowMeans(x.size(2), k, x.options());
  const torch::Tensor across = WindowMeans(x.size(3), k, x.options()).t();
  const torch::Tensor means =
      torch::matmul(torch::matmul(down, torch::cat({x, y, x * x, y * y, x * y}, 1)), across);
  const torch::Tensor mx = means.narrow(1, 0, c), my = means.narrow(1, c, c);
  const torch::Tensor sxx = means.narrow(1, 2 * c, c) - mx * mx;
  const torch::Tensor syy = means.narrow(1, 3 * c, c) - my * my;
  const torch::Tensor sxy = means.narrow(1, 4 * c, c) - mx * my;
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  const torch::Tensor ssim =
      ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
  return (1.0 - ssim.mean()) * 0.5;
}

}  // namespace facecap::nn
