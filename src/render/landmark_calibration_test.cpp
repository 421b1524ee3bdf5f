#include "render/landmark_calibration.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "render/framing.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"

namespace facecap::render {
namespace {

// Views of the demo head at a few poses, its mouth a little open, whose "detections" are the
// projections of chosen vertices: landmark l detected where vertex target[l] projects.
std::vector<CalibrationView> ViewsDetecting(const rig::Rig& rig, const Eigen::VectorXi& target) {
  Eigen::VectorXf weights = Eigen::VectorXf::Zero(rig.NumShapes());
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (rig.shapes[s].name == "jawOpen") weights[s] = 0.3f;
  }
  const Camera camera = Camera::FromFov(256, 256, 20.f);
  const float distance = FramingDistance(rig, camera, 0.55f);
  const float deg = static_cast<float>(M_PI / 180.0);
  std::vector<CalibrationView> views;
  for (float yaw : {-20.f, 0.f, 20.f}) {
    for (float pitch : {-8.f, 8.f}) {
      CalibrationView v;
      v.camera = camera;
      rig::EvaluatePosed(rig, FramedPose(rig, distance, pitch * deg, yaw * deg),
                         weights, &v.posed);
      v.detected.resize(68, 2);
      for (int l = 0; l < 68; ++l) {
        v.detected.row(l) = camera.Project(v.posed.row(target[l]).transpose()).head<2>().transpose();
      }
      views.push_back(std::move(v));
    }
  }
  return views;
}

// A detector that misses a slight opening puts the inner lower lip's points (65-67) on the
// inner upper lip's (63-61): the calibration keeps them on vertices that move with the jaw as
// their own do, while a landmark detected at another vertex of its own part (the nose tip,
// point 30, one vertex over) moves there exactly.
TEST(LandmarkCalibration, LandmarksStayOnThePartThatMovesWithThem) {
  rig::DemoHeadOptions head_options;
  head_options.num_identity_modes = 0;
  const rig::Rig rig = rig::MakeDemoHead(head_options);
  ASSERT_EQ(rig.landmarks.size(), 68);
  ASSERT_EQ(rig.jaw_weights.size(), rig.NumVertices());
  Eigen::VectorXi target = rig.landmarks;
  target[65] = rig.landmarks[63];
  target[66] = rig.landmarks[62];
  target[67] = rig.landmarks[61];
  for (int l : {61, 62, 63}) {
    ASSERT_GT(rig.jaw_weights[rig.landmarks[l + 4]] - rig.jaw_weights[rig.landmarks[l]], 0.5f)
        << "the demo head's inner lips do not move apart with the jaw";
  }
  // The nose tip's detections at the nearest other skin vertex with its jaw weight.
  const int nose = rig.landmarks[30];
  int other = -1;
  for (int v = 0; v < rig.NumVertices(); ++v) {
    if (v == nose || std::abs(rig.jaw_weights[v] - rig.jaw_weights[nose]) > 0.01f) continue;
    const float d = (rig.neutral.row(v) - rig.neutral.row(nose)).norm();
    if (d > 0.05f && d < 0.5f && (other < 0 || d < (rig.neutral.row(other) - rig.neutral.row(nose)).norm())) {
      other = v;
    }
  }
  ASSERT_GE(other, 0);
  target[30] = other;

  const LandmarkCalibration c = CalibrateLandmarks(rig, ViewsDetecting(rig, target), 1.5f);
  ASSERT_EQ(c.landmarks.size(), 68);
  EXPECT_EQ(c.landmarks[30], other);
  EXPECT_NEAR(c.error_after[30], 0., 1e-6);
  for (int l : {65, 66, 67}) {
    EXPECT_LE(std::abs(rig.jaw_weights[c.landmarks[l]] - rig.jaw_weights[rig.landmarks[l]]),
              kJawWeightTolerance) << l;
    EXPECT_NE(c.landmarks[l], target[l]) << l;
  }
  // Landmarks detected at their own vertices stay there.
  for (int l : {36, 45, 48, 54}) EXPECT_EQ(c.landmarks[l], rig.landmarks[l]) << l;
}

}  // namespace
}  // namespace facecap::render
