// The deepfake trainer on tiny images: the gradient buffer of a split batch sums to the
// gradient of the whole batch (what the allreduce relies on), training is deterministic, a
// checkpoint continues bitwise, the loss falls, and bad checkpoints are named.
#include "nn/deepfake.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "nn/augment.h"
#include "nn/deepfake_io.h"
#include "testing/testing.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

constexpr int kSize = 16;

DeepfakeNetworkOptions TinyNetwork() {
  DeepfakeNetworkOptions o;
  o.size = kSize;
  o.encoder_width = 8;
  o.latent_resolution = 4;
  o.latent_channels = 8;
  o.decoder_width = 8;
  o.discriminator_width = 8;
  return o;
}

// Domain A: flat coloured discs on black; domain B: the same discs, other colours, noise.
std::vector<uint8_t> TinyImages(int count, bool domain_b, uint64_t seed) {
  std::vector<uint8_t> images(static_cast<size_t>(count) * kSize * kSize * 3, 0);
  for (int i = 0; i < count; ++i) {
    Rng rng(seed, i);
    const float cx = rng.Uniform(5, 11), cy = rng.Uniform(5, 11), r = rng.Uniform(2.5, 5);
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        uint8_t* p = &images[((static_cast<size_t>(i) * kSize + y) * kSize + x) * 3];
        const bool inside = (x - cx) * (x - cx) + (y - cy) * (y - cy) < r * r;
        const int noise = domain_b ? static_cast<int>(rng.Uniform(-20, 20)) : 0;
        const int rgb[3] = {inside ? (domain_b ? 200 : 250) : (domain_b ? 60 : 0),
                            inside ? (domain_b ? 150 : 40) : (domain_b ? 70 : 0),
                            inside ? (domain_b ? 120 : 40) : (domain_b ? 90 : 0)};
        for (int c = 0; c < 3; ++c) p[c] = static_cast<uint8_t>(std::clamp(rgb[c] + noise, 0, 255));
      }
    }
  }
  return images;
}

TrainingBatch MakeBatch(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int first,
                        int count, uint64_t seed) {
  TrainingBatch batch;
  batch.count = count;
  batch.size = kSize;
  const size_t n = static_cast<size_t>(count) * kSize * kSize * 3, one = kSize * kSize * 3;
  batch.input_a.resize(n); batch.target_a.resize(n);
  batch.input_b.resize(n); batch.target_b.resize(n);
  AugmentOptions augment;
  for (int i = 0; i < count; ++i) {
    Rng rng(seed, first + i);
    AugmentPair(&a[(first + i) * one], kSize, kSize, augment, PairKind::kSegmentation, &rng,
                &batch.input_a[i * one], &batch.target_a[i * one]);
    AugmentPair(&b[(first + i) * one], kSize, kSize, augment, PairKind::kCamera, &rng,
                &batch.input_b[i * one], &batch.target_b[i * one]);
  }
  return batch;
}

TrainingBatch Slice(const TrainingBatch& batch, int first, int count) {
  TrainingBatch s;
  s.count = count;
  s.size = batch.size;
  const size_t one = static_cast<size_t>(batch.size) * batch.size * 3;
  auto cut = [&](const std::vector<float>& v) {
    return std::vector<float>(v.begin() + first * one, v.begin() + (first + count) * one);
  };
  s.input_a = cut(batch.input_a); s.target_a = cut(batch.target_a);
  s.input_b = cut(batch.input_b); s.target_b = cut(batch.target_b);
  return s;
}

// Writes the model to `path` and builds another from the file alone (other initial weights,
// all replaced by the file's).
std::unique_ptr<DeepfakeModel> RoundTrip(DeepfakeModel* model, const std::string& path) {
  {
    io::H5File f = io::H5File::CreateAtomic(path);
    WriteWeights(&f, model);
    f.Commit();
  }
  const io::H5File f = io::H5File::OpenRead(path);
  auto read_back = std::make_unique<DeepfakeModel>(ReadNetworkOptions(f), 8);
  ReadWeights(f, read_back.get());
  return read_back;
}

class DeepfakeTrainerTest : public ::testing::Test {
 protected:
  void SetUp() override { SetTorchThreads(1); }
  std::vector<uint8_t> a_ = TinyImages(16, false, 1), b_ = TinyImages(16, true, 2);
};

TEST_F(DeepfakeTrainerTest, LayoutCoversOneContiguousBufferWithModulePaths) {
  DeepfakeModel model(TinyNetwork(), 7);
  int64_t next = 0;
  for (const TensorSlot& s : model.ParameterLayout()) {
    EXPECT_EQ(s.offset, next) << s.name;
    next += s.count;
  }
  EXPECT_EQ(next, model.num_parameters());
  EXPECT_EQ(model.ParameterLayout().front().name, "encoder/down0/weight");
  EXPECT_EQ(model.ParameterLayout().back().name, "latent_discriminator/score/bias");
}

// A narrower D_B: its layers have the width asked for, D_A keeps decoder_width, and the model
// file records it and rebuilds the same network from it.
TEST_F(DeepfakeTrainerTest, NarrowerDecoderBIsBuiltAndStored) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.decoder_b_width = 4;
  DeepfakeModel model(o, 7);
  std::vector<int64_t> a_last, b_last;
  for (const TensorSlot& s : model.ParameterLayout()) {
    if (s.name == "decoder_a/rgb/weight") a_last = s.shape;
    if (s.name == "decoder_b/rgb/weight") b_last = s.shape;
  }
  EXPECT_EQ(a_last, (std::vector<int64_t>{3, 8, 3, 3}));
  EXPECT_EQ(b_last, (std::vector<int64_t>{3, 4, 3, 3}));
  EXPECT_LT(model.num_parameters(), DeepfakeModel(TinyNetwork(), 7).num_parameters());

  testing::TempDir dir;
  const std::unique_ptr<DeepfakeModel> read_back = RoundTrip(&model, dir.File("model.h5"));
  EXPECT_EQ(read_back->options().decoder_b_width, 4);
  EXPECT_EQ(read_back->ParameterHash(), model.ParameterHash());
  o.decoder_b_width = -1;
  EXPECT_THROW(DeepfakeModel(o, 7), InvalidInputError);
}

// The input-resolution skip: the encoder gets a stride-1 level of the width asked for, both
// decoders' last convolutions take its features beside the upsampled ones, its weights get
// gradients, and the model file rebuilds the same network.
TEST_F(DeepfakeTrainerTest, InputSkipLevelFeedsTheLastDecoderConvolutionAndIsStored) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.input_skip_width = 4;
  DeepfakeModel model(o, 7);
  std::map<std::string, TensorSlot> slots;
  for (const TensorSlot& s : model.ParameterLayout()) slots[s.name] = s;
  ASSERT_TRUE(slots.count("encoder/full/weight"));
  EXPECT_EQ(slots["encoder/full/weight"].shape, (std::vector<int64_t>{4, 3, 3, 3}));
  // 16x16 from a 4x4 code: two levels up, the last one from 16 upsampled channels and 4 skipped.
  EXPECT_EQ(slots["decoder_a/up1/weight"].shape, (std::vector<int64_t>{8, 20, 3, 3}));
  EXPECT_EQ(slots["decoder_b/up1/weight"].shape, (std::vector<int64_t>{8, 20, 3, 3}));
  EXPECT_EQ(slots["decoder_a/up0/weight"].shape, (std::vector<int64_t>{16, 16, 3, 3}));

  DeepfakeTrainer trainer(&model, DeepfakeLossOptions{});
  trainer.Backward(MakeBatch(a_, b_, 0, 4, 1), 1.0);
  const TensorSlot& full = slots["encoder/full/weight"];
  double norm = 0;
  for (int64_t i = 0; i < full.count; ++i) norm += std::abs(trainer.gradients()[full.offset + i]);
  EXPECT_GT(norm, 0.0);

  testing::TempDir dir;
  const std::unique_ptr<DeepfakeModel> read_back = RoundTrip(&model, dir.File("model.h5"));
  EXPECT_EQ(read_back->options().input_skip_width, 4);
  EXPECT_EQ(read_back->ParameterHash(), model.ParameterHash());
  o.input_skip_width = -1;
  EXPECT_THROW(DeepfakeModel(o, 7), InvalidInputError);
}

// gradient_clip: a gradient a thousand times its usual size (what a loss spike hands Adam)
// moves the weights no further than a gradient at the cap would, where unclipped Adam with
// beta1 0.5 jumps 0.5 sqrt(k) learning rates in every weight after k steps (16 once the second
// moment's bias correction has faded).
TEST_F(DeepfakeTrainerTest, GradientClipBoundsTheStepOfASpike) {
  auto step_sizes = [&](float clip) {
    DeepfakeLossOptions losses;
    losses.gradient_clip = clip;
    DeepfakeModel model(TinyNetwork(), 7);
    DeepfakeTrainer trainer(&model, losses);
    const int64_t n = trainer.num_gradients();
    std::vector<float> before;
    auto step = [&](float scale) {
      trainer.Backward(MakeBatch(a_, b_, (trainer.step() * 4) % 12, 4, trainer.step()), 1.0);
      for (int64_t i = 0; i < n; ++i) trainer.gradients()[i] *= scale;
      before.assign(model.parameters(), model.parameters() + n);
      trainer.OptimizerStep();
      double moved = 0;
      for (int64_t i = 0; i < n; ++i) moved += std::pow(model.parameters()[i] - before[i], 2);
      return std::sqrt(moved);
    };
    for (int k = 0; k < 60; ++k) step(1.f);
    const double ordinary = step(1.f);
    return std::pair<double, double>{ordinary, step(1000.f)};
  };
  const auto [ordinary, spike] = step_sizes(0.f);
  const auto [ordinary_clipped, spike_clipped] = step_sizes(4.f);
  const std::string moves = "ordinary " + std::to_string(ordinary) + ", spike " +
                            std::to_string(spike) + "; clipped: ordinary " +
                            std::to_string(ordinary_clipped) + ", spike " + std::to_string(spike_clipped);
  EXPECT_GT(spike, 4 * ordinary) << moves;
  // Ordinary steps are hardly touched by a cap of 4 RMS (it may trim an early step, which
  // changes the path a little); the spike's gradient is cut to 4 RMS, which moves the weights
  // about four ordinary steps' worth instead of eleven.
  EXPECT_NEAR(ordinary_clipped, ordinary, 0.1 * ordinary) << moves;
  EXPECT_LT(spike_clipped, 4.5 * ordinary_clipped) << moves;
  EXPECT_LT(spike_clipped, 0.5 * spike) << moves;
  DeepfakeLossOptions bad;
  bad.gradient_clip = -1;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
}

// A learning-rate scale (the stage's decay schedule) scales the Adam step of every network.
TEST_F(DeepfakeTrainerTest, LearningRateScaleScalesTheStep) {
  auto moved = [&](double scale) {
    DeepfakeModel model(TinyNetwork(), 7);
    DeepfakeTrainer trainer(&model, DeepfakeLossOptions{});
    const std::vector<float> before(model.parameters(), model.parameters() + model.num_parameters());
    trainer.Backward(MakeBatch(a_, b_, 0, 4, 0), 1.0);
    trainer.OptimizerStep(scale);
    std::vector<double> d(before.size());
    for (size_t i = 0; i < d.size(); ++i) d[i] = model.parameters()[i] - before[i];
    return d;
  };
  const std::vector<double> full = moved(1.0), quarter = moved(0.25);
  double max_err = 0, max_abs = 0;
  for (size_t i = 0; i < full.size(); ++i) {
    max_err = std::max(max_err, std::abs(quarter[i] - 0.25 * full[i]));
    max_abs = std::max(max_abs, std::abs(full[i]));
  }
  EXPECT_GT(max_abs, 0);
  EXPECT_LT(max_err, 1e-3 * max_abs);
}

// The moving average of the weights: the first steps mostly follow the weights (the warm-up
// decay (1 + t) / (10 + t)), later ones move by (1 - decay) of the difference, and over weights
// that scatter around a value the average lies far nearer that value than the weights do.
TEST(MovingAverage, WarmsUpThenAveragesOutTheScatter) {
  std::vector<float> averaged = {0.f};
  const float one = 1.f;
  UpdateMovingAverage(&one, 1, 0, 0.999, averaged.data());
  EXPECT_FLOAT_EQ(averaged[0], 0.9f);  // d = 1 / 10
  averaged[0] = 0.f;
  UpdateMovingAverage(&one, 1, 100000, 0.99, averaged.data());
  EXPECT_NEAR(averaged[0], 0.01f, 1e-6f);  // d = decay once the warm-up is past it
  Rng rng(3, 0);
  averaged[0] = 0.f;
  double scatter = 0, average_error = 0;
  for (int t = 0; t < 4000; ++t) {
    const float w = 2.f + static_cast<float>(rng.Normal());
    UpdateMovingAverage(&w, 1, t, 0.99, averaged.data());
    if (t >= 2000) {
      scatter += (w - 2.0) * (w - 2.0);
      average_error += (averaged[0] - 2.0) * (averaged[0] - 2.0);
    }
  }
  // Decay 0.99 keeps (1 - d) / (1 + d) = 1/199 of the variance.
  EXPECT_LT(average_error, scatter / 50);
}

TEST_F(DeepfakeTrainerTest, SharesOfASplitBatchSumToTheWholeBatchGradient) {
  const TrainingBatch batch = MakeBatch(a_, b_, 0, 6, 3);
  DeepfakeModel model(TinyNetwork(), 7);
  DeepfakeTrainer trainer(&model, DeepfakeLossOptions{});
  const DeepfakeLosses whole = trainer.Backward(batch, 1.0);
  const std::vector<float> full(trainer.gradients(), trainer.gradients() + trainer.num_gradients());
  // Two "ranks" with 4 and 2 images, each weighting its mean by its share of the batch.
  std::vector<float> sum(full.size(), 0.f);
  DeepfakeLosses parts[2];
  parts[0] = trainer.Backward(Slice(batch, 0, 4), 4.0 / 6.0);
  for (size_t i = 0; i < sum.size(); ++i) sum[i] += trainer.gradients()[i];
  parts[1] = trainer.Backward(Slice(batch, 4, 2), 2.0 / 6.0);
  for (size_t i = 0; i < sum.size(); ++i) sum[i] += trainer.gradients()[i];
  // Recon and adversarial terms are per-image means: the shares reproduce them exactly up to
  // rounding; the DSSIM window means are per image too.
  double max_err = 0, max_abs = 0;
  for (size_t i = 0; i < sum.size(); ++i) {
    max_err = std::max(max_err, static_cast<double>(std::abs(sum[i] - full[i])));
    max_abs = std::max(max_abs, static_cast<double>(std::abs(full[i])));
  }
  EXPECT_GT(max_abs, 0);
  EXPECT_LT(max_err, 1e-4 * max_abs);
  EXPECT_NEAR(parts[0].recon_a + parts[1].recon_a, whole.recon_a, 1e-5);
  EXPECT_NEAR(parts[0].latent_discriminator + parts[1].latent_discriminator,
              whole.latent_discriminator, 1e-5);
}

// With image_gan_weight 0, G_image is left out: f_image reads 0 and its weights get no
// gradient, while G_latent still learns.
TEST_F(DeepfakeTrainerTest, ZeroImageGanWeightLeavesTheImageDiscriminatorOut) {
  DeepfakeLossOptions losses;
  losses.image_gan_weight = 0.f;
  DeepfakeModel model(TinyNetwork(), 7);
  DeepfakeTrainer trainer(&model, losses);
  const DeepfakeLosses l = trainer.Backward(MakeBatch(a_, b_, 0, 4, 1), 1.0);
  EXPECT_EQ(l.image_discriminator, 0.0);
  EXPECT_EQ(l.image_adversarial, 0.0);
  EXPECT_GT(l.latent_discriminator, 0.0);
  double image_norm = 0, latent_norm = 0;
  for (const TensorSlot& s : model.ParameterLayout()) {
    double norm = 0;
    for (int64_t i = 0; i < s.count; ++i) norm += std::abs(trainer.gradients()[s.offset + i]);
    if (s.name.rfind("image_discriminator/", 0) == 0) image_norm += norm;
    if (s.name.rfind("latent_discriminator/", 0) == 0) latent_norm += norm;
  }
  EXPECT_EQ(image_norm, 0.0);
  EXPECT_GT(latent_norm, 0.0);
}

TEST_F(DeepfakeTrainerTest, LossFallsOnATinyDataset) {
  DeepfakeModel model(TinyNetwork(), 7);
  DeepfakeLossOptions losses;
  losses.learning_rate = 2e-3f;
  DeepfakeTrainer trainer(&model, losses);
  double first = 0, last = 0;
  const int steps = 60;
  for (int step = 0; step < steps; ++step) {
    const DeepfakeLosses l = trainer.Backward(MakeBatch(a_, b_, (step * 4) % 12, 4, step), 1.0);
    trainer.OptimizerStep();
    if (step < 5) first += l.recon_a + l.recon_b;
    if (step >= steps - 5) last += l.recon_a + l.recon_b;
  }
  EXPECT_EQ(trainer.step(), steps);
  EXPECT_LT(last, 0.6 * first) << "first 5 steps " << first / 5 << ", last 5 steps " << last / 5;
}

// The palette terms (weighted region cross-entropy, region-weighted L1 and soft Dice of D_A's
// output): split shares still sum to the whole batch's gradient, and training lowers them.
TEST_F(DeepfakeTrainerTest, PaletteTermsSplitExactlyAndFall) {
  DeepfakeLossOptions losses;
  losses.learning_rate = 2e-3f;
  losses.palette_weight = 1.f;
  losses.region_l1_weight = 1.f;
  losses.dice_weight = 1.f;
  const std::vector<float> colors = {0.f, 0.f, 0.f, 250 / 255.f, 40 / 255.f, 40 / 255.f};
  const std::vector<float> weights = {0.6f, 2.5f};
  {
    const TrainingBatch batch = MakeBatch(a_, b_, 0, 6, 3);
    DeepfakeModel model(TinyNetwork(), 7);
    DeepfakeTrainer trainer(&model, losses);
    trainer.SetPalette(colors, weights);
    const DeepfakeLosses whole = trainer.Backward(batch, 1.0);
    EXPECT_GT(whole.palette_a, 0.0);
    EXPECT_GT(whole.region_l1_a, 0.0);
    EXPECT_GT(whole.dice_a, 0.0);
    const std::vector<float> full(trainer.gradients(), trainer.gradients() + trainer.num_gradients());
    std::vector<float> sum(full.size(), 0.f);
    double palette = 0, region_l1 = 0, dice = 0;
    for (const auto& [first, count] : {std::pair<int, int>{0, 4}, std::pair<int, int>{4, 2}}) {
      const DeepfakeLosses part = trainer.Backward(Slice(batch, first, count), count / 6.0);
      palette += part.palette_a;
      region_l1 += part.region_l1_a;
      dice += part.dice_a;
      for (size_t i = 0; i < sum.size(); ++i) sum[i] += trainer.gradients()[i];
    }
    double max_err = 0, max_abs = 0;
    for (size_t i = 0; i < sum.size(); ++i) {
      max_err = std::max(max_err, static_cast<double>(std::abs(sum[i] - full[i])));
      max_abs = std::max(max_abs, static_cast<double>(std::abs(full[i])));
    }
    EXPECT_LT(max_err, 1e-4 * max_abs);
    EXPECT_NEAR(palette, whole.palette_a, 1e-5);
    EXPECT_NEAR(region_l1, whole.region_l1_a, 1e-5);
    EXPECT_NEAR(dice, whole.dice_a, 1e-5);
  }
  DeepfakeModel model(TinyNetwork(), 7);
  DeepfakeTrainer trainer(&model, losses);
  trainer.SetPalette(colors, weights);
  double first = 0, last = 0, first_l1 = 0, last_l1 = 0, first_dice = 0, last_dice = 0;
  const int steps = 60;
  for (int step = 0; step < steps; ++step) {
    const DeepfakeLosses l = trainer.Backward(MakeBatch(a_, b_, (step * 4) % 12, 4, step), 1.0);
    trainer.OptimizerStep();
    if (step < 5) {
      first += l.palette_a;
      first_l1 += l.region_l1_a;
      first_dice += l.dice_a;
    }
    if (step >= steps - 5) {
      last += l.palette_a;
      last_l1 += l.region_l1_a;
      last_dice += l.dice_a;
    }
  }
  EXPECT_LT(last, 0.5 * first) << "first 5 steps " << first / 5 << ", last 5 steps " << last / 5;
  EXPECT_LT(last_l1, 0.6 * first_l1) << "first 5 steps " << first_l1 / 5 << ", last 5 steps " << last_l1 / 5;
  EXPECT_LT(last_dice, 0.6 * first_dice) << "first 5 steps " << first_dice / 5 << ", last 5 steps " << last_dice / 5;
  EXPECT_THROW(trainer.SetPalette({0.f, 0.f}, {1.f}), InvalidInputError);
}

// The palette head: D_A's last layer gives one logit per palette colour, the model file
// records how many, its translations show palette colours only, and training it on the
// palette term teaches it domain A's labels.
TEST_F(DeepfakeTrainerTest, PaletteHeadTranslatesIntoPaletteColoursAndLearnsTheLabels) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.palette_colors = 2;
  const std::vector<float> colors = {0.f, 0.f, 0.f, 250 / 255.f, 40 / 255.f, 40 / 255.f};
  DeepfakeModel model(o, 7);
  EXPECT_THROW(model.SetPalette({0.f, 0.f, 0.f}), InvalidInputError);
  model.SetPalette(colors);
  for (const TensorSlot& s : model.ParameterLayout()) {
    if (s.name == "decoder_a/rgb/weight") {
      EXPECT_EQ(s.shape, (std::vector<int64_t>{2, 8, 3, 3}));
    }
    if (s.name == "decoder_b/rgb/weight") {
      EXPECT_EQ(s.shape, (std::vector<int64_t>{3, 8, 3, 3}));
    }
  }
  DeepfakeLossOptions losses;
  losses.learning_rate = 2e-3f;
  losses.palette_weight = 1.f;
  DeepfakeTrainer trainer(&model, losses);
  trainer.SetPalette(colors, {0.6f, 2.5f});
  double first = 0, last = 0;
  const int steps = 60;
  for (int step = 0; step < steps; ++step) {
    const DeepfakeLosses l = trainer.Backward(MakeBatch(a_, b_, (step * 4) % 12, 4, step), 1.0);
    trainer.OptimizerStep();
    if (step < 5) first += l.palette_a;
    if (step >= steps - 5) last += l.palette_a;
  }
  EXPECT_LT(last, 0.3 * first) << "first 5 steps " << first / 5 << ", last 5 steps " << last / 5;
  // Translations of A: every pixel is black or the disc's colour, and mostly the right one.
  const int count = 8;
  std::vector<uint8_t> out(count * kSize * kSize * 3);
  model.Translate(a_.data(), count, DeepfakeModel::Decoder::kA, out.data(), nullptr, nullptr);
  int wrong = 0, discs = 0;  // all black would get the disc pixels wrong
  for (int i = 0; i < count * kSize * kSize; ++i) {
    const uint8_t* p = &out[3 * i];
    const bool disc = p[0] == 250 && p[1] == 40 && p[2] == 40;
    ASSERT_TRUE(disc || (p[0] == 0 && p[1] == 0 && p[2] == 0)) << "pixel " << i;
    wrong += disc != (a_[3 * i] > 0);
    discs += a_[3 * i] > 0;
  }
  EXPECT_LT(wrong, 0.5 * discs) << "of " << count * kSize * kSize << " pixels";
  // Shift averaging over moves of two pixels: other labels at some pixels, no more wrong ones
  // than a few (here 126 against 130; labels moved the wrong way back: 268).
  model.SetShiftAverage(2);
  std::vector<uint8_t> shifted(out.size());
  model.Translate(a_.data(), count, DeepfakeModel::Decoder::kA, shifted.data(), nullptr, nullptr);
  model.SetShiftAverage(0);
  EXPECT_NE(shifted, out);
  int wrong_shifted = 0;
  for (int i = 0; i < count * kSize * kSize; ++i) {
    wrong_shifted += (shifted[3 * i] == 250) != (a_[3 * i] > 0);
  }
  EXPECT_LE(wrong_shifted, wrong + discs / 10) << wrong_shifted << " wrong, single pass " << wrong;

  testing::TempDir dir;
  const std::unique_ptr<DeepfakeModel> read_back = RoundTrip(&model, dir.File("model.h5"));
  EXPECT_EQ(read_back->options().palette_colors, 2);
  read_back->SetPalette(colors);
  std::vector<uint8_t> again(out.size());
  read_back->Translate(a_.data(), count, DeepfakeModel::Decoder::kA, again.data(), nullptr, nullptr);
  EXPECT_EQ(again, out);
  o.palette_colors = 1;
  EXPECT_THROW(DeepfakeModel(o, 7), InvalidInputError);
}

// Flip averaging makes D_A's labels mirror-equivariant: the translation of a mirror image is
// the mirrored translation with its left and right regions swapped (up to pixels whose two
// best regions tie within rounding).
TEST_F(DeepfakeTrainerTest, FlipAveragedLabelsOfAMirrorImageAreTheMirroredLabels) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.palette_colors = 3;  // background, a left region (red), its right region (blue)
  DeepfakeModel model(o, 11);
  model.SetPalette({0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 0.f, 1.f});
  EXPECT_THROW(model.SetFlipAverage({0, 2}), InvalidInputError);
  EXPECT_THROW(model.SetFlipAverage({0, 2, 3}), InvalidInputError);
  model.SetFlipAverage({0, 2, 1});
  const int count = 4, one = kSize * kSize * 3;
  std::vector<uint8_t> mirrored_inputs(a_.size());
  for (int i = 0; i < count * kSize; ++i) {  // each row reversed
    for (int x = 0; x < kSize; ++x) {
      std::copy_n(&a_[(i * kSize + x) * 3], 3, &mirrored_inputs[(i * kSize + kSize - 1 - x) * 3]);
    }
  }
  std::vector<uint8_t> out(count * one), out_of_mirror(count * one);
  model.Translate(a_.data(), count, DeepfakeModel::Decoder::kA, out.data(), nullptr, nullptr);
  model.Translate(mirrored_inputs.data(), count, DeepfakeModel::Decoder::kA, out_of_mirror.data(),
                  nullptr, nullptr);
  int differing = 0, red = 0, blue = 0;
  for (int i = 0; i < count * kSize; ++i) {
    for (int x = 0; x < kSize; ++x) {
      const uint8_t* p = &out[(i * kSize + x) * 3];
      const uint8_t* q = &out_of_mirror[(i * kSize + kSize - 1 - x) * 3];
      red += p[0] == 255;
      blue += p[2] == 255;
      differing += p[0] != q[2] || p[1] != q[1] || p[2] != q[0];  // red and blue swapped
    }
  }
  EXPECT_GT(red + blue, 0) << "the labels of the untrained head should not be all background";
  EXPECT_LE(differing, 2) << "of " << count * kSize * kSize << " pixels";
}

// Shift averaging (the image moved by d pixels either way in x, y or both, each moved back),
// its moves being symmetric, keeps flip averaging's mirror equivariance. (Its labels of a
// trained head: the palette head test.)
TEST_F(DeepfakeTrainerTest, ShiftAveragedLabelsKeepTheMirrorEquivariance) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.palette_colors = 3;
  DeepfakeModel model(o, 11);
  model.SetPalette({0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 0.f, 1.f});
  EXPECT_THROW(model.SetShiftAverage(-1), InvalidInputError);
  const int count = 4, one = kSize * kSize * 3;
  auto translate = [&](const std::vector<uint8_t>& images, int shift) {
    model.SetShiftAverage(shift);
    std::vector<uint8_t> out(count * one);
    model.Translate(images.data(), count, DeepfakeModel::Decoder::kA, out.data(), nullptr, nullptr);
    return out;
  };
  model.SetFlipAverage({0, 2, 1});
  std::vector<uint8_t> mirrored_inputs(a_.size());
  for (int i = 0; i < count * kSize; ++i) {
    for (int x = 0; x < kSize; ++x) {
      std::copy_n(&a_[(i * kSize + x) * 3], 3, &mirrored_inputs[(i * kSize + kSize - 1 - x) * 3]);
    }
  }
  const std::vector<uint8_t> out = translate(a_, 2), out_of_mirror = translate(mirrored_inputs, 2);
  int differing = 0, labelled = 0;
  for (int i = 0; i < count * kSize; ++i) {
    for (int x = 0; x < kSize; ++x) {
      const uint8_t* p = &out[(i * kSize + x) * 3];
      const uint8_t* q = &out_of_mirror[(i * kSize + kSize - 1 - x) * 3];
      labelled += p[0] == 255 || p[2] == 255;
      differing += p[0] != q[2] || p[1] != q[1] || p[2] != q[0];
    }
  }
  EXPECT_GT(labelled, 0);
  EXPECT_LE(differing, 2) << "of " << count * kSize * kSize << " pixels";
}

// Label upsampling interpolates D_A's log-probabilities bilinearly: an argmax of a convex
// combination of vectors that share their argmax keeps it, so every pixel of the network's
// size whose 3 x 3 neighbourhood has one label gives that label to its 2 x 2 block; the other
// blocks may split (borders between the network's pixels). The codes are those of the
// translation at the network's size.
TEST_F(DeepfakeTrainerTest, LabelScaleKeepsTheLabelsOfUniformNeighbourhoods) {
  DeepfakeNetworkOptions o = TinyNetwork();
  o.palette_colors = 3;
  DeepfakeModel model(o, 11);
  model.SetPalette({0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 0.f, 1.f});
  model.SetFlipAverage({0, 2, 1});
  model.SetShiftAverage(1);
  EXPECT_THROW(model.SetLabelScale(0), InvalidInputError);
  EXPECT_THROW(model.SetLabelScale(5), InvalidInputError);
  const int count = 4, big = 2 * kSize;
  const int64_t latent = o.LatentSize();
  auto label = [](const uint8_t* p) { return p[0] == 255 ? 1 : p[2] == 255 ? 2 : 0; };
  std::vector<uint8_t> plain(count * kSize * kSize * 3), scaled(count * big * big * 3);
  std::vector<float> code(count * latent), code2(count * latent), code_scaled(count * latent),
      code2_scaled(count * latent);
  model.Translate(a_.data(), count, DeepfakeModel::Decoder::kA, plain.data(), code.data(), code2.data());
  model.SetLabelScale(2);
  EXPECT_EQ(model.TranslationSize(DeepfakeModel::Decoder::kA), big);
  EXPECT_EQ(model.TranslationSize(DeepfakeModel::Decoder::kB), kSize);
  model.Translate(a_.data(), count, DeepfakeModel::Decoder::kA, scaled.data(), code_scaled.data(),
                  code2_scaled.data());
  EXPECT_EQ(code_scaled, code);
  EXPECT_EQ(code2_scaled, code2);
  int uniform = 0, split = 0;
  for (int i = 0; i < count; ++i) {
    auto native = [&](int x, int y) {
      x = std::clamp(x, 0, kSize - 1);
      y = std::clamp(y, 0, kSize - 1);
      return label(&plain[((i * kSize + y) * kSize + x) * 3]);
    };
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        bool same = true;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) same = same && native(x + dx, y + dy) == native(x, y);
        }
        for (int sy = 0; sy < 2; ++sy) {
          for (int sx = 0; sx < 2; ++sx) {
            const int l = label(&scaled[((i * big + 2 * y + sy) * big + 2 * x + sx) * 3]);
            if (same) {
              ASSERT_EQ(l, native(x, y)) << "image " << i << " pixel " << x << ", " << y;
            }
            split += l != native(x, y);
          }
        }
        uniform += same;
      }
    }
  }
  EXPECT_GT(uniform, count * kSize * kSize / 4);
  EXPECT_GT(split, 0) << "the upsampled labels should move some borders off the pixel grid";
}

TEST_F(DeepfakeTrainerTest, CheckpointContinuesBitwiseLikeTrainingStraightThrough) {
  testing::TempDir dir;
  auto train = [&](DeepfakeTrainer* trainer, int from, int to) {
    for (int step = from; step < to; ++step) {
      trainer->Backward(MakeBatch(a_, b_, step % 12, 4, step), 1.0);
      trainer->OptimizerStep();
    }
  };
  DeepfakeModel straight_model(TinyNetwork(), 7);
  DeepfakeTrainer straight(&straight_model, DeepfakeLossOptions{});
  train(&straight, 0, 6);

  const std::string path = dir.File("ckpt.h5");
  {
    DeepfakeModel model(TinyNetwork(), 7);
    DeepfakeTrainer trainer(&model, DeepfakeLossOptions{});
    train(&trainer, 0, 3);
    io::H5File f = io::H5File::CreateAtomic(path);
    WriteWeights(&f, &model);
    WriteTrainingState(&f, &trainer, {trainer.step(), 5});
    f.Commit();
  }
  DeepfakeModel resumed_model(TinyNetwork(), 99);  // other initial weights: all are replaced
  DeepfakeTrainer resumed(&resumed_model, DeepfakeLossOptions{});
  {
    io::H5File f = io::H5File::OpenRead(path);
    ReadWeights(f, &resumed_model);
    const TrainingState state = ReadTrainingState(f, &resumed);
    EXPECT_EQ(state.step, 3);
    EXPECT_EQ(state.rng_seed, 5u);
  }
  train(&resumed, 3, 6);
  EXPECT_EQ(resumed.step(), 6);
  EXPECT_EQ(resumed_model.ParameterHash(), straight_model.ParameterHash());
  EXPECT_EQ(0, std::memcmp(resumed.first_moments(), straight.first_moments(),
                           sizeof(float) * straight.num_gradients()));
}

TEST_F(DeepfakeTrainerTest, MismatchedOrTruncatedCheckpointsAreNamed) {
  testing::TempDir dir;
  const std::string path = dir.File("model.h5");
  {
    DeepfakeModel model(TinyNetwork(), 7);
    io::H5File f = io::H5File::CreateAtomic(path);
    WriteWeights(&f, &model);
    f.Commit();
  }
  DeepfakeNetworkOptions wider = TinyNetwork();
  wider.encoder_width = 12;
  DeepfakeModel other(wider, 7);
  try {
    ReadWeights(io::H5File::OpenRead(path), &other);
    FAIL() << "a checkpoint of another width was accepted";
  } catch (const FileIOError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/weights/encoder/down0/weight has shape [8, 3, 5, 5], the network "
                        "expects [12, 3, 5, 5]"), std::string::npos) << what;
  }
  // The stored architecture rebuilds the right network.
  EXPECT_EQ(ReadNetworkOptions(io::H5File::OpenRead(path)).encoder_width, 8);
  // A truncated file.
  const auto bytes = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, bytes / 2);
  EXPECT_THROW(
      {
        io::H5File f = io::H5File::OpenRead(path);
        DeepfakeModel model(TinyNetwork(), 7);
        ReadWeights(f, &model);
      },
      FileIOError);
}

TEST_F(DeepfakeTrainerTest, TranslateWritesImagesAndBothCodes) {
  DeepfakeModel model(TinyNetwork(), 7);
  const int64_t latent = model.options().LatentSize();
  std::vector<uint8_t> out(2 * kSize * kSize * 3);
  std::vector<float> code(2 * latent), code2(2 * latent);
  model.Translate(b_.data(), 2, DeepfakeModel::Decoder::kA, out.data(), code.data(), code2.data());
  // Batch of one gives the same first image as the batch of two.
  std::vector<uint8_t> one(kSize * kSize * 3);
  std::vector<float> code_one(latent);
  model.Translate(b_.data(), 1, DeepfakeModel::Decoder::kA, one.data(), code_one.data(), nullptr);
  for (int64_t i = 0; i < latent; ++i) EXPECT_NEAR(code_one[i], code[i], 1e-5);
  EXPECT_NE(code, code2);
}

TEST(Augment, NeutralOptionsReproduceTheImage) {
  AugmentOptions none;
  none.warp = 0; none.rotate_deg = 0; none.scale = 0; none.shift = 0; none.flip = false;
  none.color_jitter = 0;
  const std::vector<uint8_t> image = TinyImages(1, true, 4);
  std::vector<float> input(image.size()), target(image.size());
  Rng rng(1, 2);
  AugmentPair(image.data(), kSize, kSize, none, PairKind::kCamera, &rng, input.data(),
              target.data());
  for (size_t i = 0; i < image.size(); ++i) {
    ASSERT_NEAR(target[i] * 255.f, image[i], 1e-3) << i;
    ASSERT_EQ(input[i], target[i]);
  }
}

// A paired camera frame and its segmentation move together: the warp that the autoencoder's
// pairs put on the input alone is applied to both, so a label stays under the pixels that show
// it; the target is sampled nearest (its colours are labels and must not blend), and the
// colour jitter reaches the input only.
TEST(Augment, PairedCameraFramesShareTheWarpWithTheirTarget) {
  AugmentOptions o;
  o.warp = 0.08f;
  const std::vector<uint8_t> image = TinyImages(1, false, 9);  // a flat disc on black
  const size_t n = image.size();
  std::vector<float> input(n), target(n), seg_input(n), seg_target(n), jittered(n);
  auto mean_difference = [](const std::vector<float>& x, const std::vector<float>& y) {
    double d = 0;
    for (size_t i = 0; i < x.size(); ++i) d += std::abs(x[i] - y[i]);
    return d / x.size();
  };
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    o.color_jitter = 0;
    Rng a(seed, 0), b(seed, 0);
    AugmentPair(image.data(), kSize, kSize, o, PairKind::kPairedCamera, &a, input.data(),
                target.data(), image.data());
    AugmentPair(image.data(), kSize, kSize, o, PairKind::kSegmentation, &b, seg_input.data(),
                seg_target.data());
    for (size_t i = 0; i < n; i += 3) {
      auto is = [&](size_t k, float level) { return std::abs(target[k] * 255.f - level) < 1e-3f; };
      const bool disc = is(i, 250.f) && is(i + 1, 40.f) && is(i + 2, 40.f);
      const bool black = target[i] == 0.f && target[i + 1] == 0.f && target[i + 2] == 0.f;
      ASSERT_TRUE(disc || black) << "seed " << seed << ", pixel " << i / 3 << ": a blended label";
    }
    EXPECT_LT(mean_difference(seg_input, input), 1e-6) << "seed " << seed << ": the same warped input";
    // Pixels whose disc-or-black label differs between an input and its target.
    auto label_differences = [](const std::vector<float>& x, const std::vector<float>& y) {
      int d = 0;
      for (size_t i = 0; i < x.size(); i += 3) d += (x[i] > 0.5f) != (y[i] > 0.5f);
      return d;
    };
    // The paired target's labels follow the warped input but for a few border pixels, where
    // nearest and bilinear sampling part; the autoencoder's target, not warped, differs more.
    const int paired = label_differences(input, target);
    const int autoencoder = label_differences(seg_input, seg_target);
    EXPECT_LT(2 * paired, autoencoder) << "seed " << seed << ": the warp moves both alike";
    o.color_jitter = 0.3f;
    Rng c(seed, 0);
    AugmentPair(image.data(), kSize, kSize, o, PairKind::kPairedCamera, &c, jittered.data(),
                seg_target.data(), image.data());
    EXPECT_EQ(seg_target, target) << "seed " << seed << ": the target keeps its colours";
    EXPECT_GT(mean_difference(jittered, input), 0.01) << "seed " << seed << ": the input is jittered";
  }
}

// Without the sides' colours, segmentation targets are never mirrored (a mirror would paint the
// left brow where the right one is); camera pairs are, half of the time.
TEST(Augment, OnlyCameraPairsAreFlipped) {
  AugmentOptions o;
  o.warp = 0; o.rotate_deg = 0; o.scale = 0; o.shift = 0; o.color_jitter = 0; o.flip = true;
  const std::vector<uint8_t> image = TinyImages(1, true, 5);
  std::vector<float> input(image.size()), target(image.size());
  int camera_flips = 0;
  for (uint64_t seed = 1; seed <= 16; ++seed) {
    for (PairKind kind : {PairKind::kSegmentation, PairKind::kPairedCamera, PairKind::kCamera}) {
      Rng rng(seed, 0);
      AugmentPair(image.data(), kSize, kSize, o, kind, &rng, input.data(), target.data(),
                  image.data());
      bool same = true;
      for (size_t i = 0; i < image.size(); ++i) {
        same = same && std::abs(target[i] * 255.f - image[i]) < 1e-3f;
      }
      if (kind == PairKind::kCamera) camera_flips += same ? 0 : 1;
      else EXPECT_TRUE(same) << "seed " << seed << ": a segmentation target was mirrored";
    }
  }
  EXPECT_GT(camera_flips, 3);
  EXPECT_LT(camera_flips, 13);
}

// The background mask is the black that reaches the border: a black pupil enclosed by the
// iris stays, and a replaced background changes nothing else.
TEST(Augment, BackgroundReplacementKeepsEnclosedBlackRegions) {
  constexpr int n = 16;
  std::vector<uint8_t> seg(3 * n * n, 0);
  auto paint = [&](int x0, int y0, int x1, int y1, uint8_t r, uint8_t g, uint8_t b) {
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        seg[3 * (y * n + x)] = r;
        seg[3 * (y * n + x) + 1] = g;
        seg[3 * (y * n + x) + 2] = b;
      }
  };
  paint(3, 3, 13, 13, 200, 150, 120);  // a face
  paint(6, 6, 10, 10, 0, 180, 140);    // an iris
  paint(7, 7, 9, 9, 0, 0, 0);          // its black pupil
  const std::vector<uint8_t> mask = BorderBackgroundMask(seg.data(), n);
  int background = 0;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const bool outside = x < 3 || x >= 13 || y < 3 || y >= 13;
      EXPECT_EQ(mask[y * n + x], outside ? 1 : 0) << x << "," << y;
      background += mask[y * n + x];
    }
  }
  EXPECT_EQ(background, n * n - 100);
  std::vector<uint8_t> camera(3 * n * n), other(3 * n * n), out(3 * n * n);
  for (size_t i = 0; i < camera.size(); ++i) {
    camera[i] = static_cast<uint8_t>(i * 7);
    other[i] = static_cast<uint8_t>(255 - i);
  }
  ReplaceBackground(camera.data(), other.data(), mask, n, out.data());
  for (int i = 0; i < n * n; ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(out[3 * i + c], mask[i] ? other[3 * i + c] : camera[3 * i + c]);
    }
  }
  AugmentOptions o;
  o.random_background = 1.5f;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
}

}  // namespace
}  // namespace facecap::nn
