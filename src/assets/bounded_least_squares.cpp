#include "assets/bounded_least_squares.h"

#include <algorithm>
#include <cmath>

#include "util/errors.h"

namespace facecap::assets {

BoundedLeastSquares::BoundedLeastSquares(const Eigen::MatrixXf& basis,
                                         const BoundedLeastSquaresOptions& options)
    : basis_(basis), options_(options) {
  if (!(options.lower <= options.upper) || options.prior_weight < 0.f || options.max_sweeps < 1) {
    throw InvalidInputError("bounded least squares: need lower <= upper, prior_weight >= 0, "
                            "max_sweeps >= 1");
  }
  gram_ = (basis.transpose() * basis).cast<double>();
  gram_.diagonal().array() += options.prior_weight;
}

void BoundedLeastSquares::Solve(const Eigen::VectorXf& target, const Eigen::VectorXf& prior,
                                Eigen::VectorXf* weights,
                                BoundedLeastSquaresSummary* summary) const {
  const int n = NumWeights();
  if (target.size() != basis_.rows()) {
    throw InvalidInputError("bounded least squares: target has " + std::to_string(target.size()) +
                            " entries, the basis " + std::to_string(basis_.rows()) + " rows");
  }
  const bool has_prior = options_.prior_weight > 0.f;
  if (has_prior && prior.size() != n) {
    throw InvalidInputError("bounded least squares: prior must have one entry per weight");
  }
  // Linear term b = B^T r + gamma w_prior; objective 1/2 w^T G w - b^T w (+ const).
  Eigen::VectorXd b = (basis_.transpose() * target).cast<double>();
  if (has_prior) b += options_.prior_weight * prior.cast<double>();
  Eigen::VectorXd w(n);
  if (weights->size() == n) {
    w = weights->cast<double>();
  } else if (has_prior) {
    w = prior.cast<double>();
  } else {
    w.setConstant(options_.lower);
  }
  w = w.cwiseMax(options_.lower).cwiseMin(options_.upper);
  Eigen::VectorXd gradient = gram_ * w - b;  // kept up to date
  int sweep = 0;
  bool converged = false;
  for (; sweep < options_.max_sweeps && !converged; ++sweep) {
    double largest_step = 0;
    for (int i = 0; i < n; ++i) {
      const double g = gram_(i, i);
      if (g <= 0) continue;
      const double updated =
          std::clamp(w[i] - gradient[i] / g, static_cast<double>(options_.lower),
                     static_cast<double>(options_.upper));
      const double step = updated - w[i];
      if (step == 0) continue;
      w[i] = updated;
      gradient += step * gram_.col(i);
      largest_step = std::max(largest_step, std::abs(step));
    }
    converged = largest_step <= options_.tolerance;
  }
  *weights = w.cast<float>();
  if (summary) {
    summary->sweeps = sweep;
    summary->converged = converged;
    const Eigen::VectorXf residual = basis_ * *weights - target;
    double objective = 0.5 * residual.squaredNorm();
    if (has_prior) objective += 0.5 * options_.prior_weight * (*weights - prior).squaredNorm();
    summary->objective = objective;
  }
}

}  // namespace facecap::assets
