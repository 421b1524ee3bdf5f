#include "curate/features.h"

#include <gtest/gtest.h>

#include "util/random.h"

namespace facecap::curate {
namespace {

// The mean face in pixels (a 200-pixel face at (100, 80)).
face::Landmarks MeanFacePixels() {
  face::Landmarks l = (face::MeanFaceShape() * 200.0).cast<float>();
  l.rowwise() += Eigen::RowVector2f(100.f, 80.f);
  return l;
}

// Landmarks whose 13 stable points are the template at (pitch, yaw), placed by a similarity.
face::Landmarks LandmarksAtPose(double pitch, double yaw, double scale, double angle,
                                Eigen::Vector2d shift) {
  face::Landmarks l = MeanFacePixels();
  const Eigen::MatrixX2d p = ProjectPoseTemplate(pitch, yaw);
  Eigen::Matrix2d r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  const std::vector<int>& idx = face::ExpressionStableLandmarks();
  for (int i = 0; i < 13; ++i) {
    const Eigen::Vector2d q = scale * r * p.row(i).transpose() + shift;
    l.row(idx[i]) = q.transpose().cast<float>();
  }
  return l;
}

TEST(PoseFeatureTest, FrontalMeanFaceHasZeroPitchAndYaw) {
  const PoseEstimate e = EstimatePose(MeanFacePixels());
  EXPECT_NEAR(e.pitch_deg, 0.0, 1.0);
  EXPECT_NEAR(e.yaw_deg, 0.0, 1.0);
}

TEST(PoseFeatureTest, RecoversPitchAndYawUnderAnySimilarity) {
  Rng rng(7, 0);
  for (int trial = 0; trial < 40; ++trial) {
    const double pitch = rng.Uniform(-40, 40), yaw = rng.Uniform(-60, 60);
    const face::Landmarks l = LandmarksAtPose(pitch, yaw, rng.Uniform(80, 400), rng.Uniform(-0.5, 0.5),
                                              {rng.Uniform(0, 600), rng.Uniform(0, 400)});
    const PoseEstimate e = EstimatePose(l);
    EXPECT_NEAR(e.pitch_deg, pitch, 0.5) << "trial " << trial;
    EXPECT_NEAR(e.yaw_deg, yaw, 0.5) << "trial " << trial;
    EXPECT_LT(e.residual, 1e-3);
  }
}

TEST(PoseFeatureTest, SignConventions) {
  // As rig::RigidPose: yaw > 0 moves the nose tip (30) right relative to the eye corners;
  // pitch > 0 tilts the face down, the nose tip moves down (image y grows).
  const Eigen::MatrixX2d front = ProjectPoseTemplate(0, 0);
  const Eigen::MatrixX2d right = ProjectPoseTemplate(0, 30);
  const Eigen::MatrixX2d down = ProjectPoseTemplate(30, 0);
  const int tip = 3;  // landmark 30 in ExpressionStableLandmarks
  EXPECT_GT(right(tip, 0), front(tip, 0));
  EXPECT_GT(down(tip, 1), front(tip, 1));
}

TEST(ExpressionFeatureTest, InvariantToSimilarityAndSensitiveToTheMouth) {
  const face::Landmarks l = MeanFacePixels();
  Eigen::Matrix2f r;
  r << std::cos(0.3f), -std::sin(0.3f), std::sin(0.3f), std::cos(0.3f);
  face::Landmarks moved = (l * r.transpose() * 1.7f);
  moved.rowwise() += Eigen::RowVector2f(33.f, -12.f);
  const Eigen::VectorXf a = ExpressionFeature(l), b = ExpressionFeature(moved);
  ASSERT_EQ(a.size(), kExpressionDims);
  EXPECT_LT((a - b).norm(), 1e-4f);
  EXPECT_LT(a.norm(), 1e-4f);  // the template itself: all zero
  face::Landmarks open = l;
  for (int i = 56; i <= 58; ++i) open(i, 1) += 30.f;  // lower lip down
  for (int i = 65; i <= 67; ++i) open(i, 1) += 30.f;
  EXPECT_GT((ExpressionFeature(open) - a).norm(), 0.05f);
}

TEST(LightingFeatureTest, UniformAndSideLitNoses) {
  const face::Landmarks l = MeanFacePixels();
  Image8 grey(400, 400, 3, 128);
  const Eigen::VectorXf f = LightingFeature(grey, l);
  ASSERT_EQ(f.size(), kLightingDims);
  for (int i = 0; i < kLightingDims; ++i) EXPECT_NEAR(f[i], 128.f / 255.f, 1e-3f);
  Image8 side(400, 400, 3);
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 400; ++x)
      for (int c = 0; c < 3; ++c) side.at(x, y, c) = static_cast<uint8_t>(255 - x * 255 / 400);
  const Eigen::VectorXf g = LightingFeature(side, l);
  for (int row = 0; row < kLightingRows; ++row) {
    EXPECT_GT(g[(row * kLightingCols + 0) * 3], g[(row * kLightingCols + 2) * 3]);  // left brighter
  }
}

}  // namespace
}  // namespace facecap::curate
