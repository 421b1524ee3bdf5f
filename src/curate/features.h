// The perceptual features of paper 000 Sec. 3 that index in-the-wild frames for curation:
// f_pose (pitch and yaw), f_lighting (a 4x3 RGB grid of the nose) and f_expression (part-wise
// aligned landmarks). They are built to be agnostic to the person, so frames of person A can
// be queried with images of person B or with synthetic renders.
#ifndef FACECAP_CURATE_FEATURES_H_
#define FACECAP_CURATE_FEATURES_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "face/landmarks68.h"
#include "util/image.h"

namespace facecap::curate {

// --- f_pose ---------------------------------------------------------------------------------
// L_r: the 13 expression-stable landmarks (face::ExpressionStableLandmarks: nose bridge and
// base 27-35, eye corners 36, 39, 42, 45). They are rigidly (similarity) aligned to the
// frontal template \tilde L_r, then the pitch and yaw of a 3D template of the same 13 points
// are fitted so that its orthographic projection, after the best 2D similarity, matches the
// aligned points in least squares. Each similarity is the SVD solution (Umeyama).
//
// Angles in degrees, in the project's pose convention (rig::RigidPose, the /frames/pose of a
// wild clip, `facecap render --pitch-deg/--yaw-deg`): pitch > 0 tilts the face down (the nose
// moves down in the image), yaw > 0 turns the face to the subject's left (the nose moves right
// in the image). The template is rotated by R = Ry(yaw) Rx(pitch) as rig::RigidPose rotates a
// head; roll is in-plane and removed by the 2D alignment. Its depth profile and how it was
// checked against synthetic truth: features.cpp, kStableDepth.
struct PoseEstimate {
  double pitch_deg = 0.0;
  double yaw_deg = 0.0;
  double residual = 0.0;  // RMS misfit, as a fraction of the aligned points' RMS radius
};
PoseEstimate EstimatePose(const face::Landmarks& landmarks);

// The 3D template of the 13 points (13 by 3; x right, y down, z towards the camera) in the
// units of face::MeanFaceShape (about 0.12 m per unit).
const Eigen::Matrix<double, 13, 3, Eigen::RowMajor>& PoseTemplate3D();

// Orthographic projection (13 by 2, y down) of the template rotated by R = Ry(yaw) Rx(pitch),
// angles in degrees: exposed for tests that make landmarks of a known pose.
Eigen::MatrixX2d ProjectPoseTemplate(double pitch_deg, double yaw_deg);

constexpr int kPoseDims = 2;

// --- f_lighting -----------------------------------------------------------------------------
// A tight crop around the nose (whose rigid, curved surface samples the environment's
// lighting like a chrome sphere): the box of landmarks 27-35 grown by 15% each side,
// rasterized to a grid of kLightingRows x kLightingCols cells of mean RGB in [0, 1],
// flattened row-major (f_lighting in R^{12x3}).
constexpr int kLightingRows = 4;
constexpr int kLightingCols = 3;
constexpr int kLightingDims = kLightingRows * kLightingCols * 3;
Eigen::VectorXf LightingFeature(const Image8& image, const face::Landmarks& landmarks);

// --- f_expression ---------------------------------------------------------------------------
// L_e in groups, each aligned separately (similarity) to its part of the frontal template
// \tilde L_e, which normalizes scale, in-plane rotation and translation part by part:
//   right eye + brow (17-21, 36-41), left eye + brow (22-26, 42-47), mouth (48-67).
// The brows ride with their eye, so a raised brow (a distance to the eye) survives the
// alignment; the mouth's opening and smile survive its own. The jaw line (0-16) and the nose
// are left out: they carry pose and identity more than expression. The feature is the
// aligned points minus the template's, concatenated (84 values).
const std::vector<std::vector<int>>& ExpressionGroups();
constexpr int kExpressionDims = 2 * (11 + 11 + 20);
Eigen::VectorXf ExpressionFeature(const face::Landmarks& landmarks);

// --- all three for many frames --------------------------------------------------------------
enum class FeatureKind { kPose, kLighting, kExpression };
// "pose", "lighting", "expression"; InvalidInputError for anything else.
FeatureKind ParseFeatureKind(const std::string& name);
const char* FeatureName(FeatureKind kind);
int FeatureDims(FeatureKind kind);

struct FeatureTable {
  Eigen::MatrixXf pose;        // #frames by 2 (pitch, yaw in degrees)
  Eigen::MatrixXf lighting;    // #frames by 36
  Eigen::MatrixXf expression;  // #frames by 84
  const Eigen::MatrixXf& Of(FeatureKind kind) const;
};

// Features of frames given their aligned crops (#frames images) and crop landmarks, on
// `threads` OpenMP threads (0: default).
FeatureTable ComputeFeatures(const std::vector<const Image8*>& crops,
                             const std::vector<face::Landmarks>& landmarks, int threads = 0);

}  // namespace facecap::curate

#endif  // FACECAP_CURATE_FEATURES_H_
