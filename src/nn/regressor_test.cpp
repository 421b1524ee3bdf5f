#include "nn/regressor.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <gtest/gtest.h>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

// A noiseless synthetic task: codes uniform in [-1, 1]^8, every target a sigmoid of a fixed
// random linear map of the code; landmarks a sigmoid of a linear map of the other targets.
struct Task {
  RegressorSizes sizes{8, 2, 1, 3, 4};
  int count = 64;
  std::vector<float> code, pose, jaw, expression, landmarks;

  explicit Task(uint64_t seed) {
    Rng rng(seed, 0);
    auto random_map = [&](int rows, int cols) {
      std::vector<float> a(rows * cols);
      for (float& v : a) v = static_cast<float>(rng.Uniform(-1.5, 1.5));
      return a;
    };
    const auto A = random_map(sizes.pose + sizes.jaw + sizes.expression, sizes.code);
    const auto M = random_map(sizes.landmarks, sizes.pose + sizes.jaw + sizes.expression);
    for (int i = 0; i < count; ++i) {
      std::vector<float> e(sizes.code), t(sizes.pose + sizes.jaw + sizes.expression);
      for (float& v : e) v = static_cast<float>(rng.Uniform(-1.0, 1.0));
      for (size_t r = 0; r < t.size(); ++r) {
        double s = 0;
        for (int c = 0; c < sizes.code; ++c) s += A[r * sizes.code + c] * e[c];
        t[r] = static_cast<float>(1.0 / (1.0 + std::exp(-s)));
      }
      code.insert(code.end(), e.begin(), e.end());
      pose.insert(pose.end(), t.begin(), t.begin() + sizes.pose);
      jaw.insert(jaw.end(), t.begin() + sizes.pose, t.begin() + sizes.pose + sizes.jaw);
      expression.insert(expression.end(), t.begin() + sizes.pose + sizes.jaw, t.end());
      for (int r = 0; r < sizes.landmarks; ++r) {
        double s = 0;
        for (size_t c = 0; c < t.size(); ++c) s += M[r * t.size() + c] * (t[c] - 0.5);
        landmarks.push_back(static_cast<float>(1.0 / (1.0 + std::exp(-s))));
      }
    }
  }
  RegressorExample Example(int i, bool truth = true) const {
    RegressorExample x;
    x.code = code.data() + i * sizes.code;
    if (truth) {
      x.pose = pose.data() + i * sizes.pose;
      x.jaw = jaw.data() + i * sizes.jaw;
      x.expression = expression.data() + i * sizes.expression;
    }
    x.landmarks = landmarks.data() + i * sizes.landmarks;
    return x;
  }
  std::vector<RegressorExample> All(bool truth = true) const {
    std::vector<RegressorExample> all;
    for (int i = 0; i < count; ++i) all.push_back(Example(i, truth));
    return all;
  }
  // Mean absolute error of the predicted pose, jaw and expression over the task.
  double Error(const Regressor& r) const {
    std::vector<float> p(pose.size()), j(jaw.size()), w(expression.size());
    r.Predict(code.data(), count, p.data(), j.data(), w.data(), nullptr);
    double sum = 0;
    for (size_t k = 0; k < p.size(); ++k) sum += std::abs(p[k] - pose[k]);
    for (size_t k = 0; k < j.size(); ++k) sum += std::abs(j[k] - jaw[k]);
    for (size_t k = 0; k < w.size(); ++k) sum += std::abs(w[k] - expression[k]);
    return sum / static_cast<double>(p.size() + j.size() + w.size());
  }
  // The same for the best constant prediction (the targets' medians are near 0.5).
  double ConstantError() const {
    double sum = 0;
    for (float v : pose) sum += std::abs(v - 0.5f);
    for (float v : jaw) sum += std::abs(v - 0.5f);
    for (float v : expression) sum += std::abs(v - 0.5f);
    return sum / static_cast<double>(pose.size() + jaw.size() + expression.size());
  }
};

RegressorOptions Small() {
  RegressorOptions o;
  o.hidden = 32;
  o.layers = 2;
  o.learning_rate = 3e-3f;
  return o;
}

void Train(Regressor* r, Regressor::Phase phase, const std::vector<RegressorExample>& batch, int steps) {
  double losses[Regressor::kNumLosses];
  for (int s = 0; s < steps; ++s) {
    r->Backward(phase, batch, 1.f / static_cast<float>(batch.size()), losses);
    r->OptimizerStep(phase);
  }
}

TEST(Regressor, FirstPhaseFitsNoiselessSyntheticData) {
  const Task task(1);
  Regressor r(Small(), task.sizes);
  const double before = task.Error(r);
  Train(&r, Regressor::Phase::kPoseJawExpression, task.All(), 600);
  const double after = task.Error(r);
  EXPECT_LT(after, 0.2 * task.ConstantError()) << "before " << before << " after " << after;
}

TEST(Regressor, EachPhaseMovesOnlyItsNetworks) {
  const Task task(2);
  Regressor r(Small(), task.sizes);
  Train(&r, Regressor::Phase::kPoseJawExpression, task.All(), 50);
  // Phase 2 trains L alone: P, J, W's predictions stay bitwise the same.
  std::vector<float> p0(task.pose.size()), p1(task.pose.size()), l0(task.landmarks.size()), l1(task.landmarks.size());
  r.Predict(task.code.data(), task.count, p0.data(), nullptr, nullptr, l0.data());
  double losses[Regressor::kNumLosses];
  r.Backward(Regressor::Phase::kLandmarks, task.All(), 1.f / task.count, losses);
  const double landmark_loss = losses[3];
  EXPECT_EQ(losses[0], 0.0);
  Train(&r, Regressor::Phase::kLandmarks, task.All(), 300);
  r.Predict(task.code.data(), task.count, p1.data(), nullptr, nullptr, l1.data());
  EXPECT_EQ(p0, p1);
  EXPECT_NE(l0, l1);
  r.Backward(Regressor::Phase::kLandmarks, task.All(), 1.f / task.count, losses);
  EXPECT_LT(losses[3], 0.5 * landmark_loss);
  // Phase 3 on real examples (landmarks, no truth): P, J, W move, L's parameters (the last
  // block of the state: its three layers' weights and biases) stay bitwise.
  const std::vector<float> before = r.State();
  Train(&r, Regressor::Phase::kFineTune, task.All(false), 20);
  r.Predict(task.code.data(), task.count, p1.data(), nullptr, nullptr, nullptr);
  EXPECT_NE(p0, p1);
  const std::vector<float> after = r.State();
  const int64_t n = r.NumParameters();
  const int in = task.sizes.pose + task.sizes.jaw + task.sizes.expression, h = Small().hidden;
  const int64_t l_size = in * h + h + h * h + h + h * task.sizes.landmarks + task.sizes.landmarks;
  EXPECT_TRUE(std::equal(after.begin() + (n - l_size), after.begin() + n, before.begin() + (n - l_size)));
  EXPECT_FALSE(std::equal(after.begin(), after.begin() + (n - l_size), before.begin()));
}

TEST(Regressor, SharesOfABatchSumToTheWholeBatchsGradient) {
  const Task task(3);
  Regressor whole(Small(), task.sizes), part(Small(), task.sizes);
  const auto all = task.All();
  const float scale = 1.f / static_cast<float>(all.size());
  double losses[Regressor::kNumLosses];
  whole.Backward(Regressor::Phase::kFineTune, all, scale, losses);
  const std::vector<float> expected(whole.Gradients(), whole.Gradients() + whole.NumParameters());
  std::vector<float> sum(expected.size(), 0.f);
  for (int rank = 0; rank < 3; ++rank) {
    std::vector<RegressorExample> share;
    for (size_t i = rank; i < all.size(); i += 3) share.push_back(all[i]);
    part.Backward(Regressor::Phase::kFineTune, share, scale, losses);
    for (size_t k = 0; k < sum.size(); ++k) sum[k] += part.Gradients()[k];
  }
  double max_diff = 0, max_abs = 0;
  for (size_t k = 0; k < sum.size(); ++k) {
    max_diff = std::max(max_diff, static_cast<double>(std::abs(sum[k] - expected[k])));
    max_abs = std::max(max_abs, static_cast<double>(std::abs(expected[k])));
  }
  EXPECT_GT(max_abs, 0.0);
  EXPECT_LT(max_diff, 1e-5 * max_abs + 1e-9);
}

// A phase starts with a fresh Adam: the moments of the networks it trains zeroed, the step
// count restarted, the parameters untouched.
TEST(Regressor, StartPhaseRestartsTheOptimizerOfThePhasesNetworks) {
  const Task task(5);
  Regressor r(Small(), task.sizes);
  Train(&r, Regressor::Phase::kPoseJawExpression, task.All(), 4);
  const std::vector<float> before = r.State();
  const size_t n = static_cast<size_t>(r.NumParameters());
  ASSERT_EQ(before.size(), 3 * n + 1);
  EXPECT_EQ(before.back(), 4.f);
  r.StartPhase(Regressor::Phase::kFineTune);
  const std::vector<float> after = r.State();
  EXPECT_TRUE(std::equal(before.begin(), before.begin() + n, after.begin()));
  // L never trained: its moments were zero already; P, J, W's are now too.
  EXPECT_TRUE(std::any_of(before.begin() + n, before.begin() + 3 * n, [](float x) { return x != 0.f; }));
  EXPECT_TRUE(std::all_of(after.begin() + n, after.begin() + 3 * n, [](float x) { return x == 0.f; }));
  EXPECT_EQ(after.back(), 0.f);
}

TEST(Regressor, StateRoundTripsAndBadInputIsRefused) {
  const Task task(4);
  Regressor a(Small(), task.sizes);
  Train(&a, Regressor::Phase::kPoseJawExpression, task.All(), 5);
  RegressorOptions other = Small();
  other.seed = 9;
  Regressor b(other, task.sizes);
  EXPECT_NE(a.ParameterHash(), b.ParameterHash());
  b.SetState(a.State());
  EXPECT_EQ(a.ParameterHash(), b.ParameterHash());
  // Both continue bitwise alike (the Adam moments and step travel too).
  Train(&a, Regressor::Phase::kPoseJawExpression, task.All(), 3);
  Train(&b, Regressor::Phase::kPoseJawExpression, task.All(), 3);
  EXPECT_EQ(a.ParameterHash(), b.ParameterHash());
  EXPECT_THROW(b.SetState(std::vector<float>(3)), FileIOError);
  RegressorSizes bad = task.sizes;
  bad.landmarks = 3;
  EXPECT_THROW(Regressor(Small(), bad), InvalidInputError);
  RegressorOptions negative = Small();
  negative.hidden = 0;
  EXPECT_THROW(Regressor(negative, task.sizes), InvalidInputError);
}

}  // namespace
}  // namespace facecap::nn
