#include "nn/dssim.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

namespace facecap::nn {
namespace {

// (1 - SSIM) / 2 by its definition: every k x k window of every channel and image, in double.
double DirectDssim(const torch::Tensor& x, const torch::Tensor& y, int k) {
  const torch::Tensor xd = x.to(torch::kDouble), yd = y.to(torch::kDouble);
  const auto a = xd.accessor<double, 4>();
  const auto b = yd.accessor<double, 4>();
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  double sum = 0;
  int64_t windows = 0;
  for (int64_t n = 0; n < x.size(0); ++n) {
    for (int64_t c = 0; c < x.size(1); ++c) {
      for (int64_t i = 0; i + k <= x.size(2); ++i) {
        for (int64_t j = 0; j + k <= x.size(3); ++j) {
          double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
          for (int u = 0; u < k; ++u) {
            for (int v = 0; v < k; ++v) {
              const double p = a[n][c][i + u][j + v];
              const double q = b[n][c][i + u][j + v];
              mx += p, my += q, xx += p * p, yy += q * q, xy += p * q;
            }
          }
          const double w = 1.0 / (k * k);
          mx *= w, my *= w, xx *= w, yy *= w, xy *= w;
          const double sx = xx - mx * mx, sy = yy - my * my, sxy = xy - mx * my;
          sum += ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sx + sy + c2));
          ++windows;
        }
      }
    }
  }
  return (1.0 - sum / static_cast<double>(windows)) * 0.5;
}

// The same term with 7 x 7 average pooling, the usual way to write it.
torch::Tensor PooledDssim(const torch::Tensor& x, const torch::Tensor& y) {
  auto pool = [](const torch::Tensor& t) { return torch::avg_pool2d(t, {7, 7}, {1, 1}); };
  const torch::Tensor mx = pool(x), my = pool(y);
  const torch::Tensor sxx = pool(x * x) - mx * mx, syy = pool(y * y) - my * my;
  const torch::Tensor sxy = pool(x * y) - mx * my;
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  return (1.0 - (((2 * mx * my + c1) * (2 * sxy + c2)) /
                 ((mx * mx + my * my + c1) * (sxx + syy + c2))).mean()) * 0.5;
}

TEST(Dssim, EqualsTheDefinitionOverEveryWindow) {
  torch::manual_seed(3);
  const torch::Tensor x = torch::rand({2, 3, 12, 9});
  // y: x blurred and shifted a little, so that the windows' statistics are partly shared.
  const torch::Tensor y = (0.6 * x.roll(1, 2) + 0.4 * torch::rand({2, 3, 12, 9})).clamp(0, 1);
  const double direct = DirectDssim(x, y, 7);
  EXPECT_GT(direct, 0.05);
  EXPECT_NEAR(Dssim(x, y).item<double>(), direct, 1e-6);
  // Images smaller than 7 pixels use their whole height as the window.
  const torch::Tensor sx = x.narrow(2, 0, 5).narrow(3, 0, 5), sy = y.narrow(2, 0, 5).narrow(3, 0, 5);
  EXPECT_NEAR(Dssim(sx, sy).item<double>(), DirectDssim(sx, sy, 5), 1e-6);
  EXPECT_NEAR(Dssim(x, x).item<double>(), 0.0, 1e-6);
}

TEST(Dssim, GradientEqualsThePooledFormulations) {
  torch::manual_seed(5);
  const torch::Tensor target = torch::rand({2, 3, 16, 16});
  const torch::Tensor start = (0.5 * target + 0.5 * torch::rand({2, 3, 16, 16}));
  torch::Tensor a = start.clone().requires_grad_(true), b = start.clone().requires_grad_(true);
  const torch::Tensor ours = Dssim(a, target), pooled = PooledDssim(b, target);
  ours.backward();
  pooled.backward();
  EXPECT_NEAR(ours.item<double>(), pooled.item<double>(), 1e-6);
  const double scale = b.grad().abs().max().item<double>();
  EXPECT_GT(scale, 0);
  EXPECT_LT((a.grad() - b.grad()).abs().max().item<double>(), 1e-4 * scale);
}

}  // namespace
}  // namespace facecap::nn
