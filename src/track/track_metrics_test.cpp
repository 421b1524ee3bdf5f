// The tracking metrics: the truth scores zero, a known rotation scores its angle, the neutral
// face's row is the truth's own expression, and the active-weight error counts only the
// weights above kActiveWeight.
#include "track/track_metrics.h"

#include <cmath>

#include <gtest/gtest.h>

#include "render/framing.h"
#include "rig/demo_head.h"

namespace facecap::track {
namespace {

constexpr double kPi = 3.14159265358979323846;

class TrackMetricsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig::DemoHeadOptions o;
    o.resolution = 60;
    o.num_identity_modes = 0;
    rig_ = new rig::Rig(rig::MakeDemoHead(o));
  }
  static void TearDownTestSuite() { delete rig_; }

  // Two frames of truth: frame 0 neutral and frontal, frame 1 with jawOpen 0.6 and
  // eyeBlinkLeft 0.05, turned by 20 deg of yaw; the poses framed at the camera's distance.
  void SetUp() override {
    const int S = rig_->NumShapes();
    truth_.camera = render::Camera::FromFov(64, 64, 20.f);
    truth_.distance = render::FramingDistance(*rig_, truth_.camera, 0.7f);
    truth_.col.resize(S);
    for (int s = 0; s < S; ++s) truth_.col[s] = s;
    truth_.weights = RowMatrixF::Zero(2, S);
    jaw_ = rig_->ShapeIndex("jawOpen");
    blink_ = rig_->ShapeIndex("eyeBlinkLeft");
    ASSERT_GE(jaw_, 0);
    ASSERT_GE(blink_, 0);
    truth_.weights(1, jaw_) = 0.6f;
    truth_.weights(1, blink_) = 0.05f;
    truth_.pose = RowMatrixF::Zero(2, 3);
    truth_.pose(1, 1) = static_cast<float>(20. * kPi / 180.);
  }

  rig::RigidPose Pose(int t) const {
    return render::FramedPose(*rig_, truth_.distance, truth_.pose(t, 0), truth_.pose(t, 1),
                              truth_.pose(t, 2));
  }
  Eigen::VectorXf Weights(int t) const { return truth_.weights.row(t).transpose(); }

  static rig::Rig* rig_;
  TrackTruth truth_;
  int jaw_ = -1, blink_ = -1;
};

rig::Rig* TrackMetricsTest::rig_ = nullptr;

TEST_F(TrackMetricsTest, TheTruthScoresZeroAndTheNeutralFaceItsExpression) {
  TrackScorer scorer(*rig_, *rig_, truth_, truth_.camera);
  ASSERT_TRUE(scorer.HasEyes());
  for (int t = 0; t < 2; ++t) scorer.Score(t, t, Pose(t), Weights(t));
  const TrackScores& sc = scorer.scores();
  EXPECT_EQ(sc.scored, 2);
  // The rotation angle of equal poses is zero within acos's precision in float (0.03 deg).
  EXPECT_NEAR(sc.err.pose, 0., 0.05);
  EXPECT_NEAR(sc.err.weights, 0., 1e-9);
  EXPECT_NEAR(sc.err.nme, 0., 1e-6);
  EXPECT_NEAR(sc.err.vertex, 0., 1e-6);
  EXPECT_NEAR(sc.err.expression, 0., 1e-6);
  // Only jawOpen is active (eyeBlinkLeft's 0.05 is below kActiveWeight): the neutral face
  // misses it by its whole weight.
  EXPECT_EQ(sc.err.active_count, 1);
  EXPECT_NEAR(sc.neutral.active, 0.6, 1e-6);
  EXPECT_NEAR(sc.neutral.weights, 0.65 / rig_->NumShapes(), 1e-6);
  EXPECT_GT(sc.neutral.expression, 0.);
  EXPECT_EQ(sc.frame_errors.size(), 2u);
  EXPECT_NEAR(sc.frame_errors[1][3], 0., 1e-6);
}

TEST_F(TrackMetricsTest, ARotationScoresItsAngleAndTheNeutralSolveTheWeightsMissed) {
  TrackScorer scorer(*rig_, *rig_, truth_, truth_.camera);
  rig::RigidPose turned = Pose(1);
  turned.yaw += static_cast<float>(5. * kPi / 180.);
  const Eigen::VectorXf neutral = Eigen::VectorXf::Zero(rig_->NumShapes());
  scorer.Score(1, 1, turned, neutral);
  const TrackScores& sc = scorer.scores();
  EXPECT_NEAR(sc.err.pose, 5., 0.05);
  EXPECT_NEAR(sc.pose_errors.at(0), 5., 0.05);
  EXPECT_NEAR(sc.err.active, 0.6, 1e-6);
  EXPECT_NEAR(sc.per_shape[jaw_], 0.6, 1e-6);
  EXPECT_NEAR(sc.err.expression, sc.neutral.expression, 1e-9);
  EXPECT_GT(sc.err.nme, 0.01);
}

}  // namespace
}  // namespace facecap::track
