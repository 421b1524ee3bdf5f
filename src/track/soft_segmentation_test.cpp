// The soft segmentation render: agrees with the hard render away from borders, and its
// analytic Jacobians (per vertex and chained through the rig) match central differences.
#include "track/soft_segmentation.h"

#include <cmath>

#include <gtest/gtest.h>

#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "rig/arkit.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"

namespace facecap::track {
namespace {

class SoftSegmentationTest : public ::testing::Test {
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
    pose_ = render::FramedPose(*rig_, distance_, 0.05f, 0.3f);
    weights_ = Eigen::VectorXf::Zero(rig_->NumShapes());
    weights_[rig_->ShapeIndex("jawOpen")] = 0.4f;
    weights_[rig_->ShapeIndex("eyeBlinkLeft")] = 0.3f;
    weights_[rig_->ShapeIndex("mouthSmileRight")] = 0.5f;
    weights_[rig_->ShapeIndex("browInnerUp")] = 0.6f;
  }

  static rig::Rig* rig_;
  render::Camera camera_;
  float distance_ = 0.f;
  rig::RigidPose pose_;
  Eigen::VectorXf weights_;
};

rig::Rig* SoftSegmentationTest::rig_ = nullptr;

TEST_F(SoftSegmentationTest, EqualsHardRenderAwayFromBordersAndIsSparse) {
  SoftSegmentationRenderer renderer(*rig_, RigRegionColors(*rig_));
  rig::Vertices posed;
  rig::EvaluatePosed(*rig_, pose_, weights_, &posed);
  SoftRender soft;
  renderer.Render(posed, camera_, &soft);
  Image8 hard;
  render::RenderSegmentation(soft.gbuffer, rig_->triangle_region, rig_->regions,
                             Eigen::Vector3f::Zero(), &hard);
  int border = 0, far_from_border_differ = 0;
  for (int p = 0; p < soft.gbuffer.NumPixels(); ++p) {
    if (soft.best_edge[p] >= 0) {
      ++border;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      if (std::abs(soft.color[3 * p + k] * 255.f - hard.data[3 * p + k]) > 0.6f) {
        ++far_from_border_differ;
      }
    }
  }
  EXPECT_EQ(far_from_border_differ, 0);
  EXPECT_GT(border, 100);
  EXPECT_LT(static_cast<int>(soft.edge_pixels.size()), soft.gbuffer.NumPixels() / 2);
}

// Central differences of every parameter against the chained analytic Jacobian, on the
// pixels whose border edge is the same in both perturbed renders.
TEST_F(SoftSegmentationTest, ChainedJacobianMatchesCentralDifferences) {
  SoftSegmentationRenderer renderer(*rig_, RigRegionColors(*rig_));
  const rig::RigEvaluator evaluator(*rig_);
  std::vector<int> columns;
  for (int c = 0; c < evaluator.NumParams(); ++c) columns.push_back(c);
  rig::Vertices posed;
  evaluator.EvaluatePosed(pose_, weights_, &posed);
  SoftRender base;
  renderer.Render(posed, camera_, &base);
  Eigen::MatrixXf rows;
  SoftJacobianWorkspace ws;
  SoftEdgeJacobian(base, evaluator, pose_, weights_, columns, &rows, &ws);
  ASSERT_GT(rows.rows(), 50);

  const Eigen::VectorXf x0 = rig::PackRigParams(pose_, weights_);
  int compared = 0, large = 0;
  double max_rel_err_norm = 0.;
  for (int c : {int(rig::kPitch), int(rig::kYaw), int(rig::kRoll), int(rig::kTx), int(rig::kTz),
                rig::kNumPoseParams + rig_->ShapeIndex("jawOpen"),
                rig::kNumPoseParams + rig_->ShapeIndex("eyeBlinkLeft"),
                rig::kNumPoseParams + rig_->ShapeIndex("mouthSmileRight")}) {
    const float h = c < rig::kNumPoseParams ? (c <= rig::kRoll ? 2e-4f : 2e-3f) : 2e-3f;
    SoftRender plus, minus;
    for (int sign : {1, -1}) {
      Eigen::VectorXf x = x0;
      x[c] += sign * h;
      rig::RigidPose p;
      Eigen::VectorXf w;
      rig::UnpackRigParams(x, &p, &w);
      evaluator.EvaluatePosed(p, w, &posed);
      renderer.Render(posed, camera_, sign > 0 ? &plus : &minus);
    }
    double err2 = 0., ref2 = 0.;
    for (int i = 0; i < rows.rows(); ++i) {
      const EdgePixel& ep = base.edge_pixels[i];
      const int p = ep.pixel;
      // Same border edge and a smooth stretch of the ramp on both sides.
      if (plus.best_edge[p] < 0 || minus.best_edge[p] < 0) continue;
      if (plus.border_edges[plus.best_edge[p]] != base.border_edges[base.best_edge[p]] ||
          minus.border_edges[minus.best_edge[p]] != base.border_edges[base.best_edge[p]]) {
        continue;
      }
      // ... and the same side colours (a silhouette's behind colour is read off the hard
      // render and may switch: a discontinuity of the model, not of its derivative).
      const int kb = base.best_edge[p], kp = plus.best_edge[p], km = minus.best_edge[p];
      if (plus.edge_colors[2 * kp + 1] != base.edge_colors[2 * kb + 1] ||
          minus.edge_colors[2 * km + 1] != base.edge_colors[2 * kb + 1]) {
        continue;
      }
      if (std::abs(ep.distance) > 0.8f * renderer.options().edge_width_px) continue;
      for (int k = 0; k < 3; ++k) {
        const double numeric = (plus.color[3 * p + k] - minus.color[3 * p + k]) / (2.0 * h);
        const double analytic = ep.color_slope[k] * rows(i, c);
        err2 += (numeric - analytic) * (numeric - analytic);
        ref2 += analytic * analytic;
        ++compared;
        if (std::abs(numeric - analytic) > 0.05 * std::abs(analytic) + 0.05) ++large;
      }
    }
    ASSERT_GT(ref2, 0.) << "column " << c;
    const double rel = std::sqrt(err2 / ref2);
    max_rel_err_norm = std::max(max_rel_err_norm, rel);
    EXPECT_LT(rel, 0.05) << "column " << c;
  }
  EXPECT_GT(compared, 500);
  EXPECT_LT(large, compared / 50) << "max relative error " << max_rel_err_norm;
}

}  // namespace
}  // namespace facecap::track
