#include "face/align.h"

#include <gtest/gtest.h>

namespace facecap::face {
namespace {

FaceBox Box(float x, float y, float w) { return FaceBox{x, y, w, w, 1.f}; }

TEST(FollowSubjectTest, KeepsTheSubjectWhenALargerFaceAppears) {
  std::vector<std::vector<FaceBox>> faces = {
      {Box(100, 100, 80)},
      {Box(104, 100, 80), Box(300, 50, 150)},  // a larger stranger
      {Box(300, 50, 150), Box(108, 102, 80)},
      {},                                       // nobody
      {Box(300, 50, 150)},                      // only the stranger
      {Box(110, 104, 80)},
  };
  const std::vector<int> chosen = FollowSubject(faces);
  EXPECT_EQ(chosen, (std::vector<int>{0, 0, 1, -1, -1, 0}));
}

TEST(FollowSubjectTest, TakesTheLargestFaceAfterALongGap) {
  std::vector<std::vector<FaceBox>> faces(1, {Box(100, 100, 80)});
  for (int i = 0; i < 12; ++i) faces.push_back({Box(400, 50, 120)});
  SubjectTrackerOptions o;
  o.max_gap = 3;
  const std::vector<int> chosen = FollowSubject(faces, o);
  EXPECT_EQ(chosen[0], 0);
  EXPECT_EQ(chosen[1], -1);
  EXPECT_EQ(chosen[4], 0);  // gap of 3 frames exceeded
  EXPECT_EQ(chosen.back(), 0);
}

TEST(SimilarityTest, FitRecoversAKnownSimilarity) {
  const Eigen::MatrixX2d from = SelectRows(MeanFaceShape(), CropAlignmentLandmarks());
  Similarity2 truth;
  truth.scale = 143.0;
  truth.rotation << std::cos(0.4), -std::sin(0.4), std::sin(0.4), std::cos(0.4);
  truth.translation << 12.0, -7.0;
  Eigen::MatrixX2d to(from.rows(), 2);
  for (int i = 0; i < from.rows(); ++i) to.row(i) = truth.Apply(from.row(i).transpose()).transpose();
  const Similarity2 fit = FitSimilarity(from, to);
  EXPECT_NEAR(fit.scale, truth.scale, 1e-9);
  EXPECT_TRUE(fit.rotation.isApprox(truth.rotation, 1e-12));
  EXPECT_TRUE(fit.translation.isApprox(truth.translation, 1e-9));
  const Similarity2 back = fit.Inverse();
  EXPECT_TRUE(back.Apply(to.row(3).transpose()).isApprox(from.row(3).transpose(), 1e-9));
}

}  // namespace
}  // namespace facecap::face
