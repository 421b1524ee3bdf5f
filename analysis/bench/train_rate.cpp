// How close the trainers run to this machine's arithmetic limit, on one thread: the
// single-precision rate of torch::mm against the rate of a training step of
//  - the deepfake subcommand's recipe network (64 x 64, palette head with the 16 regions and
//    the background, U-Net skips, input-resolution skip, palette and Dice terms, gradient cap)
//    at one rank's share of the global batch of 8 on 2 ranks;
//  - the blendshape generator at blendshapes train's defaults (64 x 64 geometry images, the
//    55 template shapes on 1,649 chart vertices, 24 expressions per person), an Estimation
//    and a Tuning Stage step at one rank's share of the batch of 8 people on 2 ranks.
// The inputs are random numbers of the real sizes: the arithmetic does not depend on them.
//
//   facecap_bench_train_rate [--batch B] [--people P] [--steps N] [--matmul N]
//
// A step's operations are estimated as 3 x those torch's profiler counts in its forward pass
// and loss terms (the backward pass of a convolution or a product costs about twice its
// forward pass).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "nn/blendshape_generator.h"
#include "nn/deepfake.h"
#include "nn/flops.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

// Seconds per call of `step` over `steps` calls, after one warm-up call.
double SecondsPerStep(const std::function<void()>& step, int steps) {
  step();
  const auto start = std::chrono::steady_clock::now();
  for (int s = 0; s < steps; ++s) step();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
}

void Report(const char* what, int batch, double seconds, uint64_t forward, double peak) {
  const double gflops = 3.0 * static_cast<double>(forward) / seconds * 1e-9;
  std::printf("%s (batch %d, 1 thread): %.3f s, %.2f GFLOP counted forward, about %.1f GFLOP/s = "
              "%.0f%% of the matmul peak\n",
              what, batch, seconds, static_cast<double>(forward) * 1e-9, gflops, 100.0 * gflops / peak);
}

void DeepfakeRate(int batch, int steps, double peak) {

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
  const double seconds = SecondsPerStep([&] {
    trainer.Backward(b);
    trainer.OptimizerStep();
  }, steps);
  Report("deepfake training step", batch, seconds, CountForwardFlops([&] { trainer.Backward(b); }), peak);
}

void BlendshapeRate(int people, int steps, double peak) {
  constexpr int kSize = 64, kShapes = 55, kLarge = 14, kVertices = 1649, kExpressions = 24;
  Rng rng(11, 0);
  auto normal = [&](std::vector<float>* v, size_t n) {
    v->resize(n);
    for (float& x : *v) x = static_cast<float>(rng.Normal());
  };
  auto g = std::make_shared<BlendshapeNetGeometry>();
  g->image_size = kSize;
  g->num_shapes = kShapes;
  g->num_chart_vertices = kVertices;
  for (int i = 0; i < kLarge; ++i) g->large_motion_shapes.push_back(i);
  normal(&g->template_deltas, 3ull * kShapes * kVertices);
  g->reg_weights.assign(static_cast<size_t>(kShapes) * kVertices, 1.f);
  // Each vertex reads a 2 x 2 block of pixels spread over the image, with equal weights.
  for (int k = 0; k < kVertices; ++k) {
    const int p = (k * 37) % ((kSize - 1) * (kSize - 1));
    const int corner = (p / (kSize - 1)) * kSize + p % (kSize - 1);
    g->sample_pixels.insert(g->sample_pixels.end(), {corner, corner + 1, corner + kSize, corner + kSize + 1});
    g->sample_weights.insert(g->sample_weights.end(), 4, 0.25f);
  }
  g->num_static_channels = 4;
  normal(&g->static_channels, 4ull * kSize * kSize);
  std::vector<BlendshapePerson> persons(people);
  std::vector<const BlendshapePerson*> batch;
  for (BlendshapePerson& p : persons) {
    p.num_expressions = kExpressions;
    normal(&p.neutral_image, 3ull * kSize * kSize);
    normal(&p.neutral, 3ull * kVertices);
    normal(&p.expressions, 3ull * kExpressions * kVertices);
    normal(&p.expression_images, 3ull * kExpressions * kSize * kSize);
    p.nominal_weights.assign(static_cast<size_t>(kExpressions) * kShapes, 0.f);
    for (int k = 0; k < kExpressions; ++k) {  // each expression a few of the shapes
      for (int i = k; i < kShapes; i += kExpressions) p.nominal_weights[k * kShapes + i] = 1.f;
    }
    batch.push_back(&p);
  }
  BlendshapeGenerator model(BlendshapeNetOptions{}, g);
  model.FitAmplitudeBasis(batch);
  const float scale = 1.f / static_cast<float>(people);
  for (TrainingStage stage : {TrainingStage::kEstimation, TrainingStage::kTuning}) {
    const double seconds = SecondsPerStep([&] {
      model.Backward(batch, stage, scale);
      model.OptimizerStep(stage);
    }, steps);
    const uint64_t forward = CountForwardFlops([&] { model.Backward(batch, stage, scale); });
    Report(stage == TrainingStage::kEstimation ? "blendshape Estimation Stage step"
                                               : "blendshape Tuning Stage step",
           people, seconds, forward, peak);
  }
}

int Run(int batch, int people, int steps, int matmul) {
  SetTorchThreads(1);
  const double peak = MatmulGflops(matmul, 5);
  std::printf("matmul peak (torch::mm %dx%d, 1 thread): %.1f GFLOP/s\n", matmul, matmul, peak);
  DeepfakeRate(batch, steps, peak);
  BlendshapeRate(people, steps, peak);
  return 0;
}

}  // namespace
}  // namespace facecap::nn

int main(int argc, char** argv) {
  int batch = 4, people = 4, steps = 10, matmul = 1024;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--batch")) batch = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--people")) people = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--steps")) steps = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--matmul")) matmul = std::atoi(argv[i + 1]);
    else { std::fprintf(stderr, "unknown option %s\n", argv[i]); return 2; }
  }
  if (batch < 1 || people < 1 || steps < 1 || matmul < 16) { std::fprintf(stderr, "bad option values\n"); return 2; }
  return facecap::nn::Run(batch, people, steps, matmul);
}
