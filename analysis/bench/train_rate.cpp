// How close the deepfake trainer runs to this machine's arithmetic limit, on one thread:
// the single-precision rate of torch::mm against the rate of a training step of the
// subcommand's recipe network (64 x 64, palette head with the 16 regions and the background,
// U-Net skips, input-resolution skip, palette and Dice terms, gradient cap) at one rank's
// share of the global batch of 8 on 2 ranks.
//
//   facecap_bench_train_rate [--batch B] [--steps N] [--matmul N]
//
// A step's operations are estimated as 3 x those torch's profiler counts in its forward pass
// and loss terms (the backward pass of a convolution costs about twice its forward pass).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "nn/deepfake.h"
#include "nn/flops.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

int Run(int batch, int steps, int matmul) {
  SetTorchThreads(1);
  const double peak = MatmulGflops(matmul, 5);

  DeepfakeNetworkOptions network;
  network.skips = 2;
  network.decoder_width = 24;
  network.decoder_b_width = 16;
  network.input_skip_width = 16;
  network.palette_colors = 17;
  DeepfakeLossOptions loss;
  loss.palette_weight = 1.f;
  loss.region_l1_weight = 0.f;
  loss.dice_weight = 1.f;
  loss.gradient_clip = 3.f;
  DeepfakeModel model(network, 1, "cpu");
  DeepfakeTrainer trainer(&model, loss);
  Rng rng(7, 0);
  std::vector<float> colors(3 * network.palette_colors);
  for (float& c : colors) c = static_cast<float>(rng.Uniform());
  model.SetPalette(colors);
  trainer.SetPalette(colors, std::vector<float>(network.palette_colors, 1.f));
  TrainingBatch b;
  b.count = batch;
  b.size = network.size;
  const size_t floats = 3ull * batch * network.size * network.size;
  for (auto* v : {&b.input_a, &b.input_b, &b.target_b}) {
    v->resize(floats);
    for (float& x : *v) x = static_cast<float>(rng.Uniform());
  }
  b.target_a.resize(floats);
  for (size_t p = 0; p < floats / 3; ++p) {  // targets in the palette's colours
    const int k = static_cast<int>(rng.UniformInt(network.palette_colors));
    for (int c = 0; c < 3; ++c) b.target_a[3 * p + c] = colors[3 * k + c];
  }
  auto step = [&] {
    trainer.Backward(b);
    trainer.OptimizerStep();
  };
  step();  // warm-up
  const uint64_t forward = CountForwardFlops([&] { trainer.Backward(b); });
  const auto start = std::chrono::steady_clock::now();
  for (int s = 0; s < steps; ++s) step();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
  const double gflops = 3.0 * static_cast<double>(forward) / seconds * 1e-9;
  std::printf("matmul peak (torch::mm %dx%d, 1 thread): %.1f GFLOP/s\n", matmul, matmul, peak);
  std::printf("deepfake training step (batch %d, 1 thread): %.3f s, %.2f GFLOP counted forward, "
              "about %.1f GFLOP/s = %.0f%% of the matmul peak\n",
              batch, seconds, static_cast<double>(forward) * 1e-9, gflops, 100.0 * gflops / peak);
  return 0;
}

}  // namespace
}  // namespace facecap::nn

int main(int argc, char** argv) {
  int batch = 4, steps = 10, matmul = 1024;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--batch")) batch = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--steps")) steps = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--matmul")) matmul = std::atoi(argv[i + 1]);
    else { std::fprintf(stderr, "unknown option %s\n", argv[i]); return 2; }
  }
  if (batch < 1 || steps < 1 || matmul < 16) { std::fprintf(stderr, "bad option values\n"); return 2; }
  return facecap::nn::Run(batch, steps, matmul);
}
