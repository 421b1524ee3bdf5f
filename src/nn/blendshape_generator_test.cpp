// The blendshape generator's inference form (PredictOffsets: oneDNN convolutions, output layers
// and sampling folded into one matrix, heads and amplitude in plain loops) against the training
// modules' forward on small random networks: the same offsets to float rounding, with and
// without the Tuning Stage, after the parameters change, and from several threads at once.
#include "nn/blendshape_generator.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <thread>
#include <utility>
#include <vector>

#include <ATen/Context.h>
#include <gtest/gtest.h>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

constexpr int kSize = 16;

// A geometry of `shapes` shapes on `vertices` chart vertices with random stencils and template.
std::shared_ptr<BlendshapeNetGeometry> RandomGeometry(int shapes, const std::vector<int>& large, int vertices,
                                                      uint64_t seed) {
  Rng rng(seed, 0);
  auto g = std::make_shared<BlendshapeNetGeometry>();
  g->image_size = kSize;
  g->num_shapes = shapes;
  g->num_chart_vertices = vertices;
  g->large_motion_shapes = large;
  for (int i = 0; i < shapes * vertices * 3; ++i) g->template_deltas.push_back(static_cast<float>(rng.Normal()));
  g->reg_weights.assign(static_cast<size_t>(shapes) * vertices, 1.f);
  for (int k = 0; k < vertices; ++k) {
    const int x = static_cast<int>(rng.UniformInt(kSize - 1)), y = static_cast<int>(rng.UniformInt(kSize - 1));
    const float tx = static_cast<float>(rng.Uniform()), ty = static_cast<float>(rng.Uniform());
    for (int p : {y * kSize + x, y * kSize + x + 1, (y + 1) * kSize + x, (y + 1) * kSize + x + 1}) {
      g->sample_pixels.push_back(p);
    }
    for (float w : {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty}) g->sample_weights.push_back(w);
  }
  g->num_static_channels = 4;
  for (int i = 0; i < 4 * kSize * kSize; ++i) g->static_channels.push_back(static_cast<float>(rng.Normal()));
  return g;
}

BlendshapeNetOptions SmallNetwork() {
  BlendshapeNetOptions o;
  o.channels = 4;
  o.residual_blocks = 2;
  o.amplitude_components = 0;  // the pooled-image amplitude (the tests of the other one set it)
  return o;
}

std::vector<float> RandomImage(uint64_t seed) {
  Rng rng(seed, 1);
  std::vector<float> image(3 * kSize * kSize);
  for (float& v : image) v = static_cast<float>(rng.Normal());
  return image;
}

// The initial parameters with noise on every one (the output layers start at zero).
void Perturb(BlendshapeGenerator* model, uint64_t seed, double sigma = 0.05) {
  Rng rng(seed, 2);
  std::vector<float> p = model->Parameters();
  for (float& v : p) v += static_cast<float>(sigma * rng.Normal());
  model->SetParameters(p);
}

// Largest difference relative to the largest reference value; the reference must move.
double RelativeDifference(const std::vector<float>& fast, const std::vector<float>& reference) {
  EXPECT_EQ(fast.size(), reference.size());
  double diff = 0, scale = 0;
  for (size_t i = 0; i < std::min(fast.size(), reference.size()); ++i) {
    diff = std::max(diff, static_cast<double>(std::abs(fast[i] - reference[i])));
    scale = std::max(scale, static_cast<double>(std::abs(reference[i])));
  }
  EXPECT_GT(scale, 1e-3) << "the reference offsets are all but zero";
  return diff / scale;
}

// A person with random geometry for a geometry of `shapes` shapes on `vertices` vertices.
BlendshapePerson RandomPerson(int shapes, int vertices, uint64_t seed) {
  Rng rng(seed, 4);
  BlendshapePerson p;
  p.num_expressions = 2;
  p.neutral_image = RandomImage(seed);
  for (int i = 0; i < vertices * 3; ++i) p.neutral.push_back(static_cast<float>(rng.Normal()));
  for (int i = 0; i < 2 * vertices * 3; ++i) p.expressions.push_back(static_cast<float>(rng.Normal()));
  for (int i = 0; i < 2 * 3 * kSize * kSize; ++i) p.expression_images.push_back(static_cast<float>(rng.Normal()));
  for (int i = 0; i < 2 * shapes; ++i) p.nominal_weights.push_back(i % 3 == 0 ? 0.9f : 0.f);
  return p;
}

constexpr double kTolerance = 1e-5;

// (Also for the networks of older models: one hidden layer in the heads, the amplitude on all
// offsets, heads without the motion frame, no amplitude.)
TEST(BlendshapeGenerator, InferenceFormMatchesTheModulesWithAndWithoutTuning) {
  struct Case { int shapes; std::vector<int> large; bool frame; int amplitude; bool on_path; int depth; bool local = false; };
  for (const Case& c : {Case{20, {3, 7, 1, 12, 18}, true, 32, true, 2}, Case{9, {0, 1, 2, 3, 4, 5, 6, 7}, true, 8, true, 2},
                        Case{20, {3, 7, 1, 12, 18}, true, 32, true, 2, true},
                        Case{20, {3, 7, 1, 12, 18}, true, 32, true, 1}, Case{20, {3, 7, 1, 12, 18}, true, 32, false, 1},
                        Case{20, {3, 7, 1, 12, 18}, false, 16, true, 1}, Case{20, {3, 7, 1, 12, 18}, false, 0, false, 1}}) {
    BlendshapeNetOptions options = SmallNetwork();
    options.head_depth = c.depth;
    options.head_frame = c.frame;
    options.head_local_frame = c.local;
    options.amplitude_width = c.amplitude;
    options.amplitude_on_path = c.on_path;
    BlendshapeGenerator model(options, RandomGeometry(c.shapes, c.large, 37, c.shapes));
    Perturb(&model, 5);
    for (uint64_t seed : {1, 2}) {
      const std::vector<float> image = RandomImage(seed);
      for (bool tuned : {false, true}) {
        const std::vector<float> fast = model.PredictOffsets(image, tuned);
        ASSERT_EQ(fast.size(), static_cast<size_t>(c.shapes) * 37 * 3);
        EXPECT_LT(RelativeDifference(fast, model.PredictOffsetsWithModules(image, tuned)), kTolerance)
            << c.shapes << " shapes, depth " << c.depth << ", frame " << c.frame << ", amplitude " << c.amplitude << ", on path " << c.on_path
            << ", local frame " << c.local << ", tuned " << tuned;
      }
    }
  }
}

TEST(BlendshapeGenerator, InferenceFormWithoutOneDnnMatchesTheModules) {
  const bool enabled = at::globalContext().userEnabledMkldnn();
  at::globalContext().setUserEnabledMkldnn(false);
  BlendshapeGenerator model(SmallNetwork(), RandomGeometry(20, {3, 7, 1, 12, 18}, 37, 2));
  Perturb(&model, 9);
  const std::vector<float> image = RandomImage(4);
  const std::vector<float> fast = model.PredictOffsets(image, true);
  const std::vector<float> reference = model.PredictOffsetsWithModules(image, true);
  at::globalContext().setUserEnabledMkldnn(enabled);
  EXPECT_LT(RelativeDifference(fast, reference), kTolerance);
}

TEST(BlendshapeGenerator, InferenceFormFollowsParameterChanges) {
  const auto geometry = RandomGeometry(12, {2, 5, 9}, 25, 3);
  BlendshapeGenerator model(SmallNetwork(), geometry);
  Perturb(&model, 6);
  const std::vector<float> image = RandomImage(3);
  const std::vector<float> before = model.PredictOffsets(image, true);
  // A training step (Backward + OptimizerStep) changes the parameters in place.
  const BlendshapePerson person = RandomPerson(12, 25, 3);
  for (TrainingStage stage : {TrainingStage::kEstimation, TrainingStage::kTuning}) {
    model.Backward({&person}, stage, 1.f);
    model.OptimizerStep(stage);
    const std::vector<float> after = model.PredictOffsets(image, true);
    EXPECT_LT(RelativeDifference(after, model.PredictOffsetsWithModules(image, true)), kTolerance);
    EXPECT_NE(after, before);
  }
  // SetParameters back to the first parameters gives the first offsets again.
  BlendshapeGenerator other(SmallNetwork(), geometry);
  Perturb(&other, 6);
  model.SetParameters(other.Parameters());
  EXPECT_LT(RelativeDifference(model.PredictOffsets(image, true), before), kTolerance);
}

// Ranks each run Backward on their share of the batch with loss_scale 1 / (global batch) and
// sum the gradients: the shares' gradients must add up to the whole batch's, the amplitude's
// ridge term (amplitude_decay) counted once, not once per share.
TEST(BlendshapeGenerator, SharesOfABatchSumToTheWholeGradientWithTheRidgeTerm) {
  BlendshapeNetOptions options = SmallNetwork();
  options.amplitude_decay = 0.5f;
  BlendshapeGenerator model(options, RandomGeometry(12, {2, 5, 9}, 25, 4));
  Perturb(&model, 12);
  const BlendshapePerson a = RandomPerson(12, 25, 1), b = RandomPerson(12, 25, 2), c = RandomPerson(12, 25, 3);
  const int64_t n = model.NumParameters();
  model.Backward({&a, &b, &c}, TrainingStage::kEstimation, 1.f / 3);
  const std::vector<float> whole(model.GradientBuffer(), model.GradientBuffer() + n);
  model.Backward({&a}, TrainingStage::kEstimation, 1.f / 3);
  std::vector<float> summed(model.GradientBuffer(), model.GradientBuffer() + n);
  model.Backward({&b, &c}, TrainingStage::kEstimation, 1.f / 3);
  for (int64_t i = 0; i < n; ++i) summed[i] += model.GradientBuffer()[i];
  EXPECT_LT(RelativeDifference(summed, whole), 1e-5);
  // The ridge term is in the gradient: without it the amplitude's gradient differs.
  options.amplitude_decay = 0.f;
  BlendshapeGenerator plain(options, RandomGeometry(12, {2, 5, 9}, 25, 4));
  plain.SetParameters(model.Parameters());
  plain.Backward({&a, &b, &c}, TrainingStage::kEstimation, 1.f / 3);
  const std::vector<float> without(plain.GradientBuffer(), plain.GradientBuffer() + n);
  EXPECT_GT(RelativeDifference(without, whole), 1e-3);
}

// weight_decay (AdamW's decoupled form): with a zero gradient, Adam moves nothing and a step
// only shrinks the weight matrices of the stage in training by 1 - learning_rate x weight_decay;
// biases, the amplitude and the other stage's parameters stay bitwise, and without the decay the
// step changes nothing at all.
TEST(BlendshapeGenerator, WeightDecayShrinksOnlyTheWeightMatricesOfTheStageInTraining) {
  BlendshapeNetOptions options = SmallNetwork();
  options.learning_rate = 0.01f;
  options.weight_decay = 0.5f;
  const auto geometry = RandomGeometry(12, {2, 5, 9}, 25, 6);
  // One step of `stage` on a zero gradient (an empty share): the parameters before and after.
  auto zero_gradient_step = [&](const BlendshapeNetOptions& o, TrainingStage stage) {
    BlendshapeGenerator model(o, geometry);
    Perturb(&model, 14);
    std::pair<std::vector<float>, std::vector<float>> before_after{model.Parameters(), {}};
    model.Backward({}, stage, 1.f);
    model.OptimizerStep(stage);
    before_after.second = model.Parameters();
    return before_after;
  };
  const float keep = 1.f - 0.01f * 0.5f;
  std::vector<uint8_t> decayed[2];
  for (TrainingStage stage : {TrainingStage::kEstimation, TrainingStage::kTuning}) {
    const auto [before, after] = zero_gradient_step(options, stage);
    std::vector<uint8_t>& d = decayed[stage == TrainingStage::kEstimation ? 0 : 1];
    for (size_t i = 0; i < before.size(); ++i) {
      const bool same = after[i] == before[i];
      const bool shrunk = std::abs(after[i] - keep * before[i]) <= 1e-6f * std::abs(before[i]);
      ASSERT_TRUE(same || shrunk) << "parameter " << i << ": " << before[i] << " -> " << after[i];
      d.push_back(!same);
    }
    EXPECT_GT(std::count(d.begin(), d.end(), 1), 100);
    EXPECT_GT(std::count(d.begin(), d.end(), 0), 10);  // the biases at least
  }
  for (size_t i = 0; i < decayed[0].size(); ++i) {
    EXPECT_FALSE(decayed[0][i] && decayed[1][i]) << "parameter " << i << " decayed in both stages";
  }
  // The amplitude's weight matrices are not decayed (amplitude_decay covers them): without an
  // amplitude the model has fewer parameters but as many decayed ones.
  BlendshapeNetOptions no_amplitude = options;
  no_amplitude.amplitude_width = 0;
  const auto [first, second] = zero_gradient_step(no_amplitude, TrainingStage::kEstimation);
  ASSERT_LT(first.size(), decayed[0].size());
  int64_t changed = 0;
  for (size_t i = 0; i < first.size(); ++i) changed += first[i] != second[i] ? 1 : 0;
  EXPECT_EQ(changed, std::count(decayed[0].begin(), decayed[0].end(), 1));
  // Without the decay a zero gradient changes nothing.
  options.weight_decay = 0.f;
  const auto [plain_before, plain_after] = zero_gradient_step(options, TrainingStage::kEstimation);
  EXPECT_EQ(plain_after, plain_before);
}

// amplitude_components: the basis whitens the fitting people's pooled images (here 16 x 16,
// the images themselves): zero mean and unit variance on each component up to their rank, zero
// rows beyond it; a model given the same parameters and the stored basis predicts the same
// offsets, and the inference form matches the modules.
TEST(BlendshapeGenerator, PrincipalComponentAmplitudeIsWhitenedAndTravelsWithTheModel) {
  BlendshapeNetOptions options = SmallNetwork();
  options.amplitude_components = 8;
  const auto geometry = RandomGeometry(12, {2, 5, 9}, 25, 5);
  BlendshapeGenerator model(options, geometry);
  Perturb(&model, 13);
  std::vector<BlendshapePerson> people;
  for (uint64_t seed = 20; seed < 26; ++seed) people.push_back(RandomPerson(12, 25, seed));
  std::vector<const BlendshapePerson*> pointers;
  for (const auto& p : people) pointers.push_back(&p);
  model.FitAmplitudeBasis(pointers);
  const std::vector<float> basis = model.AmplitudeBasis();
  const int F = 3 * kSize * kSize, R = options.amplitude_components, n = static_cast<int>(people.size());
  ASSERT_EQ(basis.size(), static_cast<size_t>((R + 1) * F));
  for (int k = 0; k < R; ++k) {
    double sum = 0, square = 0, row = 0;
    for (int f = 0; f < F; ++f) row += std::abs(basis[(k + 1) * F + f]);
    for (const auto& p : people) {
      double z = 0;
      for (int f = 0; f < F; ++f) z += (p.neutral_image[f] - basis[f]) * basis[(k + 1) * F + f];
      sum += z;
      square += z * z;
    }
    if (k < n - 1) {  // six people span five directions around their mean
      EXPECT_NEAR(sum / n, 0.0, 1e-3) << k;
      EXPECT_NEAR(square / n, 1.0, 1e-3) << k;
    } else {
      EXPECT_EQ(row, 0.0) << k;
    }
  }
  const std::vector<float> image = RandomImage(30);
  const std::vector<float> offsets = model.PredictOffsets(image, true);
  EXPECT_LT(RelativeDifference(offsets, model.PredictOffsetsWithModules(image, true)), kTolerance);
  BlendshapeGenerator loaded(options, geometry);
  loaded.SetParameters(model.Parameters());
  EXPECT_GT(RelativeDifference(loaded.PredictOffsets(image, true), offsets), 1e-3);  // without the basis
  loaded.SetAmplitudeBasis(basis);
  EXPECT_LT(RelativeDifference(loaded.PredictOffsets(image, true), offsets), kTolerance);
  EXPECT_THROW(loaded.SetAmplitudeBasis(std::vector<float>(F)), FileIOError);
}

// The Tuning Stage computes each person's Estimation outputs once and reuses them while the
// Estimation networks stay fixed: its gradient must equal that of a model given the same
// parameters afresh, after a Tuning step (which keeps them), after an Estimation step and a
// new amplitude basis (which change them), and for a person whose neutral changed in place.
TEST(BlendshapeGenerator, TuningStageReusesEstimationOutputsOnlyWhileTheyHold) {
  BlendshapeNetOptions options = SmallNetwork();
  options.amplitude_components = 4;
  const auto geometry = RandomGeometry(12, {2, 5, 9}, 25, 6);
  BlendshapeGenerator model(options, geometry);
  Perturb(&model, 14);
  BlendshapePerson a = RandomPerson(12, 25, 1), b = RandomPerson(12, 25, 2);
  const BlendshapePerson c = RandomPerson(12, 25, 3);
  model.FitAmplitudeBasis({&a, &b, &c});
  const int64_t n = model.NumParameters();
  auto tuning_gradient = [&](BlendshapeGenerator& m) {
    m.Backward({&a, &b}, TrainingStage::kTuning, 0.5f);
    return std::vector<float>(m.GradientBuffer(), m.GradientBuffer() + n);
  };
  auto fresh_gradient = [&] {
    BlendshapeGenerator fresh(options, geometry);
    fresh.SetParameters(model.Parameters());
    fresh.SetAmplitudeBasis(model.AmplitudeBasis());
    return tuning_gradient(fresh);
  };
  const std::vector<float> first = tuning_gradient(model);
  EXPECT_EQ(tuning_gradient(model), first);  // from the stored outputs
  EXPECT_EQ(fresh_gradient(), first);
  model.OptimizerStep(TrainingStage::kTuning);
  EXPECT_EQ(tuning_gradient(model), fresh_gradient());
  model.Backward({&c}, TrainingStage::kEstimation, 1.f);
  model.OptimizerStep(TrainingStage::kEstimation);
  const std::vector<float> stepped = tuning_gradient(model);
  EXPECT_EQ(stepped, fresh_gradient());
  EXPECT_GT(RelativeDifference(stepped, first), 1e-4);
  model.FitAmplitudeBasis({&a, &c});
  EXPECT_EQ(tuning_gradient(model), fresh_gradient());
  a.neutral_image = RandomImage(40);
  const std::vector<float> changed = tuning_gradient(model);
  EXPECT_EQ(changed, fresh_gradient());
  EXPECT_GT(RelativeDifference(changed, stepped), 1e-4);
}

TEST(BlendshapeGenerator, InferenceFromSeveralThreadsMatchesOneThread) {
  BlendshapeGenerator model(SmallNetwork(), RandomGeometry(15, {0, 4, 8, 11}, 30, 7));
  Perturb(&model, 8);
  std::vector<std::vector<float>> images, expected(4), got(4);
  for (int t = 0; t < 4; ++t) images.push_back(RandomImage(10 + t));
  model.PrepareInference();
  for (int t = 0; t < 4; ++t) expected[t] = model.PredictOffsets(images[t], true);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int r = 0; r < 3; ++r) got[t] = model.PredictOffsets(images[t], true);
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_LT(RelativeDifference(got[t], expected[t]), kTolerance) << t;
}

}  // namespace
}  // namespace facecap::nn
