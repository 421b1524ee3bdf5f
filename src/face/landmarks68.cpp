#include "face/landmarks68.h"

#include <cmath>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "util/errors.h"

namespace facecap::face {

const std::vector<int>& ExpressionStableLandmarks() {
  static const std::vector<int> kIndices = {27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 39, 42, 45};
  return kIndices;
}

const std::vector<int>& CropAlignmentLandmarks() {
  static const std::vector<int> kIndices = [] {
    std::vector<int> v;
    for (int i = 27; i <= 54; ++i) v.push_back(i);
    for (int i = 60; i <= 64; ++i) v.push_back(i);
    return v;
  }();
  return kIndices;
}

const Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor>& MeanFaceShape() {
  static const Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor> kShape = [] {
    // dlib's mean face shape for points 17-67 (dlib/image_transforms/interpolation.h,
    // Boost Software License).
    static const double kX[] = {
        0.000213256, 0.0752622, 0.18113,  0.29077,  0.393397, 0.586856, 0.689483, 0.799124,
        0.904991,    0.98004,   0.490127, 0.490127, 0.490127, 0.490127, 0.36688,  0.426036,
        0.490127,    0.554217,  0.613373, 0.121737, 0.187122, 0.265825, 0.334606, 0.260918,
        0.182743,    0.645647,  0.714428, 0.793132, 0.858516, 0.79751,  0.719335, 0.254149,
        0.340985,    0.428858,  0.490127, 0.551395, 0.639268, 0.726104, 0.642159, 0.556721,
        0.490127,    0.423532,  0.338094, 0.290379, 0.428096, 0.490127, 0.552157, 0.689874,
        0.553364,    0.490127,  0.42689};
    static const double kY[] = {
        0.106454, 0.038915, 0.0187482, 0.0344891, 0.0773906, 0.0773906, 0.0344891, 0.0187482,
        0.038915, 0.106454, 0.203352,  0.307009,  0.409805,  0.515625,  0.587326,  0.609345,
        0.628106, 0.609345, 0.587326,  0.216423,  0.178758,  0.179852,  0.231733,  0.245099,
        0.244077, 0.231733, 0.179852,  0.178758,  0.216423,  0.244077,  0.245099,  0.780233,
        0.745405, 0.727388, 0.742578,  0.727388,  0.745405,  0.780233,  0.864805,  0.902192,
        0.909281, 0.902192, 0.864805,  0.784792,  0.778746,  0.785343,  0.778746,  0.784792,
        0.824182, 0.831803, 0.824182};
    Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor> s;
    for (int i = 17; i < kNumLandmarks; ++i) s.row(i) << kX[i - 17], kY[i - 17];
    // Jaw: half an ellipse from the right ear line (point 0) over the chin (8) to the left
    // ear line (16), centred between the eyes.
    const double cx = 0.490127, cy = 0.22, rx = 0.56, ry = 0.86;
    for (int i = 0; i <= 16; ++i) {
      const double angle = M_PI * (1.0 - i / 16.0);  // pi at point 0, 0 at point 16
      s.row(i) << cx + rx * std::cos(angle), cy + ry * std::sin(angle);
    }
    return s;
  }();
  return kShape;
}

Eigen::Matrix<double, 2, 3> Similarity2::Matrix() const {
  Eigen::Matrix<double, 2, 3> m;
  m.leftCols<2>() = scale * rotation;
  m.col(2) = translation;
  return m;
}

Similarity2 Similarity2::Inverse() const {
  Similarity2 inv;
  inv.scale = 1.0 / scale;
  inv.rotation = rotation.transpose();
  inv.translation = -inv.scale * (inv.rotation * translation);
  return inv;
}

Similarity2 FitSimilarity(const Eigen::MatrixX2d& from, const Eigen::MatrixX2d& to) {
  if (from.rows() != to.rows() || from.rows() < 2) {
    throw InvalidInputError("FitSimilarity: needs two point lists of equal length >= 2, got " +
                            std::to_string(from.rows()) + " and " + std::to_string(to.rows()));
  }
  const Eigen::RowVector2d mean_from = from.colwise().mean();
  const Eigen::RowVector2d mean_to = to.colwise().mean();
  const Eigen::MatrixX2d a = from.rowwise() - mean_from;
  const Eigen::MatrixX2d b = to.rowwise() - mean_to;
  const double n = static_cast<double>(from.rows());
  const double var_from = a.squaredNorm() / n;
  Similarity2 t;
  if (var_from <= 0.0) {  // all points coincide: a translation only
    t.translation = (mean_to - mean_from).transpose();
    return t;
  }
  // Cross-covariance Sigma = B^T A / n; R = U S V^T with S fixing det(R) = +1.
  const Eigen::Matrix2d sigma = b.transpose() * a / n;
  Eigen::JacobiSVD<Eigen::Matrix2d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix2d s = Eigen::Matrix2d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s(1, 1) = -1.0;
  t.rotation = svd.matrixU() * s * svd.matrixV().transpose();
  t.scale = (svd.singularValues().asDiagonal() * s).trace() / var_from;
  t.translation = mean_to.transpose() - t.scale * t.rotation * mean_from.transpose();
  return t;
}

Eigen::MatrixX2d SelectRows(const Landmarks& landmarks, const std::vector<int>& indices) {
  Eigen::MatrixX2d out(indices.size(), 2);
  for (size_t i = 0; i < indices.size(); ++i) {
    out.row(i) = landmarks.row(indices[i]).cast<double>();
  }
  return out;
}

Eigen::MatrixX2d SelectRows(const Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor>& shape,
                            const std::vector<int>& indices) {
  Eigen::MatrixX2d out(indices.size(), 2);
  for (size_t i = 0; i < indices.size(); ++i) out.row(i) = shape.row(indices[i]);
  return out;
}

}  // namespace facecap::face
