#include "track/tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/Cholesky>

#include "util/errors.h"

namespace facecap::track {

bool TrackerOptions::Check(std::string* why) const {
  if (objective != "segmentation" && objective != "landmarks") {
    *why = "objective must be segmentation or landmarks, not " + objective;
    return false;
  }
  if (epochs < 1 || coarse_epochs < 0) {
    *why = "epochs must be >= 1 and coarse_epochs >= 0";
    return false;
  }
  if (levels < 1 || levels > 4) {
    *why = "levels must be in [1, 4]";
    return false;
  }
  if (pose_iterations < 0 || jaw_iterations < 0 || expression_iterations < 0) {
    *why = "iterations per block must be >= 0";
    return false;
  }
  if (!(weight_prior >= 0.f && weight_prior < 1e6f)) {
    *why = "weight_prior must be in [0, 1e6)";
    return false;
  }
  if (!(sparsity_prior >= 0.f && sparsity_prior < 1e6f)) {
    *why = "sparsity_prior must be in [0, 1e6)";
    return false;
  }
  if (!(landmark_weight >= 0.f && landmark_weight < 1e6f)) {
    *why = "landmark_weight must be in [0, 1e6)";
    return false;
  }
  if (!landmark_point_weights.empty()) {
    if (landmark_point_weights.size() != 68) {
      *why = "landmark_point_weights must hold 68 weights";
      return false;
    }
    for (float w : landmark_point_weights) {
      if (!(w >= 0.f && w < 1e6f)) {
        *why = "landmark_point_weights must be in [0, 1e6)";
        return false;
      }
    }
  }
  for (float w : region_weights) {
    if (!(w >= 0.f && w <= 1e6f)) {
      *why = "region_weights must be in [0, 1e6]";
      return false;
    }
  }
  if (!(function_tolerance > 0.)) {
    *why = "function_tolerance must be positive";
    return false;
  }
  if (!(convergence_tolerance > 0. && convergence_tolerance < 1.)) {
    *why = "convergence_tolerance must be in (0, 1)";
    return false;
  }
  return soft.Check(why);
}

const char* TerminationName(Termination t) {
  switch (t) {
    case Termination::kConvergence: return "CONVERGENCE";
    case Termination::kNoConvergence: return "NO_CONVERGENCE";
    case Termination::kFailure: return "FAILURE";
  }
  return "UNKNOWN";
}

std::string FrameSummary::BriefReport() const {
  char text[256];
  std::snprintf(text, sizeof(text),
                "Inverse rendering, Initial cost %.6e, Final cost %.6e, Iterations %d, "
                "Evaluations %d, Time %.3f s, Termination: %s",
                initial_cost, final_cost, iterations, evaluations, seconds,
                TerminationName(termination));
  return text;
}

namespace {

// The full parameter vector [pitch, yaw, roll, tx, ty, tz, scale, w...] in double, and the
// columns that one block solves.
struct BlockState {
  Eigen::VectorXd params;
  std::vector<int> columns;

  void Expand(const double* block, Eigen::VectorXf* full) const {
    *full = params.cast<float>();
    for (size_t k = 0; k < columns.size(); ++k) (*full)[columns[k]] = static_cast<float>(block[k]);
  }
};

void Unpack(const Eigen::VectorXf& full, rig::RigidPose* pose, Eigen::VectorXf* weights) {
  rig::UnpackRigParams(full, pose, weights);
}

// Writes the Gauss-Newton-compressed residual and Jacobian of a cost |r|^2 whose
// J^T J = normal and J^T r = gradient (see tracker.h): m + 1 residuals for m columns.
void CompressedResidual(const Eigen::MatrixXd& normal, const Eigen::VectorXd& gradient,
                        double squared_norm, double* residuals, double* jacobian) {
  const int m = static_cast<int>(gradient.size());
  Eigen::MatrixXd a = normal;
  const double scale = std::max(a.diagonal().maxCoeff(), 1e-12);
  a.diagonal().array() += 1e-9 * scale;
  Eigen::LLT<Eigen::MatrixXd> llt(a);
  Eigen::MatrixXd l = llt.matrixL();
  Eigen::VectorXd top = l.triangularView<Eigen::Lower>().solve(gradient);
  for (int i = 0; i < m; ++i) residuals[i] = top[i];
  residuals[m] = std::sqrt(std::max(squared_norm - top.squaredNorm(), 0.));
  if (jacobian) {
    // Rows of [L^T; 0], row-major (m + 1) x m.
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> j(
        jacobian, m + 1, m);
    j.setZero();
    j.topRows(m) = l.transpose();
  }
}

}  // namespace

// Shared workspace of one frame's solve (one thread).
struct Tracker::Impl {
  const Tracker& tracker;
  const TrackTarget& target;
  rig::Vertices posed;
  SoftRender render;
  Eigen::MatrixXf vertex_jacobian;  // landmarks objective
  Eigen::MatrixXf rows;
  SoftJacobianWorkspace jacobian_ws;
  int evaluations = 0;
  // The parameters `render` was made at: Ceres asks for the Jacobian of an accepted step at
  // the point whose cost it has just evaluated, and the render is reused then.
  Eigen::VectorXf rendered_at;

  Impl(const Tracker& t, const TrackTarget& tg) : tracker(t), target(tg) {}

  // Each pixel's weight under TrackerOptions::region_weights (none without them).
  std::vector<float> pixel_weights;
  void WeighPixels(const std::vector<float>& rendered, const std::vector<float>& target_rgb) {
    const std::vector<float>& omega = tracker.options_.region_weights;
    pixel_weights.clear();
    if (omega.empty()) return;
    const std::vector<Eigen::Vector3f>& colors = tracker.renderer_.region_colors();
    auto weight_of = [&](const float* rgb) {
      const Eigen::Vector3f x(rgb[0], rgb[1], rgb[2]);
      float nearest = (x - tracker.options_.soft.background_color).squaredNorm();
      float w = 1.f;
      for (size_t k = 0; k < colors.size(); ++k) {
        const float d = (x - colors[k]).squaredNorm();
        if (d < nearest) {
          nearest = d;
          w = omega[k];
        }
      }
      return w;
    };
    const size_t n = target_rgb.size() / 3;
    pixel_weights.resize(n);
    for (size_t i = 0; i < n; ++i) {
      pixel_weights[i] = std::min(weight_of(&target_rgb[3 * i]), weight_of(&rendered[3 * i]));
    }
  }

  // |F_seg - T|^2; with normal/gradient, also J^T J and J^T r over `columns`.
  double Segmentation(const Eigen::VectorXf& full, const std::vector<int>* columns,
                      Eigen::MatrixXd* normal, Eigen::VectorXd* gradient) {
    rig::RigidPose pose;
    Eigen::VectorXf weights;
    Unpack(full, &pose, &weights);
    if (rendered_at.size() != full.size() || rendered_at != full) {
      tracker.evaluator_.EvaluatePosed(pose, weights, &posed);
      tracker.renderer_.Render(posed, target.camera, &render);
      rendered_at = full;
      ++evaluations;
    }
    const std::vector<float>& c =
        tracker.options_.hard_residual ? render.hard_color : render.color;
    const std::vector<float>& t = target.image.data;
    WeighPixels(c, t);
    double sum = 0.;
    for (size_t i = 0; i < c.size(); ++i) {
      const double r = static_cast<double>(c[i]) - t[i];
      sum += (pixel_weights.empty() ? 1. : pixel_weights[i / 3]) * r * r;
    }
    if (!normal) return sum;
    const int m = static_cast<int>(columns->size());
    normal->setZero(m, m);
    gradient->setZero(m);
    const int n = static_cast<int>(render.edge_pixels.size());
    if (n > 0) {
      SoftEdgeJacobian(render, tracker.evaluator_, pose, weights, *columns, &rows, &jacobian_ws);
      // J^T J = sum |k|^2 g^T g and J^T r = sum (k . r) g^T, k the pixel's colour slope and
      // g its row of d d_A / dparams.
      Eigen::VectorXf scaled_r(n);
      for (int i = 0; i < n; ++i) {
        const EdgePixel& ep = render.edge_pixels[i];
        const float knorm = ep.color_slope.norm();
        const int p = ep.pixel;
        const Eigen::Vector3f r(c[3 * p] - t[3 * p], c[3 * p + 1] - t[3 * p + 1],
                                c[3 * p + 2] - t[3 * p + 2]);
        const float root = pixel_weights.empty() ? 1.f : std::sqrt(pixel_weights[p]);
        rows.row(i) *= knorm * root;
        scaled_r[i] = knorm > 0.f ? root * ep.color_slope.dot(r) / knorm : 0.f;
      }
      // Coefficient-based products: single-threaded (no OpenMP inside Eigen's GEMM), so the
      // result does not depend on the thread count.
      *normal = rows.transpose().lazyProduct(rows).cast<double>();
      *gradient = rows.transpose().lazyProduct(scaled_r).cast<double>();
    }
    return sum;
  }

  // Landmark reprojection error sum_l omega_l |proj(X_l) - l|^2 over the visible landmarks
  // from `first` on; omega_l from `point_weights` (empty: 1).
  double Landmarks(const Eigen::VectorXf& full, const std::vector<int>* columns,
                   Eigen::MatrixXd* normal, Eigen::VectorXd* gradient, int first = 0,
                   const std::vector<float>& point_weights = {}) {
    rig::RigidPose pose;
    Eigen::VectorXf weights;
    Unpack(full, &pose, &weights);
    const rig::Rig& rig = tracker.rig_;
    const int L = static_cast<int>(rig.landmarks.size());
    if (target.landmarks.rows() != L) {
      throw InvalidInputError("track: the landmarks objective needs " + std::to_string(L) +
                              " target landmarks, the target has " +
                              std::to_string(target.landmarks.rows()));
    }
    std::vector<int> ids(rig.landmarks.data(), rig.landmarks.data() + L);
    rig::Vertices positions;
    tracker.evaluator_.EvaluatePosedWithJacobian(pose, weights, ids, &positions,
                                                 normal ? &vertex_jacobian : nullptr);
    ++evaluations;
    const render::Camera& cam = target.camera;
    double sum = 0.;
    const int m = columns ? static_cast<int>(columns->size()) : 0;
    if (normal) {
      normal->setZero(m, m);
      gradient->setZero(m);
    }
    for (int l = first; l < L; ++l) {
      if (!target.landmark_visible.empty() && !target.landmark_visible[l]) continue;
      const Eigen::Vector3f x = positions.row(l).transpose();
      const Eigen::Vector3f uvd = cam.Project(x);
      const float omega = point_weights.empty() ? 1.f : point_weights[l];
      const Eigen::Vector2f r = uvd.head<2>() - target.landmarks.row(l).transpose();
      sum += omega * r.squaredNorm();
      if (!normal) continue;
      const float z = x.z();
      Eigen::Matrix<float, 2, 3> dp;
      dp << -cam.fx / z, 0.f, cam.fx * x.x() / (z * z), 0.f, cam.fy / z,
          -cam.fy * x.y() / (z * z);
      Eigen::MatrixXf jl(2, m);
      for (int k = 0; k < m; ++k) {
        jl.col(k) = dp * vertex_jacobian.block<3, 1>(3 * l, (*columns)[k]);
      }
      const Eigen::MatrixXd jd = jl.cast<double>();
      *normal += omega * (jd.transpose() * jd);
      *gradient += omega * (jd.transpose() * r.cast<double>());
    }
    return sum;
  }

  double Objective(bool landmarks, const Eigen::VectorXf& full, const std::vector<int>* columns,
                   Eigen::MatrixXd* normal, Eigen::VectorXd* gradient) {
    if (landmarks) return Landmarks(full, columns, normal, gradient);
    double sum = Segmentation(full, columns, normal, gradient);
    const float lambda = tracker.options_.landmark_weight;
    if (lambda > 0.f && target.landmarks.rows() > 0) {
      Eigen::MatrixXd lm_normal;
      Eigen::VectorXd lm_gradient;
      // The term leaves out the 17 jaw points of the 68: dlib puts them on the silhouette of
      // the turned head, which no fixed vertex follows, and fitting them tilts the head.
      const int first = target.landmarks.rows() == 68 ? 17 : 0;
      sum += lambda * Landmarks(full, columns, normal ? &lm_normal : nullptr,
                                normal ? &lm_gradient : nullptr, first,
                                tracker.options_.landmark_point_weights);
      if (normal) {
        *normal += lambda * lm_normal;
        *gradient += lambda * lm_gradient;
      }
    }
    return sum;
  }
};

namespace {

// One block's data term for Ceres, in compressed form.
class BlockCost : public ceres::CostFunction {
 public:
  BlockCost(Tracker::Impl* impl, const BlockState* state, bool landmarks)
      : impl_(impl), state_(state), landmarks_(landmarks) {
    const int m = static_cast<int>(state->columns.size());
    set_num_residuals(m + 1);
    mutable_parameter_block_sizes()->push_back(m);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::VectorXf full;
    state_->Expand(parameters[0], &full);
    const int m = static_cast<int>(state_->columns.size());
    if (!jacobians || !jacobians[0]) {
      const double sum = impl_->Objective(landmarks_, full, nullptr, nullptr, nullptr);
      residuals[0] = std::sqrt(sum);
      for (int i = 1; i <= m; ++i) residuals[i] = 0.;
      return std::isfinite(sum);
    }
    Eigen::MatrixXd normal;
    Eigen::VectorXd gradient;
    const double sum = impl_->Objective(landmarks_, full, &state_->columns, &normal, &gradient);
    if (!std::isfinite(sum) || !normal.allFinite()) return false;
    CompressedResidual(normal, gradient, sum, residuals, jacobians[0]);
    return true;
  }

 private:
  Tracker::Impl* impl_;
  const BlockState* state_;
  bool landmarks_;
};

// sqrt(lambda) w_i for the weight columns of a block (prior towards the neutral).
class WeightPrior : public ceres::CostFunction {
 public:
  WeightPrior(std::vector<int> slots, double sqrt_lambda, int block_size)
      : slots_(std::move(slots)), sqrt_lambda_(sqrt_lambda), block_size_(block_size) {
    set_num_residuals(static_cast<int>(slots_.size()));
    mutable_parameter_block_sizes()->push_back(block_size);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (size_t i = 0; i < slots_.size(); ++i) residuals[i] = sqrt_lambda_ * parameters[0][slots_[i]];
    if (jacobians && jacobians[0]) {
      std::fill(jacobians[0], jacobians[0] + slots_.size() * block_size_, 0.);
      for (size_t i = 0; i < slots_.size(); ++i) {
        jacobians[0][i * block_size_ + slots_[i]] = sqrt_lambda_;
      }
    }
    return true;
  }

 private:
  std::vector<int> slots_;
  double sqrt_lambda_;
  int block_size_;
};

// The sparsity prior mu sum_i w_i for the weight columns of a block, each term smoothed as
// mu (sqrt(w^2 + e^2) - e), e = kSparsityEpsilon: the residual sqrt(mu (sqrt(w^2 + e^2) - e))
// (Ceres halves its square, as it halves the pixel residual's), whose derivative tends to
// sqrt(mu / (2 e)) at w = 0.
constexpr double kSparsityEpsilon = 0.01;
class SparsityPrior : public ceres::CostFunction {
 public:
  SparsityPrior(std::vector<int> slots, double mu, int block_size)
      : slots_(std::move(slots)), mu_(mu), block_size_(block_size) {
    set_num_residuals(static_cast<int>(slots_.size()));
    mutable_parameter_block_sizes()->push_back(block_size);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    constexpr double e = kSparsityEpsilon;
    if (jacobians && jacobians[0]) {
      std::fill(jacobians[0], jacobians[0] + slots_.size() * block_size_, 0.);
    }
    for (size_t i = 0; i < slots_.size(); ++i) {
      const double w = parameters[0][slots_[i]];
      const double root = std::sqrt(w * w + e * e);
      residuals[i] = std::sqrt(mu_ * (root - e));
      if (jacobians && jacobians[0]) {
        // d/dw sqrt(mu h(w)) = mu h'(w) / (2 r), h' = w / root; its limit at w = 0.
        jacobians[0][i * block_size_ + slots_[i]] =
            residuals[i] > 1e-12 ? mu_ * (w / root) / (2. * residuals[i])
                                 : std::copysign(std::sqrt(mu_ / (2. * e)), w);
      }
    }
    return true;
  }

 private:
  std::vector<int> slots_;
  double mu_;
  int block_size_;
};

struct BlockOutcome {
  int iterations = 0;
  bool failed = false;
};

}  // namespace

namespace {

// Solves one block with Ceres (single-threaded), updating state->params.
BlockOutcome SolveBlock(Tracker::Impl* impl, BlockState* state, bool landmarks,
                        int max_iterations, const TrackerOptions& options, double prior_scale) {
  BlockOutcome outcome;
  const int m = static_cast<int>(state->columns.size());
  if (m == 0 || max_iterations == 0) return outcome;
  std::vector<double> block(m);
  for (int k = 0; k < m; ++k) block[k] = state->params[state->columns[k]];
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddResidualBlock(new BlockCost(impl, state, landmarks), nullptr, block.data());
  std::vector<int> weight_slots;
  for (int k = 0; k < m; ++k) {
    if (state->columns[k] >= rig::kNumPoseParams) weight_slots.push_back(k);
  }
  if (!weight_slots.empty() && options.weight_prior > 0.f) {
    problem.AddResidualBlock(
        new WeightPrior(weight_slots, std::sqrt(options.weight_prior * prior_scale), m), nullptr,
        block.data());
  }
  if (!weight_slots.empty() && options.sparsity_prior > 0.f) {
    problem.AddResidualBlock(
        new SparsityPrior(weight_slots, options.sparsity_prior * prior_scale, m), nullptr,
        block.data());
  }
  for (int slot : weight_slots) {
    problem.SetParameterLowerBound(block.data(), slot, 0.);
    problem.SetParameterUpperBound(block.data(), slot, 1.);
  }
  for (int k = 0; k < m; ++k) {
    const int c = state->columns[k];
    if (c == rig::kPitch || c == rig::kYaw || c == rig::kRoll) {
      problem.SetParameterLowerBound(block.data(), k, -1.6);
      problem.SetParameterUpperBound(block.data(), k, 1.6);
    } else if (c == rig::kScale) {
      problem.SetParameterLowerBound(block.data(), k, 0.5);
      problem.SetParameterUpperBound(block.data(), k, 2.0);
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.num_threads = 1;
  so.max_num_iterations = max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.gradient_tolerance = 1e-10;
  so.parameter_tolerance = 1e-7;
  // Bounds are enforced by Ceres projecting each step onto the box; its extra projected line
  // search for bounded problems evaluates the full Jacobian (a render) at every trial step and
  // would triple the renders per iteration.
  so.max_num_line_search_step_size_iterations = 0;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  outcome.iterations = static_cast<int>(summary.iterations.size()) - 1;
  outcome.failed = summary.termination_type == ceres::FAILURE;
  // Keep the best point Ceres found (it returns the last accepted one).
  for (int k = 0; k < m; ++k) state->params[state->columns[k]] = block[k];
  return outcome;
}

// The columns of a block that a bounded step can move: a weight at a bound whose gradient
// pushes it out of [0, 1] stays there for this block solve (the active set of a projected
// method). Without this, the Gauss-Newton step of a block with many weights at 0 (most
// expressions leave most shapes off) points out of the box; its projection decreases the cost
// far less than the model predicts and the trust region rejects step after step. The set is
// formed anew for every block solve, so a weight leaves its bound when the gradient turns.
std::vector<int> FreeColumns(Tracker::Impl* impl, const BlockState& state,
                             const std::vector<int>& columns, bool landmarks, double prior,
                             double sparsity) {
  std::vector<int> weight_columns;
  for (int c : columns) {
    if (c >= rig::kNumPoseParams) weight_columns.push_back(c);
  }
  if (weight_columns.empty()) return columns;
  Eigen::MatrixXd normal;
  Eigen::VectorXd gradient;
  impl->Objective(landmarks, state.params.cast<float>(), &weight_columns, &normal, &gradient);
  std::vector<int> free;
  size_t k = 0;
  for (int c : columns) {
    if (c < rig::kNumPoseParams) {
      free.push_back(c);
      continue;
    }
    const double w = state.params[c];
    // Half the gradient of |r|^2 + prior |w|^2 + sparsity sum w (at w = 0 the L1 term's
    // one-sided derivative, so that a weight leaves 0 only when the pixels outweigh it).
    const double g = gradient[k++] + prior * w + 0.5 * sparsity;
    const bool stuck = (w <= 0. && g >= 0.) || (w >= 1. && g <= 0.);
    if (!stuck) free.push_back(c);
  }
  return free;
}

}  // namespace

Tracker::Tracker(const rig::Rig& rig, std::vector<Eigen::Vector3f> region_colors,
                 const TrackerOptions& options)
    : rig_(rig),
      options_(options),
      evaluator_(rig),
      renderer_(rig, std::move(region_colors), options.soft) {
  std::string why;
  if (!options_.Check(&why)) throw InvalidInputError("track: " + why);
  if (!options_.region_weights.empty() &&
      options_.region_weights.size() != renderer_.region_colors().size()) {
    throw InvalidInputError("track: " + std::to_string(options_.region_weights.size()) +
                            " region weights for a rig of " +
                            std::to_string(renderer_.region_colors().size()) + " regions");
  }
  jaw_shapes_ = evaluator_.jaw_shapes();
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (!std::binary_search(jaw_shapes_.begin(), jaw_shapes_.end(), s)) other_shapes_.push_back(s);
  }
}

Tracker::~Tracker() = default;

namespace {

// The rigid-pose columns the options solve: translation, and pitch, yaw (and roll) unless the
// rotation is held; the scale when asked.
std::vector<int> PoseColumns(const TrackerOptions& options, bool scale) {
  std::vector<int> columns;
  if (options.solve_rotation) {
    columns = {rig::kPitch, rig::kYaw};
    if (options.solve_roll) columns.push_back(rig::kRoll);
  }
  columns.insert(columns.end(), {rig::kTx, rig::kTy, rig::kTz});
  if (scale) columns.push_back(rig::kScale);
  return columns;
}

}  // namespace

void Tracker::HoldShapesFixed(const std::vector<int>& shapes) {
  auto drop = [&](std::vector<int>* list) {
    list->erase(std::remove_if(list->begin(), list->end(),
                               [&](int s) {
                                 return std::find(shapes.begin(), shapes.end(), s) != shapes.end();
                               }),
                list->end());
  };
  drop(&jaw_shapes_);
  drop(&other_shapes_);
}

double Tracker::SegmentationCost(const TrackTarget& target, const rig::RigidPose& pose,
                                 const Eigen::VectorXf& weights) const {
  Impl impl(*this, target);
  return 0.5 * impl.Segmentation(rig::PackRigParams(pose, weights), nullptr, nullptr, nullptr);
}

double Tracker::NormalEquations(const TrackTarget& target, const Eigen::VectorXf& params,
                                const std::vector<int>& columns, Eigen::MatrixXd* normal,
                                Eigen::VectorXd* gradient) const {
  if (params.size() != rig::NumRigParams(rig_)) {
    throw InvalidInputError("track: NormalEquations needs " + std::to_string(rig::NumRigParams(rig_)) +
                            " parameters, got " + std::to_string(params.size()));
  }
  Impl impl(*this, target);
  return impl.Objective(options_.objective == "landmarks", params, &columns, normal, gradient);
}

rig::RigidPose Tracker::PoseFromLandmarks(const TrackTarget& target,
                                          const rig::RigidPose& initial_pose,
                                          const Eigen::VectorXf& weights) const {
  Impl impl(*this, target);
  BlockState state;
  state.params = rig::PackRigParams(initial_pose, weights).cast<double>();
  state.columns = PoseColumns(options_, false);
  SolveBlock(&impl, &state, true, 20, options_, 1.);
  rig::RigidPose pose;
  Eigen::VectorXf w;
  Unpack(state.params.cast<float>(), &pose, &w);
  return pose;
}

TrackResult Tracker::Solve(const TrackTarget& target, const rig::RigidPose& initial_pose,
                           const Eigen::VectorXf& initial_weights) const {
  const auto start = std::chrono::steady_clock::now();
  const bool landmarks = options_.objective == "landmarks";
  if (!landmarks && (target.image.width != target.camera.width ||
                     target.image.height != target.camera.height || target.image.channels != 3)) {
    throw InvalidInputError("track: the target image must be RGB of the camera's size");
  }
  if (initial_weights.size() != rig_.NumShapes()) {
    throw InvalidInputError("track: initial weights have the wrong size");
  }
  // The pyramid, coarsest first.
  const int levels = landmarks ? 1 : options_.levels;
  std::vector<TrackTarget> pyramid{target};
  for (int l = 1; l < levels; ++l) {
    if (pyramid.back().camera.width < 16) break;
    pyramid.push_back(Downsample(pyramid.back()));
  }
  std::reverse(pyramid.begin(), pyramid.end());

  BlockState state;
  state.params = rig::PackRigParams(initial_pose, initial_weights).cast<double>();
  const std::vector<int> pose_columns = PoseColumns(options_, options_.solve_scale);
  std::vector<int> jaw_columns, other_columns;
  for (int s : jaw_shapes_) jaw_columns.push_back(rig::kNumPoseParams + s);
  for (int s : other_shapes_) other_columns.push_back(rig::kNumPoseParams + s);

  TrackResult result;
  FrameSummary& summary = result.summary;
  Impl full_impl(*this, target);
  auto objective_at_full = [&](const Eigen::VectorXd& params) {
    return 0.5 * full_impl.Objective(landmarks, params.cast<float>(), nullptr, nullptr, nullptr);
  };
  summary.initial_cost = objective_at_full(state.params);
  bool failed = false;
  double cost_before_last_epoch = summary.initial_cost;
  for (size_t level = 0; level < pyramid.size(); ++level) {
    const bool finest = level + 1 == pyramid.size();
    const int epochs = finest ? options_.epochs : options_.coarse_epochs;
    Impl impl(*this, pyramid[level]);
    // The prior is relative to the pixel cost of a 128 x 128 image: it scales with the pixel
    // count of the level, so that its balance with the data term does not depend on size.
    const double prior_scale =
        landmarks ? 1. : static_cast<double>(pyramid[level].camera.width) *
                             pyramid[level].camera.height / (128. * 128.);
    for (int epoch = 0; epoch < epochs; ++epoch) {
      const bool last_epoch = finest && epoch + 1 == epochs;
      if (last_epoch) cost_before_last_epoch = objective_at_full(state.params);
      const std::pair<const std::vector<int>*, int> blocks[3] = {
          {&pose_columns, options_.pose_iterations},
          {&jaw_columns, options_.jaw_iterations},
          {&other_columns, options_.expression_iterations}};
      for (int b = 0; b < 3; ++b) {
        const std::vector<int>* columns = blocks[b].first;
        const int iterations = blocks[b].second;
        const double prior = options_.weight_prior * prior_scale;
        const double sparsity = options_.sparsity_prior * prior_scale;
        state.columns = iterations > 0
                            ? FreeColumns(&impl, state, *columns, landmarks, prior, sparsity)
                            : std::vector<int>();
        const BlockOutcome o =
            SolveBlock(&impl, &state, landmarks, iterations, options_, prior_scale);
        summary.iterations += o.iterations;
        failed = failed || o.failed;
      }
    }
    summary.evaluations += impl.evaluations;
  }
  summary.final_cost = objective_at_full(state.params);
  const bool converged = cost_before_last_epoch - summary.final_cost <=
                         options_.convergence_tolerance * cost_before_last_epoch;
  summary.termination = failed ? Termination::kFailure
                               : (converged ? Termination::kConvergence : Termination::kNoConvergence);
  Unpack(state.params.cast<float>(), &result.pose, &result.weights);
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

TrackTarget Downsample(const TrackTarget& target) {
  TrackTarget out;
  const render::Camera& c = target.camera;
  out.camera = c;
  out.camera.width = c.width / 2;
  out.camera.height = c.height / 2;
  out.camera.fx = c.fx / 2;
  out.camera.fy = c.fy / 2;
  out.camera.cx = c.cx / 2;
  out.camera.cy = c.cy / 2;
  if (!target.image.empty()) {
    const int ch = target.image.channels;
    out.image = ImageF(out.camera.width, out.camera.height, ch);
    for (int y = 0; y < out.image.height; ++y) {
      for (int x = 0; x < out.image.width; ++x) {
        for (int k = 0; k < ch; ++k) {
          out.image.at(x, y, k) =
              0.25f * (target.image.at(2 * x, 2 * y, k) + target.image.at(2 * x + 1, 2 * y, k) +
                       target.image.at(2 * x, 2 * y + 1, k) +
                       target.image.at(2 * x + 1, 2 * y + 1, k));
        }
      }
    }
  }
  out.landmarks = target.landmarks / 2.f;
  out.landmark_visible = target.landmark_visible;
  return out;
}

ImageF ToFloatImage(const Image8& image) {
  ImageF out(image.width, image.height, image.channels);
  for (size_t i = 0; i < image.data.size(); ++i) out.data[i] = image.data[i] / 255.f;
  return out;
}

ImageF RecolorSegmentation(const ImageF& image, const std::vector<Eigen::Vector3f>& from,
                           const std::vector<Eigen::Vector3f>& to,
                           const Eigen::Vector3f& background) {
  ImageF out = image;
  for (int p = 0; p < image.width * image.height; ++p) {
    const Eigen::Vector3f c(image.data[3 * p], image.data[3 * p + 1], image.data[3 * p + 2]);
    float best = (c - background).squaredNorm();
    Eigen::Vector3f color = background;
    for (size_t r = 0; r < from.size(); ++r) {
      const float d = (c - from[r]).squaredNorm();
      if (d < best) {
        best = d;
        color = to[r];
      }
    }
    out.data[3 * p] = color.x();
    out.data[3 * p + 1] = color.y();
    out.data[3 * p + 2] = color.z();
  }
  return out;
}

std::vector<Eigen::Vector3f> SkinRegionColors(const rig::Rig& rig) {
  const Eigen::Vector3f skin(0.78f, 0.58f, 0.48f);
  std::vector<Eigen::Vector3f> colors;
  for (const auto& r : rig.regions) {
    const std::string& n = r.name;
    Eigen::Vector3f c = skin;
    if (n.find("lip") != std::string::npos) c = Eigen::Vector3f(0.70f, 0.38f, 0.38f);
    else if (n == "mouth_interior") c = Eigen::Vector3f(0.35f, 0.12f, 0.12f);
    else if (n == "sclera") c = Eigen::Vector3f(0.88f, 0.86f, 0.82f);
    else if (n == "iris") c = Eigen::Vector3f(0.30f, 0.22f, 0.15f);
    else if (n == "pupil") c = Eigen::Vector3f(0.03f, 0.03f, 0.03f);
    else if (n.find("brow") != std::string::npos) c = Eigen::Vector3f(0.32f, 0.22f, 0.15f);
    else if (n == "hair") c = Eigen::Vector3f(0.20f, 0.13f, 0.08f);
    colors.push_back(c);
  }
  return colors;
}

}  // namespace facecap::track
