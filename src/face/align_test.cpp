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

// crop_raise frames the face higher: the template moves up by raise x size, and a face aligned
// with it lands there (landmarks within a hundredth of a pixel of the template's fit).
TEST(CropTemplateTest, RaiseMovesTheFaceUpByAFractionOfTheCrop) {
  CropOptions plain{128, 0.4, 0.0}, raised{128, 0.4, 0.05};
  const auto a = CropTemplate(plain), b = CropTemplate(raised);
  EXPECT_TRUE((a.col(0) - b.col(0)).isZero(1e-12));
  EXPECT_NEAR((a.col(1) - b.col(1)).minCoeff(), 0.05 * 128, 1e-9);
  EXPECT_NEAR((a.col(1) - b.col(1)).maxCoeff(), 0.05 * 128, 1e-9);
  std::string why;
  EXPECT_TRUE(raised.Check(&why)) << why;
  EXPECT_FALSE((CropOptions{128, 0.4, 0.7}).Check(&why));

  // A face in a 200 x 200 image: the template's own landmarks, at half scale, shifted.
  Image8 image(200, 200, 3);
  Landmarks face(kNumLandmarks, 2);
  for (int i = 0; i < kNumLandmarks; ++i) {
    face(i, 0) = static_cast<float>(0.5 * a(i, 0) + 40);
    face(i, 1) = static_cast<float>(0.5 * a(i, 1) + 30);
  }
  const AlignedCrop p = AlignFace(image, face, plain), r = AlignFace(image, face, raised);
  for (int i = 0; i < kNumLandmarks; ++i) {
    EXPECT_NEAR(p.landmarks(i, 1) - r.landmarks(i, 1), 0.05 * 128, 1e-2) << i;
    EXPECT_NEAR(p.landmarks(i, 0), r.landmarks(i, 0), 1e-2) << i;
  }
}

}  // namespace
}  // namespace facecap::face
