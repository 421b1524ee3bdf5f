// Shaping the random sample set to the footage (paper 000 Sec. 7.1-7.2), in the deepfake's
// latent space: samples whose codes E(I_S) lie far from every real frame's code E(I_R) are
// outliers and are removed (contraction); real frames whose codes lie far from every sample's
// are gaps, and the tracker's solutions on them seed new samples, jittered per control and
// interpolated between pairs (expansion).
//
// Codes are rows of a row-major [count, dim] float matrix. Every function is deterministic:
// new sample i draws only from Rng(seed, i), so an expanded set is the same for any rank count.
#ifndef FACECAP_SYNTH_SAMPLE_SET_H_
#define FACECAP_SYNTH_SAMPLE_SET_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "synth/samples.h"

namespace facecap::synth {

using CodeMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// For each row of `queries`: the mean Euclidean distance to its `k` nearest rows of
// `reference` (fewer when the reference has fewer rows), and in *nearest (when not null) the
// index of the nearest one. With `skip_same_index`, reference row i is not a neighbour of
// query row i (a set scored against itself). Ties go to the lower index.
// Throws InvalidInputError when the dimensions differ, k < 1 or the reference is empty.
std::vector<double> MeanNearestDistance(const CodeMatrix& queries, const CodeMatrix& reference,
                                        int k, bool skip_same_index,
                                        std::vector<int64_t>* nearest);

// The score above which `fraction` of `scores` lie: the scores sorted descending, the mean of
// the last one removed and the first one kept (+infinity when fraction is 0). Removing the
// scores above it removes round(fraction * count) of them (ties at the boundary kept).
double FractionThreshold(std::vector<double> scores, double fraction);

// Indices of the scores strictly above `threshold`, ascending.
std::vector<int64_t> ScoresAbove(const std::vector<double>& scores, double threshold);

// A sample's parameters as a seed of expansion: the tracker's solution on a gap frame.
struct SeedParams {
  float pitch = 0.f;  // rad
  float yaw = 0.f;    // rad
  Eigen::VectorXf weights;
};

struct ExpansionOptions {
  int seed = 1;                     // new sample i draws from Rng(seed, i)
  double jitter_low = 0.8;          // per-control factor d_i of D, uniform in [low, high]
  double jitter_high = 1.2;
  // Fraction of new samples interpolated between two seeds, alpha w1 + (1 - alpha) w2 with
  // alpha uniform in (0, 1); the others are D w of one seed.
  double interpolate_fraction = 0.5;
  double pose_jitter_deg = 2.0;     // sigma of a Gaussian added to each seed's pitch and yaw

  template <class V>
  void Visit(V&& v) {
    v("seed", seed, "seed of the new samples; new sample i draws from (seed, i)");
    v("jitter_low", jitter_low, "lowest per-control jitter factor d_i of D w");
    v("jitter_high", jitter_high, "highest per-control jitter factor d_i of D w");
    v("interpolate_fraction", interpolate_fraction,
      "fraction of new samples interpolated between two gap seeds (the rest: one seed jittered)");
    v("pose_jitter_deg", pose_jitter_deg,
      "sigma in degrees of the Gaussian added to a seed's pitch and yaw");
  }
  bool Check(std::string* why) const;
};

// Zeroes the shapes of no sparsity group and, in each group, all but its max_active largest
// weights (ties: the lower index kept); clamps every weight to [0, 1].
void EnforceSparsity(const Sparsity& sparsity, Eigen::VectorXf* weights);

// New sample `index` from `seeds` (at least one): D w of a seed or alpha w1 + (1 - alpha) w2
// of two, under the sparsity limits and in [0, 1]; its pose the seed's (interpolated with the
// same alpha), jittered, and pitch and yaw limited as `limits` limits the random samples'.
// Throws InvalidInputError when there are no seeds.
SampleParams ExpandSample(const std::vector<SeedParams>& seeds, const Sparsity& sparsity,
                          const SampleOptions& limits, const ExpansionOptions& options,
                          int64_t index);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_SAMPLE_SET_H_
