// The 68 facial landmarks of the iBUG 300-W markup (the order dlib's shape predictor returns),
// their named groups, a frontal 2D mean shape, and the 2D similarity (Umeyama) fit used to
// align landmarks and crops. Plain Eigen: no dlib or OpenCV here.
//
// Indices (0-based):
//    0-16  jaw line, from the right ear (image left) over the chin to the left ear
//   17-21  right brow (image left)      22-26  left brow
//   27-30  nose bridge, nasion to tip   31-35  nostrils / nose base, right to left
//   36-41  right eye (36 outer corner, 39 inner corner)
//   42-47  left eye (42 inner corner, 45 outer corner)
//   48-59  outer lip (48 right corner, 54 left corner)   60-67  inner lip
#ifndef FACECAP_FACE_LANDMARKS68_H_
#define FACECAP_FACE_LANDMARKS68_H_

#include <vector>

#include <Eigen/Core>

namespace facecap::face {

constexpr int kNumLandmarks = 68;

// 68 by 2 list of (x, y) positions in pixels, y down.
using Landmarks = Eigen::Matrix<float, kNumLandmarks, 2, Eigen::RowMajor>;

// Landmarks whose positions barely change with expression: the nose bridge and base (27-35)
// and the four eye corners (36, 39, 42, 45). The eye corners stay put under blinks and the
// nose is rigid on the skull, so these 13 points follow the head's rigid pose only
// (paper 000 Sec. 3, L_r in R^{13x2}). The jaw line is left out: it opens with the mouth, and
// the brows and lips move with expression.
const std::vector<int>& ExpressionStableLandmarks();

// Landmarks used to align crops: the 13 expression-stable points plus the eye lids and the
// upper lip (27-54, 60-64), as dlib's face chips use them; the lower lip, jaw and brows are
// left out so that an open mouth or a raised brow does not move the crop.
const std::vector<int>& CropAlignmentLandmarks();

// A frontal mean face: 68 by 2, (x, y) in a unit frame with y down, the face filling about
// [0, 1] x [0, 1] from the brows (y ~ 0) to the chin (y ~ 1). Points 17-67 are dlib's mean
// face shape (the one behind dlib::get_face_chip_details); the jaw points 0-16 are an
// elliptic contour through the ear line and the chin.
const Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor>& MeanFaceShape();

// A 2D similarity transform x' = scale * R(angle) x + translation.
struct Similarity2 {
  double scale = 1.0;
  Eigen::Matrix2d rotation = Eigen::Matrix2d::Identity();
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();

  Eigen::Vector2d Apply(const Eigen::Vector2d& p) const {
    return scale * rotation * p + translation;
  }
  // The 2 by 3 matrix [s R | t].
  Eigen::Matrix<double, 2, 3> Matrix() const;
  Similarity2 Inverse() const;
};

// The least-squares similarity mapping `from` onto `to` (Umeyama 1991: an SVD of the 2x2
// cross-covariance, no reflection). Both are #P by 2 with #P >= 2 and equal row counts.
Similarity2 FitSimilarity(const Eigen::MatrixX2d& from, const Eigen::MatrixX2d& to);

// Rows `indices` of a 68-landmark matrix, as doubles.
Eigen::MatrixX2d SelectRows(const Landmarks& landmarks, const std::vector<int>& indices);
Eigen::MatrixX2d SelectRows(const Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor>& shape,
                            const std::vector<int>& indices);

}  // namespace facecap::face

#endif  // FACECAP_FACE_LANDMARKS68_H_
