#include "rig/compare.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "util/errors.h"

namespace facecap::rig {

double SimilarityAlignedRms(const Vertices& estimate, const Vertices& truth) {
  if (estimate.rows() != truth.rows() || estimate.rows() < 3) {
    throw InvalidInputError("shape comparison: " + std::to_string(estimate.rows()) + " and " +
                            std::to_string(truth.rows()) + " vertices (one topology of 3 or more)");
  }
  const Eigen::Matrix3Xd src = estimate.cast<double>().transpose();
  const Eigen::Matrix3Xd dst = truth.cast<double>().transpose();
  const Eigen::Matrix4d t = Eigen::umeyama(src, dst, true);
  const Eigen::Matrix3Xd moved = (t.topLeftCorner<3, 3>() * src).colwise() + t.topRightCorner<3, 1>();
  return std::sqrt((moved - dst).colwise().squaredNorm().mean());
}

double InterOcularDistance(const Rig& rig, const Vertices& vertices) {
  if (rig.landmarks.size() != 68) return 0.;
  return (vertices.row(rig.landmarks[36]) - vertices.row(rig.landmarks[45])).cast<double>().norm();
}

double RotationAngleDeg(const RigidPose& a, const RigidPose& b) {
  const Eigen::Matrix3d r = (a.Rotation().transpose() * b.Rotation()).cast<double>();
  return std::acos(std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace facecap::rig
