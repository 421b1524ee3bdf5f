// Tracking accuracy against a known truth (eval track): per frame the rotation error, the
// weight error per shape and over the truth's active weights, the expression error (the shape
// without the rigid pose, less each rig's own neutral, over the inter-ocular distance), and,
// for a 68-landmark rig, the landmark NME and the vertex error of the posed meshes. Beside
// every sum it keeps the neutral face's (every weight 0): what solving no expression at all
// scores on the same frames, the reference every figure has to beat.
#ifndef FACECAP_TRACK_TRACK_METRICS_H_
#define FACECAP_TRACK_TRACK_METRICS_H_

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::track {

// A true weight above this is active: the active-weight MAE is taken over those.
constexpr float kActiveWeight = 0.1f;

using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The truth of a take: per row its pose (pitch, yaw, roll rad) and weights, the translation
// (cm; empty: each pose framed at `distance` as the renderer frames it), the camera its images
// were taken with, and the column of each rig shape in `weights` (-1: the truth has none).
struct TrackTruth {
  std::vector<int> col;
  RowMatrixF weights, pose, translation;
  render::Camera camera;
  float distance = 0.f;
};

// Sums of one row of metrics over the scored frames.
struct TrackErrors {
  double pose = 0., translation = 0., weights = 0., nme = 0., vertex = 0.;
  double active = 0., expression = 0.;
  int64_t active_count = 0;
};

// The sums over the scored frames: the solved rows' and the neutral face's.
struct TrackScores {
  TrackErrors err, neutral;
  std::vector<double> per_shape;
  std::vector<double> pose_errors;
  // Each scored frame's index, pose error, weight MAE and landmark NME (NaN without eyes).
  std::vector<std::array<double, 4>> frame_errors;
  int64_t scored = 0;
};

// Scores solved frames against the truth, frame by frame. `rig` is the truth's rig;
// `tracked_rig` (the same topology) was solved, its poses seen by `tracked_camera`.
class TrackScorer {
 public:
  TrackScorer(const rig::Rig& rig, const rig::Rig& tracked_rig, const TrackTruth& truth,
              const render::Camera& tracked_camera);

  // Landmark NME and vertex errors need the 68 landmarks (the eye corners normalize).
  bool HasEyes() const { return L_ == 68; }
  const TrackScores& scores() const { return scores_; }

  // Frame f of the track, whose truth is row t, solved as `solved` with weights `ws` (in the
  // tracked rig's shape order).
  void Score(int64_t f, int64_t t, const rig::RigidPose& solved, const Eigen::VectorXf& ws);

 private:
  rig::RigidPose TruthPose(int64_t t) const;
  double ScoreWeights(int64_t t, const Eigen::VectorXf& ws, Eigen::VectorXf* wt);
  void ScoreExpression(const Eigen::VectorXf& wt, const Eigen::VectorXf& ws);
  void ScoreLandmarks();

  const rig::Rig& rig_;
  const rig::Rig& tracked_rig_;
  const TrackTruth& truth_;
  const render::Camera tracked_camera_;
  const rig::RigEvaluator evaluator_, tracked_evaluator_;
  const int S_, L_;
  const double iod3_neutral_;
  rig::Vertices truth_posed_, solved_posed_, truth_shape_, solved_shape_;
  TrackScores scores_;
};

}  // namespace facecap::track

#endif  // FACECAP_TRACK_TRACK_METRICS_H_
