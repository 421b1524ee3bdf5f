#include "synth/sample_set.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

}  // namespace

std::vector<double> MeanNearestDistance(const CodeMatrix& queries, const CodeMatrix& reference,
                                        int k, bool skip_same_index,
                                        std::vector<int64_t>* nearest) {
  if (k < 1) throw InvalidInputError("nearest neighbours: k must be at least 1");
  if (reference.rows() == 0) throw InvalidInputError("nearest neighbours: no reference codes");
  if (queries.cols() != reference.cols()) {
    throw InvalidInputError("nearest neighbours: codes of " + std::to_string(queries.cols()) +
                            " and " + std::to_string(reference.cols()) + " values");
  }
  const Eigen::MatrixXd ref = reference.cast<double>();
  const int64_t n = queries.rows();
  std::vector<double> score(n);
  if (nearest) nearest->assign(n, -1);
  std::vector<int64_t> order(ref.rows());
  for (int64_t q = 0; q < n; ++q) {
    const Eigen::RowVectorXd row = queries.row(q).cast<double>();
    const Eigen::VectorXd d2 = (ref.rowwise() - row).rowwise().squaredNorm();
    order.resize(ref.rows());
    std::iota(order.begin(), order.end(), 0);
    if (skip_same_index && q < ref.rows()) order.erase(order.begin() + q);
    const int64_t m = std::min<int64_t>(k, static_cast<int64_t>(order.size()));
    if (m == 0) {
      score[q] = std::numeric_limits<double>::infinity();
      continue;
    }
    std::partial_sort(order.begin(), order.begin() + m, order.end(), [&](int64_t a, int64_t b) {
      return d2[a] < d2[b] || (d2[a] == d2[b] && a < b);
    });
    double sum = 0;
    for (int64_t j = 0; j < m; ++j) sum += std::sqrt(d2[order[j]]);
    score[q] = sum / static_cast<double>(m);
    if (nearest) (*nearest)[q] = order[0];
  }
  return score;
}

double FractionThreshold(std::vector<double> scores, double fraction) {
  const int64_t n = static_cast<int64_t>(scores.size());
  const int64_t removed = std::llround(std::clamp(fraction, 0.0, 1.0) * static_cast<double>(n));
  if (removed == 0) return std::numeric_limits<double>::infinity();
  std::sort(scores.begin(), scores.end(), std::greater<double>());
  if (removed >= n) return scores.back() - 1.0;
  return 0.5 * (scores[removed - 1] + scores[removed]);
}

std::vector<int64_t> ScoresAbove(const std::vector<double>& scores, double threshold) {
  std::vector<int64_t> above;
  for (size_t i = 0; i < scores.size(); ++i) {
    if (scores[i] > threshold) above.push_back(static_cast<int64_t>(i));
  }
  return above;
}

bool ExpansionOptions::Check(std::string* why) const {
  if (!(jitter_low > 0 && jitter_low <= jitter_high)) {
    *why = "jitter_low must be positive and at most jitter_high";
    return false;
  }
  if (!(interpolate_fraction >= 0 && interpolate_fraction <= 1)) {
    *why = "interpolate_fraction must be in [0, 1]";
    return false;
  }
  if (!(pose_jitter_deg >= 0)) {
    *why = "pose_jitter_deg must be >= 0";
    return false;
  }
  return true;
}

void EnforceSparsity(const Sparsity& sparsity, Eigen::VectorXf* weights) {
  Eigen::VectorXf& w = *weights;
  w = w.cwiseMax(0.f).cwiseMin(1.f);
  for (int i : sparsity.ungrouped) w[i] = 0.f;
  for (size_t g = 0; g < sparsity.group_shapes.size(); ++g) {
    std::vector<int> shapes = sparsity.group_shapes[g];
    const size_t keep = static_cast<size_t>(std::max(0, sparsity.max_active[g]));
    if (shapes.size() <= keep) continue;
    std::stable_sort(shapes.begin(), shapes.end(), [&](int a, int b) { return w[a] > w[b]; });
    for (size_t j = keep; j < shapes.size(); ++j) w[shapes[j]] = 0.f;
  }
}

SampleParams ExpandSample(const std::vector<SeedParams>& seeds, const Sparsity& sparsity,
                          const SampleOptions& limits, const ExpansionOptions& options,
                          int64_t index) {
  if (seeds.empty()) throw InvalidInputError("expansion: no seed samples (no gap frames)");
  Rng rng(static_cast<uint64_t>(options.seed), static_cast<uint64_t>(index));
  const int64_t n = static_cast<int64_t>(seeds.size());
  const SeedParams& a = seeds[rng.UniformInt(n)];
  SampleParams p;
  double pitch = a.pitch, yaw = a.yaw;
  if (n > 1 && rng.Uniform() < options.interpolate_fraction) {
    // A second seed other than the first, and alpha in (0, 1).
    const SeedParams* b = &seeds[rng.UniformInt(n)];
    while (b == &a) b = &seeds[rng.UniformInt(n)];
    double alpha = rng.Uniform();
    while (alpha <= 0.0) alpha = rng.Uniform();
    p.weights = (static_cast<float>(alpha) * a.weights + static_cast<float>(1.0 - alpha) * b->weights);
    pitch = alpha * a.pitch + (1.0 - alpha) * b->pitch;
    yaw = alpha * a.yaw + (1.0 - alpha) * b->yaw;
  } else {
    p.weights = a.weights;
    for (int i = 0; i < p.weights.size(); ++i) {
      p.weights[i] *= static_cast<float>(rng.Uniform(options.jitter_low, options.jitter_high));
    }
  }
  EnforceSparsity(sparsity, &p.weights);
  const double sigma = options.pose_jitter_deg * kDegToRad;
  pitch += sigma * rng.Normal();
  yaw += sigma * rng.Normal();
  const double pitch_limit = limits.pitch_limit_deg * kDegToRad;
  const double yaw_limit = limits.yaw_limit_deg * kDegToRad;
  p.pitch = static_cast<float>(std::clamp(pitch, -pitch_limit, pitch_limit));
  p.yaw = static_cast<float>(std::clamp(yaw, -yaw_limit, yaw_limit));
  return p;
}

}  // namespace facecap::synth
