#include "track/track_metrics.h"

#include <algorithm>
#include <cmath>

#include "render/framing.h"
#include "rig/compare.h"

namespace facecap::track {

TrackScorer::TrackScorer(const rig::Rig& rig, const rig::Rig& tracked_rig, const TrackTruth& truth,
                         const render::Camera& tracked_camera)
    : rig_(rig), tracked_rig_(tracked_rig), truth_(truth), tracked_camera_(tracked_camera),
      evaluator_(rig), tracked_evaluator_(tracked_rig), S_(rig.NumShapes()),
      L_(static_cast<int>(rig.landmarks.size())),
      iod3_neutral_(rig::InterOcularDistance(rig, rig.neutral)) {
  scores_.per_shape.assign(S_, 0.);
}

void TrackScorer::Score(int64_t f, int64_t t, const rig::RigidPose& solved, const Eigen::VectorXf& ws) {
  TrackErrors& err = scores_.err;
  ++scores_.scored;
  const rig::RigidPose truth_pose = TruthPose(t);
  Eigen::VectorXf wt = Eigen::VectorXf::Zero(S_);
  const double frame_weight_err = ScoreWeights(t, ws, &wt);
  err.weights += frame_weight_err;
  const double pe = rig::RotationAngleDeg(truth_pose, solved);
  scores_.frame_errors.push_back({static_cast<double>(f), pe, frame_weight_err, std::nan("")});
  scores_.pose_errors.push_back(pe);
  err.pose += pe;
  err.translation += (truth_pose.translation - solved.translation).norm();
  ScoreExpression(wt, ws);
  evaluator_.EvaluatePosed(truth_pose, wt, &truth_posed_);
  tracked_evaluator_.EvaluatePosed(solved, ws, &solved_posed_);
  if (HasEyes()) ScoreLandmarks();
}

rig::RigidPose TrackScorer::TruthPose(int64_t t) const {
  const RowMatrixF& tp = truth_.pose;
  rig::RigidPose truth_pose;
  if (truth_.translation.rows() > 0) {
    truth_pose.pitch = tp(t, 0);
    truth_pose.yaw = tp(t, 1);
    truth_pose.roll = tp.cols() > 2 ? tp(t, 2) : 0.f;
    truth_pose.translation = truth_.translation.row(t).transpose();
  } else {
    truth_pose = render::FramedPose(rig_, truth_.distance, tp(t, 0), tp(t, 1),
                                    tp.cols() > 2 ? tp(t, 2) : 0.f);
  }
  return truth_pose;
}

// The truth's weights of row t into *wt; the per-shape and active-weight errors summed;
// returns the frame's weight MAE.
double TrackScorer::ScoreWeights(int64_t t, const Eigen::VectorXf& ws, Eigen::VectorXf* wt) {
  double frame_weight_err = 0.;
  for (int s = 0; s < S_; ++s) {
    if (truth_.col[s] >= 0) (*wt)[s] = truth_.weights(t, truth_.col[s]);
    const double e = std::abs((*wt)[s] - ws[s]);
    scores_.per_shape[s] += e;
    frame_weight_err += e / S_;
    scores_.neutral.weights += std::abs((*wt)[s]) / S_;
    if ((*wt)[s] > kActiveWeight) {
      scores_.err.active += e;
      scores_.neutral.active += (*wt)[s];
      ++scores_.err.active_count;
    }
  }
  return frame_weight_err;
}

// Expression: the shape without the rigid pose, less each rig's own neutral.
void TrackScorer::ScoreExpression(const Eigen::VectorXf& wt, const Eigen::VectorXf& ws) {
  evaluator_.EvaluateShape(wt, &truth_shape_);
  tracked_evaluator_.EvaluateShape(ws, &solved_shape_);
  if (iod3_neutral_ > 0.) {
    scores_.err.expression +=
        ((solved_shape_ - tracked_rig_.neutral) - (truth_shape_ - rig_.neutral))
            .rowwise().norm().mean() / iod3_neutral_;
    scores_.neutral.expression +=
        (truth_shape_ - rig_.neutral).rowwise().norm().mean() / iod3_neutral_;
  }
}

// Landmark NME and vertex error of the posed meshes, over the inter-ocular distance.
void TrackScorer::ScoreLandmarks() {
  const render::Camera& camera = truth_.camera;
  const int a = rig_.landmarks[36], b = rig_.landmarks[45];
  const float iod3 = (truth_posed_.row(a) - truth_posed_.row(b)).norm();
  const Eigen::Vector2f pa = camera.Project(truth_posed_.row(a).transpose()).head<2>();
  const Eigen::Vector2f pb = camera.Project(truth_posed_.row(b).transpose()).head<2>();
  const float iod2 = (pa - pb).norm();
  double lm = 0.;
  for (int l = 0; l < L_; ++l) {
    // The same surface points on both meshes (one topology): the truth's landmarks.
    lm += (camera.Project(truth_posed_.row(rig_.landmarks[l]).transpose()).head<2>() -
           tracked_camera_.Project(solved_posed_.row(rig_.landmarks[l]).transpose()).head<2>())
              .norm();
  }
  scores_.err.nme += lm / L_ / iod2;
  scores_.frame_errors.back()[3] = lm / L_ / iod2;
  scores_.err.vertex += (truth_posed_ - solved_posed_).rowwise().norm().mean() / iod3;
}

}  // namespace facecap::track
