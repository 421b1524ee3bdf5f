// The inverse-rendering tracker on clean segmentation renders of the demo head with known
// parameters: the block coordinate descent recovers pose and weights from the neutral frontal
// start, and the landmark fit recovers the pose. (The pixel Jacobians are checked against
// central differences in soft_segmentation_test.cpp.)
#include "track/tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/landmarks.h"
#include "render/rasterizer.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"
#include "util/errors.h"

namespace facecap::track {
namespace {

class TrackerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig::DemoHeadOptions o;
    o.resolution = 60;
    o.num_identity_modes = 0;
    rig_ = new rig::Rig(rig::MakeDemoHead(o));
  }
  static void TearDownTestSuite() { delete rig_; }

  void SetUp() override {
    camera_ = render::Camera::FromFov(64, 64, 20.f);
    distance_ = render::FramingDistance(*rig_, camera_, 0.7f);
  }

  // A clean hard segmentation render (uint8, as stored in files) with landmarks.
  TrackTarget Target(const rig::RigidPose& pose, const Eigen::VectorXf& weights) const {
    rig::Vertices posed;
    rig::EvaluatePosed(*rig_, pose, weights, &posed);
    render::GBuffer g;
    render::Rasterize(posed, rig_->triangles, camera_, &g);
    Image8 seg;
    render::RenderSegmentation(g, rig_->triangle_region, rig_->regions, Eigen::Vector3f::Zero(),
                               &seg);
    std::vector<render::Landmark2D> lm;
    render::ProjectLandmarks(posed, rig_->triangles, rig_->landmarks, camera_, g, &lm);
    TrackTarget t;
    t.camera = camera_;
    t.image = ToFloatImage(seg);
    t.landmarks.resize(lm.size(), 2);
    for (size_t i = 0; i < lm.size(); ++i) {
      t.landmarks.row(i) = lm[i].position.transpose();
      t.landmark_visible.push_back(lm[i].visible ? 1 : 0);
    }
    return t;
  }

  Eigen::VectorXf Weights(std::initializer_list<std::pair<const char*, float>> values) const {
    Eigen::VectorXf w = Eigen::VectorXf::Zero(rig_->NumShapes());
    for (const auto& [name, value] : values) w[rig_->ShapeIndex(name)] = value;
    return w;
  }

  static rig::Rig* rig_;
  render::Camera camera_;
  float distance_ = 0.f;
};

rig::Rig* TrackerTest::rig_ = nullptr;

double AngleDeg(const rig::RigidPose& a, const rig::RigidPose& b) {
  const Eigen::Matrix3f r = a.Rotation().transpose() * b.Rotation();
  const double c = std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

TEST_F(TrackerTest, RecoversPoseAndWeightsFromNeutralFrontal) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, 0.06f, -0.25f);
  const Eigen::VectorXf truth = Weights({{"jawOpen", 0.45f},
                                         {"eyeBlinkRight", 0.6f},
                                         {"mouthSmileLeft", 0.5f},
                                         {"browInnerUp", 0.5f}});
  const TrackTarget target = Target(truth_pose, truth);
  TrackerOptions options;
  Tracker tracker(*rig_, RigRegionColors(*rig_), options);
  const rig::RigidPose start = render::FramedPose(*rig_, distance_, 0.f, 0.f);
  const TrackResult result = tracker.Solve(target, start, Eigen::VectorXf::Zero(rig_->NumShapes()));
  std::printf("%s\n", result.summary.BriefReport().c_str());
  std::printf("cost at truth %.3f\n", tracker.SegmentationCost(target, truth_pose, truth));
  const double angle = AngleDeg(result.pose, truth_pose);
  const double mae = (result.weights - truth).cwiseAbs().mean();
  std::printf("pose error %.3f deg, translation error %.3f cm, weight MAE %.4f\n", angle,
              (result.pose.translation - truth_pose.translation).norm(), mae);
  for (const char* name : {"jawOpen", "eyeBlinkRight", "mouthSmileLeft", "browInnerUp"}) {
    std::printf("  %s: %.3f (truth %.3f)\n", name, result.weights[rig_->ShapeIndex(name)],
                truth[rig_->ShapeIndex(name)]);
  }
  EXPECT_LT(angle, 1.0);
  EXPECT_LT(mae, 0.04);
  EXPECT_NEAR(result.weights[rig_->ShapeIndex("jawOpen")], 0.45f, 0.1f);
  EXPECT_NEAR(result.weights[rig_->ShapeIndex("eyeBlinkRight")], 0.6f, 0.3f);
  EXPECT_NEAR(result.weights[rig_->ShapeIndex("browInnerUp")], 0.5f, 0.15f);
  EXPECT_LT(result.summary.final_cost, 0.2 * result.summary.initial_cost);
  EXPECT_NE(result.summary.termination, Termination::kFailure);
}

// The sparsity prior (L1) against no prior on a clean target of four shapes: the 48 shapes
// the truth leaves off stay at exactly 0 more often and sum far lower, the jaw and the brow
// keep within 0.1 of the truth; a very large one keeps every weight at the neutral.
TEST_F(TrackerTest, SparsityPriorKeepsSmallWeightsOffAndLargeOnesOn) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, 0.06f, -0.25f);
  const std::vector<std::pair<const char*, float>> active = {
      {"jawOpen", 0.45f}, {"eyeBlinkRight", 0.6f}, {"mouthSmileLeft", 0.5f}, {"browInnerUp", 0.5f}};
  Eigen::VectorXf truth = Eigen::VectorXf::Zero(rig_->NumShapes());
  for (const auto& [name, value] : active) truth[rig_->ShapeIndex(name)] = value;
  const TrackTarget target = Target(truth_pose, truth);
  const rig::RigidPose start = render::FramedPose(*rig_, distance_, 0.f, 0.f);
  auto solve = [&](float sparsity) {
    TrackerOptions options;
    options.weight_prior = 0.f;
    options.sparsity_prior = sparsity;
    return Tracker(*rig_, RigRegionColors(*rig_), options)
        .Solve(target, start, Eigen::VectorXf::Zero(rig_->NumShapes()))
        .weights;
  };
  // The sum of the weights the truth leaves off, and how many of them are exactly 0.
  auto off = [&](const Eigen::VectorXf& w, int* zeros) {
    double sum = 0;
    *zeros = 0;
    for (int s = 0; s < w.size(); ++s) {
      if (truth[s] > 0) continue;
      sum += w[s];
      *zeros += w[s] == 0.f;
    }
    return sum;
  };
  const Eigen::VectorXf free = solve(0.f), sparse = solve(2.f), none = solve(1e4f);
  int zeros_free = 0, zeros_sparse = 0, zeros_none = 0;
  const double off_free = off(free, &zeros_free), off_sparse = off(sparse, &zeros_sparse);
  off(none, &zeros_none);
  std::printf("shapes off: sum %.3f, %d at 0 (no prior); sum %.3f, %d at 0 (sparsity prior 2)\n",
              off_free, zeros_free, off_sparse, zeros_sparse);
  for (const auto& [name, value] : active) {
    const int s = rig_->ShapeIndex(name);
    std::printf("  %s: %.3f, no prior %.3f (truth %.3f)\n", name, sparse[s], free[s], value);
    // (The blink, a thin band of this 64-pixel render, is one the prior can keep off.)
    if (std::string(name) == "jawOpen" || std::string(name) == "browInnerUp") {
      EXPECT_NEAR(sparse[s], value, 0.1f) << name;
    }
  }
  EXPECT_LT(off_sparse, 0.1 * off_free);
  EXPECT_GT(zeros_sparse, zeros_free);
  EXPECT_EQ(zeros_none, rig_->NumShapes() - 4);
  EXPECT_EQ(none.maxCoeff(), 0.f);
  TrackerOptions negative;
  negative.sparsity_prior = -1.f;
  EXPECT_THROW(Tracker(*rig_, RigRegionColors(*rig_), negative), InvalidInputError);
}

TEST_F(TrackerTest, LandmarkFitRecoversPose) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, -0.08f, 0.4f);
  const TrackTarget target = Target(truth_pose, Weights({{"jawOpen", 0.3f}}));
  TrackerOptions options;
  Tracker tracker(*rig_, RigRegionColors(*rig_), options);
  const rig::RigidPose start = render::FramedPose(*rig_, distance_, 0.f, 0.f);
  const rig::RigidPose pose =
      tracker.PoseFromLandmarks(target, start, Weights({{"jawOpen", 0.3f}}));
  EXPECT_LT(AngleDeg(pose, truth_pose), 0.5);
  options.objective = "landmarks";
  Tracker landmark_tracker(*rig_, RigRegionColors(*rig_), options);
  const TrackResult r =
      landmark_tracker.Solve(target, start, Eigen::VectorXf::Zero(rig_->NumShapes()));
  EXPECT_LT(AngleDeg(r.pose, truth_pose), 1.0);
  EXPECT_NEAR(r.weights[rig_->ShapeIndex("jawOpen")], 0.3f, 0.1f);
}

// The landmark term reads the 51 points off the jaw contour: moving the 17 jaw points of the
// target changes nothing, moving the nose points does.
TEST_F(TrackerTest, LandmarkTermLeavesTheJawContourOut) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, -0.05f, 0.2f);
  const Eigen::VectorXf truth = Weights({{"jawOpen", 0.2f}});
  const TrackTarget target = Target(truth_pose, truth);
  ASSERT_EQ(target.landmarks.rows(), 68);
  TrackerOptions options;
  options.landmark_weight = 0.05f;
  options.epochs = 1;
  const Tracker tracker(*rig_, RigRegionColors(*rig_), options);
  const Eigen::VectorXf start = Eigen::VectorXf::Zero(rig_->NumShapes());
  auto solve = [&](int first, int last, float dy) {
    TrackTarget moved = target;
    for (int l = first; l <= last; ++l) moved.landmarks(l, 1) += dy;
    return tracker.Solve(moved, truth_pose, start);
  };
  const TrackResult plain = solve(0, -1, 0.f);
  const TrackResult jaw = solve(0, 16, 8.f);
  const TrackResult nose = solve(27, 35, 8.f);
  EXPECT_EQ(AngleDeg(plain.pose, jaw.pose), 0.0);
  EXPECT_EQ((plain.weights - jaw.weights).cwiseAbs().maxCoeff(), 0.f);
  EXPECT_GT(AngleDeg(plain.pose, nose.pose) + (plain.pose.translation - nose.pose.translation).norm(),
            1e-3);
}

// Each point counts by its weight omega_l: a point of weight 0 does not move the solve, and
// scaling lambda_L by c and every omega_l by 1/c gives the same solve.
TEST_F(TrackerTest, LandmarkPointWeightsScaleEachPoint) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, -0.05f, 0.2f);
  const Eigen::VectorXf truth = Weights({{"jawOpen", 0.2f}});
  TrackTarget target = Target(truth_pose, truth);
  ASSERT_EQ(target.landmarks.rows(), 68);
  for (int l = 27; l <= 35; ++l) target.landmarks(l, 1) += 8.f;  // the nose moved down
  const Eigen::VectorXf start = Eigen::VectorXf::Zero(rig_->NumShapes());
  auto solve = [&](float lambda, const std::vector<float>& omega) {
    TrackerOptions options;
    options.landmark_weight = lambda;
    options.landmark_point_weights = omega;
    options.epochs = 1;
    std::string why;
    EXPECT_TRUE(options.Check(&why)) << why;
    const Tracker tracker(*rig_, RigRegionColors(*rig_), options);
    return tracker.Solve(target, truth_pose, start);
  };
  std::vector<float> nose_off(68, 1.f), halved(68, 0.5f);
  for (int l = 27; l <= 35; ++l) nose_off[l] = 0.f;
  TrackTarget unmoved = Target(truth_pose, truth);
  TrackerOptions plain_options;
  plain_options.landmark_weight = 0.05f;
  plain_options.landmark_point_weights = nose_off;
  plain_options.epochs = 1;
  const Tracker plain_tracker(*rig_, RigRegionColors(*rig_), plain_options);
  const TrackResult unmoved_solve = plain_tracker.Solve(unmoved, truth_pose, start);
  const TrackResult off = solve(0.05f, nose_off);
  EXPECT_NEAR(AngleDeg(unmoved_solve.pose, off.pose), 0.0, 1e-4);
  EXPECT_LT((unmoved_solve.weights - off.weights).cwiseAbs().maxCoeff(), 1e-4f);
  const TrackResult all = solve(0.05f, {});
  EXPECT_GT(AngleDeg(all.pose, off.pose) + (all.pose.translation - off.pose.translation).norm(), 1e-3);
  const TrackResult scaled = solve(0.1f, halved);
  EXPECT_NEAR(AngleDeg(all.pose, scaled.pose), 0.0, 1e-3);
  EXPECT_LT((all.weights - scaled.weights).cwiseAbs().maxCoeff(), 1e-3f);
  TrackerOptions bad;
  bad.landmark_point_weights.assign(67, 1.f);
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  bad.landmark_point_weights.assign(68, -1.f);
  EXPECT_FALSE(bad.Check(&why));
}

// A region of weight 0 leaves its pixels out on both sides: a target whose eyes were painted
// over with skin costs at the truth what the clean target costs (the colours' rounding), where
// without the weights it costs the painted pixels; weight 0.5 halves what they cost.
TEST_F(TrackerTest, RegionWeightsLeaveARegionOut) {
  const rig::RigidPose truth_pose = render::FramedPose(*rig_, distance_, 0.05f, -0.15f);
  const Eigen::VectorXf truth = Weights({{"jawOpen", 0.3f}});
  TrackTarget target = Target(truth_pose, truth);
  auto region = [&](const std::string& name) {
    for (size_t k = 0; k < rig_->regions.size(); ++k) {
      if (rig_->regions[k].name == name) return static_cast<int>(k);
    }
    ADD_FAILURE() << "no region " << name;
    return 0;
  };
  const std::vector<int> eyes = {region("sclera"), region("iris")};
  const Eigen::Vector3f skin = rig_->regions[region("skin")].color;
  int painted = 0;
  for (int y = 0; y < target.image.height; ++y) {
    for (int x = 0; x < target.image.width; ++x) {
      const Eigen::Vector3f c(target.image.at(x, y, 0), target.image.at(x, y, 1),
                              target.image.at(x, y, 2));
      for (int k : eyes) {
        if ((c - rig_->regions[k].color).norm() > 0.01f) continue;
        for (int ch = 0; ch < 3; ++ch) target.image.at(x, y, ch) = skin[ch];
        ++painted;
      }
    }
  }
  ASSERT_GT(painted, 10);
  auto tracker_with = [&](float eye_weight) {
    TrackerOptions options;
    options.region_weights.assign(rig_->regions.size(), 1.f);
    for (int k : eyes) options.region_weights[k] = eye_weight;
    return Tracker(*rig_, RigRegionColors(*rig_), options);
  };
  const Tracker plain(*rig_, RigRegionColors(*rig_), TrackerOptions());
  // The clean target costs only the colours' 8-bit rounding.
  const double clean = plain.SegmentationCost(Target(truth_pose, truth), truth_pose, truth);
  const double cost = plain.SegmentationCost(target, truth_pose, truth);
  EXPECT_GT(cost, 1.0);
  EXPECT_LT(clean, 1e-3 * cost);
  EXPECT_NEAR(tracker_with(1.f).SegmentationCost(target, truth_pose, truth), cost, 1e-9 * cost);
  EXPECT_NEAR(tracker_with(0.5f).SegmentationCost(target, truth_pose, truth), 0.5 * cost, clean);
  const Tracker ignoring = tracker_with(0.f);
  EXPECT_LE(ignoring.SegmentationCost(target, truth_pose, truth), clean);
  TrackerOptions negative;
  negative.region_weights.assign(rig_->regions.size(), -1.f);
  std::string why;
  EXPECT_FALSE(negative.Check(&why));
  TrackerOptions short_list;
  short_list.region_weights.assign(rig_->regions.size() - 1, 1.f);
  EXPECT_THROW(Tracker(*rig_, RigRegionColors(*rig_), short_list), InvalidInputError);
}

}  // namespace
}  // namespace facecap::track
