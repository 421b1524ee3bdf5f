#include "render/camera.h"

#include <cmath>

#include <gtest/gtest.h>

#include "rig/pose.h"

namespace facecap::render {
namespace {

// Where a source-camera point lands in the crop: through the source projection and the 2 x 3
// crop transform (pixel centres at integers, as OpenCV and dlib place them), then scaled.
Eigen::Vector2f ThroughTheCrop(const Camera& source, const Eigen::Matrix<float, 2, 3>& m,
                               const Eigen::Vector3f& x, float k) {
  const Eigen::Vector2f p = source.Project(x).head<2>() - Eigen::Vector2f(0.5f, 0.5f);
  const Eigen::Vector2f q = m.leftCols<2>() * p + m.col(2);
  return k * (q + Eigen::Vector2f(0.5f, 0.5f));
}

TEST(CameraOfCropTest, ProjectsLikeTheSourceImageWarpedByTheCropTransform) {
  const Camera source = Camera::FromFov(400, 300, 40.f);
  // A crop of 128 pixels turned by 17 degrees, scaled 0.6, shown at 64 pixels.
  const float theta = 17.f * static_cast<float>(M_PI) / 180.f, s = 0.6f;
  Eigen::Matrix<float, 2, 3> m;
  m << s * std::cos(theta), -s * std::sin(theta), -80.f, s * std::sin(theta), s * std::cos(theta),
      -20.f;
  const CropView view = CameraOfCrop(source, m, 128, 64);
  EXPECT_NEAR(view.roll, -theta, 1e-6f);
  EXPECT_EQ(view.camera.width, 64);
  const Eigen::Matrix3f turn =
      rig::EulerToMatrix(Eigen::Vector3f(0.f, 0.f, view.roll));
  for (const Eigen::Vector3f x : {Eigen::Vector3f(3.f, -2.f, -40.f), Eigen::Vector3f(-5.f, 4.f, -55.f),
                                  Eigen::Vector3f(0.5f, 0.1f, -30.f)}) {
    const Eigen::Vector2f expected = ThroughTheCrop(source, m, x, 0.5f);
    const Eigen::Vector2f got = view.camera.Project(turn * x).head<2>();
    EXPECT_NEAR((expected - got).norm(), 0.f, 1e-3f) << x.transpose();
  }
}

TEST(CameraOfCropTest, AHeadPoseSolvedInTheCropIsTheSourcePoseWithItsRollMoved) {
  const Camera source = Camera::FromFov(320, 240, 50.f);
  const float theta = -0.3f, s = 1.4f;
  Eigen::Matrix<float, 2, 3> m;
  m << s * std::cos(theta), -s * std::sin(theta), 10.f, s * std::sin(theta), s * std::cos(theta),
      -35.f;
  const CropView view = CameraOfCrop(source, m, 128, 128);
  rig::RigidPose in_source;
  in_source.pitch = 0.1f;
  in_source.yaw = -0.4f;
  in_source.roll = 0.05f;
  in_source.translation = Eigen::Vector3f(2.f, 1.f, -50.f);
  rig::RigidPose in_crop = in_source;
  in_crop.roll += view.roll;
  in_crop.translation = rig::EulerToMatrix(Eigen::Vector3f(0.f, 0.f, view.roll)) * in_source.translation;
  const Eigen::Vector3f head_point(4.f, 3.f, 6.f);
  const Eigen::Vector2f expected = ThroughTheCrop(source, m, in_source.Apply(head_point), 1.f);
  const Eigen::Vector2f got = view.camera.Project(in_crop.Apply(head_point)).head<2>();
  EXPECT_NEAR((expected - got).norm(), 0.f, 1e-3f);
}

}  // namespace
}  // namespace facecap::render
