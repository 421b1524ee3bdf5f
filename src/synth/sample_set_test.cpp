#include "synth/sample_set.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {
namespace {

// Rows drawn around `center` with unit Gaussian spread.
CodeMatrix Cloud(int rows, int dim, double center, uint64_t seed) {
  Rng rng(seed, 0);
  CodeMatrix m(rows, dim);
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < dim; ++j) m(i, j) = static_cast<float>(center + rng.Normal());
  }
  return m;
}

TEST(Contraction, PlantedOutliersAreTheOnesRemoved) {
  const int dim = 16;
  const CodeMatrix real = Cloud(60, dim, 0.0, 1);
  // 90 samples like the real frames, then 10 far from all of them, interleaved.
  const CodeMatrix near = Cloud(90, dim, 0.0, 2), far = Cloud(10, dim, 6.0, 3);
  CodeMatrix samples(100, dim);
  std::set<int64_t> planted;
  int n = 0, f = 0;
  for (int i = 0; i < 100; ++i) {
    if (i % 10 == 7) {
      samples.row(i) = far.row(f++);
      planted.insert(i);
    } else {
      samples.row(i) = near.row(n++);
    }
  }
  std::vector<int64_t> nearest;
  const std::vector<double> score = MeanNearestDistance(samples, real, 5, false, &nearest);
  const double threshold = FractionThreshold(score, 0.1);
  const std::vector<int64_t> removed = ScoresAbove(score, threshold);
  EXPECT_EQ(std::set<int64_t>(removed.begin(), removed.end()), planted);
  // A smaller fraction removes only planted ones, the most distant first.
  const std::vector<int64_t> fewer = ScoresAbove(score, FractionThreshold(score, 0.05));
  EXPECT_EQ(fewer.size(), 5u);
  for (int64_t i : fewer) EXPECT_TRUE(planted.count(i)) << i;
  EXPECT_TRUE(ScoresAbove(score, FractionThreshold(score, 0.0)).empty());
  // The nearest real frame is the true nearest.
  for (int i = 0; i < 100; ++i) {
    Eigen::Index best;
    (real.rowwise() - samples.row(i)).rowwise().squaredNorm().minCoeff(&best);
    EXPECT_EQ(nearest[i], best) << i;
  }
}

TEST(Contraction, SkippingOwnIndexAndTies) {
  CodeMatrix a(3, 1);
  a << 0.f, 1.f, 3.f;
  // Scored against itself: row 0's nearest other is row 1 (distance 1), row 2's is row 1 (2).
  std::vector<int64_t> nearest;
  const std::vector<double> self = MeanNearestDistance(a, a, 1, true, &nearest);
  EXPECT_DOUBLE_EQ(self[0], 1.0);
  EXPECT_DOUBLE_EQ(self[2], 2.0);
  EXPECT_EQ(nearest[0], 1);
  CodeMatrix q(1, 1);
  q << 2.f;  // equidistant from rows 1 and 2: the lower index wins
  MeanNearestDistance(q, a, 1, false, &nearest);
  EXPECT_EQ(nearest[0], 1);
  // k beyond the reference's rows averages over all of them.
  EXPECT_DOUBLE_EQ(MeanNearestDistance(q, a, 10, false, nullptr)[0], (2.0 + 1.0 + 1.0) / 3.0);
  EXPECT_THROW(MeanNearestDistance(q, CodeMatrix(0, 1), 1, false, nullptr), InvalidInputError);
  EXPECT_THROW(MeanNearestDistance(CodeMatrix(1, 2), a, 1, false, nullptr), InvalidInputError);
}

Sparsity TwoGroups() {
  Sparsity s;
  s.group_shapes = {{0, 1, 2, 3}, {4, 5, 6}};
  s.max_active = {2, 1};
  s.ungrouped = {7};
  return s;
}

TEST(Expansion, NewSamplesStayInRangeUnderTheSparsityLimits) {
  const Sparsity sparsity = TwoGroups();
  std::vector<SeedParams> seeds(4);
  Rng rng(5, 0);
  for (auto& s : seeds) {
    s.weights = Eigen::VectorXf(8);
    for (int i = 0; i < 8; ++i) s.weights[i] = static_cast<float>(rng.Uniform(0.3, 1.0));
    s.pitch = static_cast<float>(rng.Uniform(-0.1, 0.1));
    s.yaw = static_cast<float>(rng.Uniform(-1.2, 1.2));
  }
  SampleOptions limits;
  limits.yaw_limit_deg = 60.f;
  ExpansionOptions options;
  for (const double fraction : {0.0, 0.5, 1.0}) {
    options.interpolate_fraction = fraction;
    for (int64_t i = 0; i < 200; ++i) {
      const SampleParams p = ExpandSample(seeds, sparsity, limits, options, i);
      ASSERT_EQ(p.weights.size(), 8);
      EXPECT_GE(p.weights.minCoeff(), 0.f) << i;
      EXPECT_LE(p.weights.maxCoeff(), 1.f) << i;
      EXPECT_EQ(p.weights[7], 0.f) << i;
      EXPECT_LE((p.weights.head(4).array() > 0).count(), 2) << i;
      EXPECT_LE((p.weights.segment(4, 3).array() > 0).count(), 1) << i;
      EXPECT_GT((p.weights.array() > 0).count(), 0) << i;
      EXPECT_LE(std::abs(p.yaw), 60.f * M_PI / 180.f + 1e-6) << i;
      EXPECT_LE(std::abs(p.pitch), 10.f * M_PI / 180.f + 1e-6) << i;
      if (fraction == 0.0) {
        // D w of one seed: every kept weight d_k w_k with d_k in [0.8, 1.2] (or clamped at 1).
        bool of_one_seed = false;
        for (const auto& s : seeds) {
          bool all = true;
          for (int k = 0; k < 7 && all; ++k) {
            if (p.weights[k] == 0.f) continue;
            const double d = p.weights[k] / s.weights[k];
            all = (d >= 0.8 - 1e-6 && d <= 1.2 + 1e-6) || (p.weights[k] == 1.f && d >= 0.8);
          }
          of_one_seed = of_one_seed || all;
        }
        EXPECT_TRUE(of_one_seed) << i;
      }
      if (fraction == 1.0) {
        // alpha w1 + (1 - alpha) w2: between the seeds' values, equal to none of the seeds.
        for (int k = 0; k < 7; ++k) {
          if (p.weights[k] == 0.f) continue;
          float lo = 1.f, hi = 0.f;
          for (const auto& s : seeds) {
            lo = std::min(lo, s.weights[k]);
            hi = std::max(hi, s.weights[k]);
          }
          EXPECT_GE(p.weights[k], lo - 1e-6f) << i;
          EXPECT_LE(p.weights[k], hi + 1e-6f) << i;
        }
        for (const auto& s : seeds) {
          Eigen::VectorXf trimmed = s.weights;
          EnforceSparsity(sparsity, &trimmed);
          EXPECT_NE(p.weights, trimmed) << i;
        }
      }
      // The same index gives the same sample.
      const SampleParams again = ExpandSample(seeds, sparsity, limits, options, i);
      EXPECT_EQ(again.weights, p.weights);
      EXPECT_EQ(again.yaw, p.yaw);
    }
  }
  EXPECT_THROW(ExpandSample({}, sparsity, limits, options, 0), InvalidInputError);
}

TEST(Expansion, EnforceSparsityKeepsTheLargestWeights) {
  Eigen::VectorXf w(8);
  w << 0.2f, 0.9f, 1.5f, 0.5f, 0.3f, 0.3f, -0.2f, 0.7f;
  EnforceSparsity(TwoGroups(), &w);
  Eigen::VectorXf expected(8);
  expected << 0.f, 0.9f, 1.f, 0.f, 0.3f, 0.f, 0.f, 0.f;  // ties: the lower index kept
  EXPECT_EQ(w, expected);
}

}  // namespace
}  // namespace facecap::synth
