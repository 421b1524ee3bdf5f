#include "assets/example_based_rigging.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "assets/bounded_least_squares.h"
#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::assets {

bool ExampleBasedOptions::Check(std::string* why) const {
  if (iterations < 1) { *why = "iterations must be >= 1"; return false; }
  if (!(shape_regularization > 0.f)) { *why = "shape_regularization must be > 0"; return false; }
  if (!(kappa > 0.f)) { *why = "kappa must be > 0"; return false; }
  if (!(theta >= 0.f)) { *why = "theta must be >= 0"; return false; }
  if (!(weight_regularization >= 0.f)) { *why = "weight_regularization must be >= 0"; return false; }
  return true;
}

Eigen::MatrixXf SelectVertexRows(const Eigen::MatrixXf& m, const std::vector<int>& vertices) {
  Eigen::MatrixXf out(3 * static_cast<int>(vertices.size()), m.cols());
  for (size_t k = 0; k < vertices.size(); ++k) out.middleRows<3>(3 * k) = m.middleRows<3>(3 * vertices[k]);
  return out;
}

ExampleBasedResult FitExampleBasedRig(const Eigen::VectorXf& neutral,
                                      const Eigen::MatrixXf& expressions,
                                      const Eigen::MatrixXf& nominal_weights,
                                      const Eigen::MatrixXf& transferred,
                                      const Eigen::MatrixXf& template_deltas,
                                      const std::vector<int>& vertices,
                                      const ExampleBasedOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("example-based rigging: " + why);
  const int N = static_cast<int>(transferred.cols()), K = static_cast<int>(expressions.cols());
  if (nominal_weights.rows() != K || nominal_weights.cols() != N ||
      template_deltas.cols() != N || expressions.rows() != neutral.size() ||
      transferred.rows() != neutral.size() || template_deltas.rows() != neutral.size()) {
    throw InvalidInputError("example-based rigging: inconsistent sizes");
  }
  // w_i(x) per solved vertex and shape.
  const int A = static_cast<int>(vertices.size());
  Eigen::VectorXf largest = Eigen::VectorXf::Zero(N);
  for (int i = 0; i < N; ++i) {
    for (int v : vertices) largest[i] = std::max(largest[i], template_deltas.block<3, 1>(3 * v, i).norm());
  }
  Eigen::MatrixXf vertex_weight(A, N);
  for (int k = 0; k < A; ++k) {
    for (int i = 0; i < N; ++i) {
      const float d = largest[i] > 0 ? template_deltas.block<3, 1>(3 * vertices[k], i).norm() / largest[i] : 0.f;
      vertex_weight(k, i) = options.shape_regularization *
                            std::pow((1.f + d) / (options.kappa + d), options.theta);
    }
  }
  ExampleBasedResult result;
  result.deltas = transferred;
  result.weights = nominal_weights;
  const Eigen::MatrixXf displacement = expressions.colwise() - neutral;  // P_k - B_0
  const Eigen::MatrixXf displacement_rows = SelectVertexRows(displacement, vertices);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    // Shape step, one N by N system per vertex.
    const Eigen::MatrixXd gram = (result.weights.transpose() * result.weights).cast<double>();
    const Eigen::MatrixXd weights_t = result.weights.transpose().cast<double>();
    ParallelFor(0, A, options.threads, [&](int k) {
      const int v = vertices[k];
      Eigen::MatrixXd system = gram;
      system.diagonal() += vertex_weight.row(k).transpose().cast<double>();
      Eigen::MatrixXd r(K, 3);
      for (int e = 0; e < K; ++e) r.row(e) = displacement.block<3, 1>(3 * v, e).transpose().cast<double>();
      Eigen::MatrixXd prior(N, 3);
      for (int i = 0; i < N; ++i) prior.row(i) = transferred.block<3, 1>(3 * v, i).transpose().cast<double>();
      const Eigen::MatrixXd rhs = weights_t * r + vertex_weight.row(k).transpose().cast<double>().asDiagonal() * prior;
      const Eigen::MatrixXd b = system.ldlt().solve(rhs);
      for (int i = 0; i < N; ++i) result.deltas.block<3, 1>(3 * v, i) = b.row(i).transpose().cast<float>();
    });
    // Weight step, a bounded least squares per scan.
    const Eigen::MatrixXf basis = SelectVertexRows(result.deltas, vertices);
    BoundedLeastSquaresOptions ls;
    ls.prior_weight = options.weight_regularization;
    const BoundedLeastSquares solver(basis, ls);
    for (int e = 0; e < K; ++e) {
      Eigen::VectorXf w = result.weights.row(e).transpose();
      solver.Solve(displacement_rows.col(e), nominal_weights.row(e).transpose(), &w);
      result.weights.row(e) = w.transpose();
    }
  }
  return result;
}

Eigen::VectorXd ReconstructionErrors(const Eigen::VectorXf& neutral, const Eigen::MatrixXf& deltas,
                                     const Eigen::MatrixXf& expressions,
                                     const std::vector<int>& vertices, Eigen::MatrixXf* weights) {
  const int K = static_cast<int>(expressions.cols()), N = static_cast<int>(deltas.cols());
  const Eigen::MatrixXf basis = SelectVertexRows(deltas, vertices);
  const Eigen::MatrixXf targets = SelectVertexRows(expressions.colwise() - neutral, vertices);
  const BoundedLeastSquares solver(basis, BoundedLeastSquaresOptions());
  Eigen::VectorXd errors(K);
  if (weights) weights->resize(K, N);
  for (int e = 0; e < K; ++e) {
    Eigen::VectorXf w;
    solver.Solve(targets.col(e), Eigen::VectorXf(), &w);
    const Eigen::VectorXf residual = basis * w - targets.col(e);
    double sum = 0;
    for (size_t k = 0; k < vertices.size(); ++k) sum += residual.segment<3>(3 * k).norm();
    errors[e] = sum / static_cast<double>(vertices.size());
    if (weights) weights->row(e) = w.transpose();
  }
  return errors;
}

double MeanShapeDistance(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b,
                         const std::vector<int>& vertices) {
  double sum = 0;
  for (int i = 0; i < a.cols(); ++i) {
    for (int v : vertices) sum += (a.block<3, 1>(3 * v, i) - b.block<3, 1>(3 * v, i)).norm();
  }
  return sum / (static_cast<double>(a.cols()) * static_cast<double>(vertices.size()));
}

}  // namespace facecap::assets
