#include "assets/deformation_transfer.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "util/errors.h"

namespace facecap::assets {
namespace {

using Frame = Eigen::Matrix3d;

// [e1, e2, n / sqrt|n|] of a triangle (Sumner and Popovic's fourth vertex).
Frame EdgeFrame(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  Frame f;
  f.col(0) = b - a;
  f.col(1) = c - a;
  const Eigen::Vector3d n = f.col(0).cross(f.col(1));
  const double len = n.norm();
  f.col(2) = len > 0 ? Eigen::Vector3d(n / std::sqrt(len)) : Eigen::Vector3d::Zero();
  return f;
}

}  // namespace

bool DeformationTransferOptions::Check(std::string* why) const {
  if (!(anchor_weight > 0)) { *why = "anchor_weight must be > 0"; return false; }
  if (!(min_triangle_area >= 0)) { *why = "min_triangle_area must be >= 0"; return false; }
  return true;
}

struct DeformationTransfer::Impl {
  DeformationTransferOptions options;
  rig::Triangles triangles;
  rig::Vertices source_rest, target_rest;
  std::vector<int> used;                     // triangles in the gradient term
  std::vector<Frame> source_frame_inverse;   // V_t^-1 of the source, per used triangle
  std::vector<double> area;                  // target rest area, per used triangle
  Eigen::SparseMatrix<double> gradient;      // 3|used| by #V: rows of X_t G_t (per coordinate)
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
};

DeformationTransfer::DeformationTransfer(const rig::Vertices& source_rest,
                                         const rig::Vertices& target_rest,
                                         const rig::Triangles& triangles,
                                         const DeformationTransferOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("deformation transfer: " + why);
  if (source_rest.rows() != target_rest.rows()) {
    throw InvalidInputError("deformation transfer: source and target have different vertex counts");
  }
  Impl& m = *impl_;
  m.options = options;
  m.triangles = triangles;
  m.source_rest = source_rest;
  m.target_rest = target_rest;
  const int V = static_cast<int>(target_rest.rows());
  std::vector<Eigen::Triplet<double>> entries;
  for (int t = 0; t < triangles.rows(); ++t) {
    const int a = triangles(t, 0), b = triangles(t, 1), c = triangles(t, 2);
    const Eigen::Vector3d ta = target_rest.row(a).cast<double>().transpose();
    const Eigen::Vector3d tb = target_rest.row(b).cast<double>().transpose();
    const Eigen::Vector3d tc = target_rest.row(c).cast<double>().transpose();
    Eigen::Matrix<double, 3, 2> edges;
    edges << tb - ta, tc - ta;
    const double area = 0.5 * edges.col(0).cross(edges.col(1)).norm();
    const Frame source = EdgeFrame(source_rest.row(a).cast<double>().transpose(),
                                   source_rest.row(b).cast<double>().transpose(),
                                   source_rest.row(c).cast<double>().transpose());
    if (area <= options.min_triangle_area || std::abs(source.determinant()) < 1e-18) continue;
    const Eigen::Matrix<double, 2, 3> pinv =
        (edges.transpose() * edges).inverse() * edges.transpose();  // G_t
    const int row = 3 * static_cast<int>(m.used.size());
    for (int j = 0; j < 3; ++j) {
      entries.emplace_back(row + j, a, -(pinv(0, j) + pinv(1, j)));
      entries.emplace_back(row + j, b, pinv(0, j));
      entries.emplace_back(row + j, c, pinv(1, j));
    }
    m.used.push_back(t);
    m.area.push_back(area);
    m.source_frame_inverse.push_back(source.inverse());
  }
  m.gradient.resize(3 * static_cast<int>(m.used.size()), V);
  m.gradient.setFromTriplets(entries.begin(), entries.end());
  Eigen::VectorXd row_weight(3 * m.used.size());
  for (size_t k = 0; k < m.used.size(); ++k) row_weight.segment<3>(3 * k).setConstant(m.area[k]);
  Eigen::SparseMatrix<double> system =
      m.gradient.transpose() * row_weight.asDiagonal() * m.gradient;
  Eigen::SparseMatrix<double> identity(V, V);
  identity.setIdentity();
  system += options.anchor_weight * identity;
  m.solver.compute(system);
  if (m.solver.info() != Eigen::Success) {
    throw InvalidInputError("deformation transfer: the target system could not be factorized");
  }
}

DeformationTransfer::~DeformationTransfer() = default;

namespace {

// The solution X (#V by 3, double) for one source deformation.
Eigen::MatrixXd SolveTransfer(const DeformationTransfer::Impl& m,
                              const Eigen::MatrixXd& source_deformed) {
  // Right-hand side: G^T A C + mu (T_0 + D), C row 3k+j, column r = (Q_t)_{r, j}.
  Eigen::MatrixXd targets(3 * m.used.size(), 3);
  for (size_t k = 0; k < m.used.size(); ++k) {
    const int t = m.used[k];
    const int a = m.triangles(t, 0), b = m.triangles(t, 1), c = m.triangles(t, 2);
    const Frame deformed = EdgeFrame(source_deformed.row(a).transpose(),
                                     source_deformed.row(b).transpose(),
                                     source_deformed.row(c).transpose());
    const Eigen::Matrix3d q = deformed * m.source_frame_inverse[k];
    targets.block<3, 3>(3 * k, 0) = m.area[k] * q.transpose();
  }
  Eigen::MatrixXd rhs = m.gradient.transpose() * targets;
  const Eigen::MatrixXd prior =
      m.target_rest.cast<double>() + (source_deformed - m.source_rest.cast<double>());
  rhs += m.options.anchor_weight * prior;
  return m.solver.solve(rhs);
}

}  // namespace

rig::Vertices DeformationTransfer::Transfer(const rig::Vertices& source_deformed) const {
  const Eigen::MatrixXd x = SolveTransfer(*impl_, source_deformed.cast<double>());
  rig::Vertices out = x.cast<float>();
  return out;
}

Eigen::MatrixXf DeformationTransfer::TransferDeltas(const Eigen::MatrixXf& source_deltas) const {
  const Impl& m = *impl_;
  const int V = static_cast<int>(m.target_rest.rows());
  if (source_deltas.rows() != 3 * V) {
    throw InvalidInputError("deformation transfer: deltas must have 3 #V rows");
  }
  Eigen::MatrixXf out(3 * V, source_deltas.cols());
  for (int i = 0; i < source_deltas.cols(); ++i) {
    const rig::Vertices delta = Eigen::Map<const rig::Vertices>(source_deltas.col(i).data(), V, 3);
    const Eigen::MatrixXd deformed = m.source_rest.cast<double>() + delta.cast<double>();
    const Eigen::MatrixXd moved = SolveTransfer(m, deformed) - m.target_rest.cast<double>();
    rig::Vertices moved_rows = moved.cast<float>();
    out.col(i) = Eigen::Map<const Eigen::VectorXf>(moved_rows.data(), 3 * V);
  }
  return out;
}

}  // namespace facecap::assets
