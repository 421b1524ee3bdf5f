#include "rig/pose.h"

#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "rig/evaluate.h"

namespace facecap::rig {
namespace {

Eigen::Matrix3d ComposedAxisRotations(const Eigen::Vector3d& e) {
  return (Eigen::AngleAxisd(e.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(e.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(e.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

std::vector<Eigen::Vector3f> RandomAngles(int n) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> angle(-3.f, 3.f);
  std::vector<Eigen::Vector3f> out;
  for (int i = 0; i < n; ++i) out.emplace_back(angle(rng), angle(rng), angle(rng));
  return out;
}

TEST(EulerToMatrixTest, IsOrthonormalWithUnitDeterminant) {
  for (const Eigen::Vector3f& e : RandomAngles(50)) {
    const Eigen::Matrix3f r = EulerToMatrix(e);
    EXPECT_LT((r * r.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff(), 1e-6f);
    EXPECT_NEAR(r.determinant(), 1.f, 1e-6f);
  }
}

TEST(EulerToMatrixTest, MatchesComposedAxisRotations) {
  for (const Eigen::Vector3f& e : RandomAngles(50)) {
    const Eigen::Matrix3d expected = ComposedAxisRotations(e.cast<double>());
    EXPECT_LT((EulerToMatrix(e).cast<double>() - expected).cwiseAbs().maxCoeff(), 1e-6) << e;
  }
  // Single axes: +90 degrees about x sends +y to +z.
  const Eigen::Vector3f y_rotated =
      EulerToMatrix(Eigen::Vector3f(static_cast<float>(M_PI / 2), 0, 0)) * Eigen::Vector3f::UnitY();
  EXPECT_LT((y_rotated - Eigen::Vector3f::UnitZ()).norm(), 1e-6f);
}

TEST(EulerToMatrixTest, DerivativesMatchCentralDifferences) {
  for (const Eigen::Vector3f& e : RandomAngles(20)) {
    Eigen::Matrix3f r;
    std::array<Eigen::Matrix3f, 3> derivatives;
    EulerToMatrixWithDerivatives(e, &r, &derivatives);
    EXPECT_LT((r - EulerToMatrix(e)).cwiseAbs().maxCoeff(), 1e-6f);
    for (int k = 0; k < 3; ++k) {
      const double step = 1e-6;
      Eigen::Vector3d plus = e.cast<double>(), minus = e.cast<double>();
      plus[k] += step;
      minus[k] -= step;
      const Eigen::Matrix3d numeric =
          (ComposedAxisRotations(plus) - ComposedAxisRotations(minus)) / (2 * step);
      EXPECT_LT((derivatives[k].cast<double>() - numeric).cwiseAbs().maxCoeff(), 1e-5)
          << "angle " << k << " at " << e.transpose();
    }
  }
}

TEST(RigidPoseTest, ApplyIsScaledRotationPlusTranslation) {
  RigidPose pose;
  pose.pitch = 0.1f;
  pose.yaw = 0.7f;
  pose.roll = -0.2f;
  pose.translation = Eigen::Vector3f(1, 2, -50);
  pose.scale = 0.8f;
  const Eigen::Vector3f x(3, -4, 5);
  const Eigen::Vector3d expected =
      0.8 * ComposedAxisRotations(Eigen::Vector3d(0.1, 0.7, -0.2)) * x.cast<double>() +
      Eigen::Vector3d(1, 2, -50);
  EXPECT_LT((pose.Apply(x).cast<double>() - expected).norm(), 1e-5);
  EXPECT_LT((pose.Rotation() - EulerToMatrix(Eigen::Vector3f(0.1f, 0.7f, -0.2f)))
                .cwiseAbs().maxCoeff(), 1e-7f);
}

TEST(RigidPoseTest, PositiveYawTurnsTheFaceTowardsPlusX) {
  RigidPose pose;
  pose.yaw = 0.5f;
  pose.translation.setZero();
  EXPECT_GT(pose.Apply(Eigen::Vector3f::UnitZ()).x(), 0.f);
}

}  // namespace
}  // namespace facecap::rig
