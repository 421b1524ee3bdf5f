#include "track/person_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "rig/evaluate.h"
#include "rig/identity_shapes.h"
#include "track/soft_segmentation.h"
#include "util/errors.h"

namespace facecap::track {

PersonFitOptions::PersonFitOptions() {
  landmark_tracker.objective = "landmarks";
  landmark_tracker.levels = 1;
  landmark_tracker.epochs = 3;
  refine_tracker.objective = "segmentation";
  refine_tracker.landmark_weight = 0.f;
  refine_tracker.weight_prior = 30.f;
}

bool PersonFitOptions::Check(std::string* why) const {
  if (landmark_rounds < 0 || refine_rounds < 0) {
    *why = "landmark_rounds and refine_rounds must be >= 0";
    return false;
  }
  if (!(identity_prior > 0. && identity_prior < 1e6)) {
    *why = "identity_prior must be in (0, 1e6)";
    return false;
  }
  if (!(robust_px > 0. && robust_px < 1e6)) { *why = "robust_px must be in (0, 1e6)"; return false; }
  if (!(robust_cost > 0. && robust_cost < 1e6)) { *why = "robust_cost must be in (0, 1e6)"; return false; }
  if (!(damping >= 0. && damping < 1e3)) { *why = "damping must be in [0, 1e3)"; return false; }
  if (landmark_tracker.objective != "landmarks") {
    *why = "the landmark phase solves the landmarks objective";
    return false;
  }
  if (refine_tracker.objective != "segmentation") {
    *why = "the refinement solves the segmentation objective";
    return false;
  }
  return landmark_tracker.Check(why) && refine_tracker.Check(why);
}

struct PersonFitter::Impl {
  PersonFitOptions options;
  rig::Rig generic;
  // The generic rig with the identity modes appended as shapes: a frame's
  // parameters are [pose, expression weights, identity], and the tracker's normal equations
  // give the identity's columns directly.
  rig::Rig augmented;
  std::vector<rig::Vertices> modes;  // the identity modes
  std::unique_ptr<Tracker> landmark_tracker, refine_tracker, identity_tracker;
  int num_shapes = 0;                // the generic rig's expression shapes
};

PersonFitter::PersonFitter(const rig::Rig& generic, const PersonFitOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("person fit: " + why);
  if (generic.landmarks.size() != 68) {
    throw InvalidInputError("person fit: the rig needs the 68 iBUG landmarks");
  }
  Impl& m = *impl_;
  m.options = options;
  m.generic = generic;
  m.num_shapes = generic.NumShapes();
  m.modes = generic.identity_modes;
  m.augmented = rig::WithIdentityShapes(generic);
  std::vector<int> identity_shapes;
  for (int k = 0; k < static_cast<int>(m.modes.size()); ++k) identity_shapes.push_back(m.num_shapes + k);
  const std::vector<Eigen::Vector3f> colors = RigRegionColors(generic);
  m.landmark_tracker = std::make_unique<Tracker>(m.augmented, colors, options.landmark_tracker);
  TrackerOptions per_frame = options.refine_tracker;
  per_frame.region_weights.clear();
  m.refine_tracker = std::make_unique<Tracker>(m.augmented, colors, per_frame);
  m.identity_tracker = std::make_unique<Tracker>(m.augmented, colors, options.refine_tracker);
  m.landmark_tracker->HoldShapesFixed(identity_shapes);
  m.refine_tracker->HoldShapesFixed(identity_shapes);
  m.identity_tracker->HoldShapesFixed(identity_shapes);
}

PersonFitter::~PersonFitter() = default;

int PersonFitter::NumIdentityParams() const { return static_cast<int>(impl_->modes.size()); }

rig::Vertices PersonFitter::Neutral(const Eigen::VectorXd& identity) const {
  if (identity.size() != NumIdentityParams()) {
    throw InvalidInputError("person fit: " + std::to_string(NumIdentityParams()) +
                            " identity parameters expected, got " + std::to_string(identity.size()));
  }
  rig::Vertices n = impl_->generic.neutral;
  for (int k = 0; k < identity.size(); ++k) {
    if (identity[k] != 0.) n += static_cast<float>(identity[k]) * impl_->modes[k];
  }
  return n;
}

rig::Rig PersonFitter::WithNeutral(const Eigen::VectorXd& identity) const {
  rig::Rig r = impl_->generic;
  r.neutral = Neutral(identity);
  return r;
}

PersonFrameContribution PersonFitter::SolveFrame(const Eigen::VectorXd& identity, bool refine,
                                                 PersonFrame* frame) const {
  const Impl& m = *impl_;
  const int S = m.num_shapes, K = NumIdentityParams();
  if (frame->weights.size() != S) throw InvalidInputError("person fit: frame weights of the wrong size");
  if (frame->target.landmarks.rows() != 68) {
    throw InvalidInputError("person fit: every frame needs its 68 landmarks");
  }
  const Tracker& tracker = refine ? *m.refine_tracker : *m.landmark_tracker;
  Eigen::VectorXf weights(S + K);
  weights << frame->weights, identity.cast<float>();
  const TrackResult r = tracker.Solve(frame->target, frame->pose, weights);
  frame->pose = r.pose;
  frame->weights = r.weights.head(S);

  // Local columns: the pose and the weights off their bounds; global: the identity.
  std::vector<int> columns = {rig::kPitch, rig::kYaw, rig::kRoll, rig::kTx, rig::kTy, rig::kTz};
  for (int s = 0; s < S; ++s) {
    const float w = frame->weights[s];
    if (w > 1e-3f && w < 1.f - 1e-3f) columns.push_back(rig::kNumPoseParams + s);
  }
  const int local = static_cast<int>(columns.size());
  for (int k = 0; k < K; ++k) columns.push_back(rig::kNumPoseParams + S + k);
  const Eigen::VectorXf params = rig::PackRigParams(r.pose, r.weights);
  Eigen::MatrixXd normal;
  Eigen::VectorXd gradient;
  PersonFrameContribution c;
  const Tracker& equations = refine ? *m.identity_tracker : *m.landmark_tracker;
  c.cost = equations.NormalEquations(frame->target, params, columns, &normal, &gradient);
  // The expression prior of the per-frame solve belongs to the local block.
  const render::Camera& cam = frame->target.camera;
  const double pixels = static_cast<double>(cam.width) * cam.height;
  const double prior = (refine ? pixels / (128. * 128.) : 1.) * tracker.options().weight_prior;
  for (int i = 6; i < local; ++i) {
    normal(i, i) += prior;
    gradient[i] += prior * params[columns[i]];
  }
  const Eigen::MatrixXd hll = normal.topLeftCorner(local, local);
  const Eigen::MatrixXd hlg = normal.topRightCorner(local, K);
  Eigen::MatrixXd damped = hll;
  damped.diagonal().array() += 1e-9 * std::max(1e-12, hll.diagonal().maxCoeff());
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(damped);
  c.normal = normal.bottomRightCorner(K, K) - hlg.transpose() * ldlt.solve(hlg);
  c.gradient = gradient.tail(K) - hlg.transpose() * ldlt.solve(gradient.head(local));
  // Landmark residual of the frame (pixels of a 128-pixel target) and its robust weight.
  {
    const double sum = m.landmark_tracker->NormalEquations(frame->target, params, {}, nullptr, nullptr);
    int visible = 0;
    for (size_t l = 0; l < 68; ++l) {
      visible += frame->target.landmark_visible.empty() || frame->target.landmark_visible[l];
    }
    c.landmark_rms = std::sqrt(sum / std::max(1, visible)) * 128. / cam.width;
  }
  // Every frame's system in the units of a 128 x 128 target.
  const double unit = 128. * 128. / pixels;
  c.normal *= unit;
  c.gradient *= unit;
  c.cost *= unit;
  return c;
}

Eigen::VectorXd PersonFitter::Step(const Eigen::VectorXd& identity,
                                   std::vector<PersonFrameContribution>* frames,
                                   bool refine) const {
  const int K = NumIdentityParams();
  const PersonFitOptions& o = impl_->options;
  double scale = o.robust_px;
  if (refine && !frames->empty()) {
    std::vector<double> costs;
    for (const PersonFrameContribution& c : *frames) costs.push_back(c.cost);
    std::nth_element(costs.begin(), costs.begin() + costs.size() / 2, costs.end());
    scale = o.robust_cost * std::max(costs[costs.size() / 2], 1e-12);
  }
  for (PersonFrameContribution& c : *frames) {
    const double e = refine ? c.cost : c.landmark_rms;
    c.weight = 1. / (1. + (e / scale) * (e / scale));
  }
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(K, K);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(K);
  for (const PersonFrameContribution& c : *frames) {
    h += c.weight * c.normal;
    g += c.weight * c.gradient;
  }
  // alpha ~ N(0, 1), scaled by identity_prior.
  const double lambda = impl_->options.identity_prior;
  for (int k = 0; k < K; ++k) {
    h(k, k) += lambda;
    g[k] += lambda * identity[k];
  }
  h.diagonal() *= 1. + impl_->options.damping;
  Eigen::VectorXd step = -h.ldlt().solve(g);
  // A step of more than one standard deviation per round is cut back.
  const double largest = step.cwiseAbs().maxCoeff();
  if (largest > 1.) step *= 1. / largest;
  return identity + step;
}

}  // namespace facecap::track
