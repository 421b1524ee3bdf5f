#include "render/turntable.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "util/errors.h"

namespace facecap::render {
namespace {

TEST(TurntableTest, AnglesCoverBothRangesEvenly) {
  const float pitch_min = -0.3f, pitch_max = 0.3f, yaw_min = -1.2f, yaw_max = 1.2f;
  const auto angles = TurntableAngles(200, pitch_min, pitch_max, yaw_min, yaw_max);
  ASSERT_EQ(angles.size(), 200u);
  std::set<float> pitches;
  float lowest_yaw = 1e9f, highest_yaw = -1e9f;
  for (const auto& [pitch, yaw] : angles) {
    EXPECT_GE(pitch, pitch_min);
    EXPECT_LE(pitch, pitch_max);
    EXPECT_GE(yaw, yaw_min);
    EXPECT_LE(yaw, yaw_max);
    pitches.insert(pitch);
    lowest_yaw = std::min(lowest_yaw, yaw);
    highest_yaw = std::max(highest_yaw, yaw);
  }
  // sqrt(200 * 0.6 / 2.4) = 7.07: 7 pitch rows, ends included.
  EXPECT_EQ(pitches.size(), 7u);
  EXPECT_FLOAT_EQ(*pitches.begin(), pitch_min);
  EXPECT_FLOAT_EQ(*pitches.rbegin(), pitch_max);
  EXPECT_FLOAT_EQ(lowest_yaw, yaw_min);
  EXPECT_FLOAT_EQ(highest_yaw, yaw_max);
  // Serpentine order: consecutive views are neighbours (one yaw step apart, or the next
  // row at the same end of the yaw range).
  const float yaw_step = 2.4f / (200 / 7 - 1);
  const float pitch_step = 0.6f / 6;
  for (size_t i = 1; i < angles.size(); ++i) {
    const float dp = std::fabs(angles[i].first - angles[i - 1].first);
    const float dy = std::fabs(angles[i].second - angles[i - 1].second);
    EXPECT_LE(dp, pitch_step * 1.001f);
    EXPECT_LE(dy, yaw_step * 1.1f);
  }
}

TEST(TurntableTest, DegenerateRangesAndSingleViews) {
  const auto classic = TurntableAngles(12, 0.f, 0.f, -1.f, 1.f);  // fixed pitch
  ASSERT_EQ(classic.size(), 12u);
  for (size_t i = 0; i < classic.size(); ++i) {
    EXPECT_EQ(classic[i].first, 0.f);
    EXPECT_NEAR(classic[i].second, -1.f + 2.f * i / 11.f, 1e-6f);
  }
  const auto single = TurntableAngles(1, -0.2f, 0.4f, -1.f, 0.5f);
  ASSERT_EQ(single.size(), 1u);
  EXPECT_NEAR(single[0].first, 0.1f, 1e-6f);
  EXPECT_NEAR(single[0].second, -0.25f, 1e-6f);
  const auto pitch_only = TurntableAngles(5, -0.4f, 0.4f, 0.3f, 0.3f);
  ASSERT_EQ(pitch_only.size(), 5u);
  EXPECT_NEAR(pitch_only[2].first, 0.f, 1e-6f);
  for (const auto& angle : pitch_only) EXPECT_EQ(angle.second, 0.3f);
}

TEST(TurntableTest, PosesKeepTheBasePoseAndRejectBadInput) {
  rig::RigidPose base;
  base.roll = 0.1f;
  base.translation = Eigen::Vector3f(1.f, 2.f, -50.f);
  base.scale = 1.1f;
  const auto poses = TurntablePoses(9, -0.2f, 0.2f, -0.5f, 0.5f, base);
  const auto angles = TurntableAngles(9, -0.2f, 0.2f, -0.5f, 0.5f);
  ASSERT_EQ(poses.size(), 9u);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].pitch, angles[i].first);
    EXPECT_EQ(poses[i].yaw, angles[i].second);
    EXPECT_EQ(poses[i].roll, 0.1f);
    EXPECT_EQ(poses[i].translation, base.translation);
    EXPECT_EQ(poses[i].scale, 1.1f);
  }
  EXPECT_THROW(TurntableAngles(0, 0.f, 1.f, 0.f, 1.f), InvalidInputError);
  EXPECT_THROW(TurntableAngles(4, 1.f, 0.f, 0.f, 1.f), InvalidInputError);
  EXPECT_THROW(TurntableAngles(4, 0.f, 1.f, 0.f, NAN), InvalidInputError);
}

}  // namespace
}  // namespace facecap::render
