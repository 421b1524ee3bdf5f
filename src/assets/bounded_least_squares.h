// Bounded linear least squares: min_w 1/2 ||B w - r||^2 + 1/2 gamma ||w - w_prior||^2 subject
// to lo <= w <= hi, with a precompute / solve split. The weight solve of every reconstruction
// error in facecap's blendshape comparison (paper 001 Table 2), weights in [0, 1].
#ifndef FACECAP_ASSETS_BOUNDED_LEAST_SQUARES_H_
#define FACECAP_ASSETS_BOUNDED_LEAST_SQUARES_H_

#include <Eigen/Core>

namespace facecap::assets {

struct BoundedLeastSquaresOptions {
  float lower = 0.f;               // lower bound of every weight
  float upper = 1.f;               // upper bound of every weight
  float prior_weight = 0.f;        // gamma: pull towards w_prior (0: none)
  int max_sweeps = 500;            // projected coordinate-descent sweeps at most
  double tolerance = 1e-7;         // stop when no weight moves more than this in a sweep
};

struct BoundedLeastSquaresSummary {
  int sweeps = 0;                  // sweeps run
  bool converged = false;          // the last sweep moved no weight more than the tolerance
  double objective = 0;            // 1/2 ||B w - r||^2 + prior term at the solution
};

class BoundedLeastSquares {
 public:
  // Precomputes the Gram matrix B^T B (+ gamma I). B: M by N (M rows of residual, N weights).
  BoundedLeastSquares(const Eigen::MatrixXf& basis, const BoundedLeastSquaresOptions& options);
  // Solves for target r (M); w_prior (N) only matters when prior_weight > 0. Warm start from
  // *weights when it has N entries, else from the clamped prior (or lower bound).
  void Solve(const Eigen::VectorXf& target, const Eigen::VectorXf& prior, Eigen::VectorXf* weights,
             BoundedLeastSquaresSummary* summary = nullptr) const;
  int NumWeights() const { return static_cast<int>(gram_.rows()); }

 private:
  const Eigen::MatrixXf& basis_;
  BoundedLeastSquaresOptions options_;
  Eigen::MatrixXd gram_;
};

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_BOUNDED_LEAST_SQUARES_H_
