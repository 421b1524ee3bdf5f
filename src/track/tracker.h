// Inverse-rendering tracker (paper 000 Sec. 8): per frame,
//
//   argmin_{P_rigid, w in [0,1]^S}  || F_seg(P_rigid, w) - T ||^2  +  lambda ||w||^2
//
// with F_seg the soft segmentation render of the posed rig (soft_segmentation.h), T the target
// segmentation image in the rig's image frame, the pixel-wise L2 distance of the paper and an
// optional small L2 prior towards the neutral for the shapes a segmentation image barely shows
// (tongue, cheek puff). Block coordinate descent as in the paper: each epoch solves the rigid
// pose, then the jaw controls (shapes with jaw skinning), then the remaining controls, each
// block a bounded Ceres trust-region solve with the others fixed. Optional coarse-to-fine
// levels solve on downsampled targets first.
//
// The pixel residual has 3 x #pixels entries but only the pixels along borders have non-zero
// derivatives; each block's cost is handed to Ceres in Gauss-Newton-compressed form: with
// J^T J = L L^T (Cholesky) and b = J^T r, the residual [L^{-1} b; sqrt(|r|^2 - |L^{-1} b|^2)]
// with Jacobian [L^T; 0] has exactly the cost |r|^2, gradient and Gauss-Newton Hessian of the
// full pixel residual, at a size of (block + 1) instead of 3 x #pixels.
//
// A baseline objective fits the rig's 68 landmarks to 2D target landmarks (the classic
// approach) with the same parametrization and blocks; it also gives the pose initialisation
// "from landmarks" (paper Sec. 3).
//
// Every solve runs single-threaded and depends only on its inputs: the same frame gives the
// same result bit for bit whatever the number of ranks or threads around it.
#ifndef FACECAP_TRACK_TRACKER_H_
#define FACECAP_TRACK_TRACKER_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "rig/rig.h"
#include "track/soft_segmentation.h"
#include "util/image.h"

namespace facecap::track {

struct TrackerOptions {
  // What the solve matches: "segmentation" (pixel-wise L2 against the target image) or
  // "landmarks" (2D landmark reprojection error, the landmarks-only baseline).
  std::string objective = "segmentation";
  // Epochs of block coordinate descent at the finest level.
  int epochs = 3;
  // Epochs at each coarser level (coarse-to-fine).
  int coarse_epochs = 2;
  // Resolution levels: 1 solves at the target's size only; L > 1 first solves at 1 / 2^(L-1)
  // of it, then doubles the resolution up to the full size.
  int levels = 3;
  // Ceres iterations per block solve: the rigid pose, the jaw controls, the rest.
  int pose_iterations = 8;
  int jaw_iterations = 6;
  int expression_iterations = 10;
  // Solve the rotation of P_rigid (false: held at its initial value, the translation alone
  // solved), roll besides pitch and yaw, and the uniform scale.
  bool solve_rotation = true;
  bool solve_roll = true;
  bool solve_scale = false;
  // lambda of the L2 prior lambda |w|^2 towards the neutral on the solved weights, relative
  // to the pixel cost (sum of squared RGB differences in [0, 1]) of a 128 x 128 image; it
  // scales with the pixel count of other sizes.
  // Shapes that a segmentation image barely shows (tongue, cheek puff, dimples) are otherwise
  // free to take any value that trades a few border pixels; 0 turns it off.
  float weight_prior = 3.f;
  // mu of a sparsity prior mu sum_i w_i on the solved weights (the L1 norm, the weights being
  // >= 0), relative to the same pixel cost as weight_prior. Unlike the L2 prior it pulls every
  // weight down by the same amount: a weight that the pixels push up by less stays at 0, one
  // they push further is lowered by a constant, not in proportion to its value. Smoothed within
  // 0.01 of 0 for Gauss-Newton; 0: off.
  float sparsity_prior = 0.f;
  // lambda_L of a landmark term lambda_L sum_l |proj(X_l) - l|^2 added to the segmentation
  // cost, over the target's visible landmarks but the jaw contour (points 17-67 of the 68;
  // pixels of the target image; it scales with the pixel count like the prior); 0: off, and
  // ignored for a target without landmarks.
  float landmark_weight = 0.f;
  // omega_l: the landmark term's weight of each of the 68 points, lambda_L sum_l omega_l
  // |proj(X_l) - l|^2 (empty: 1 each). Set by the caller (track: the inverse squared noise of
  // each point that person fit measured), not an option of job files.
  std::vector<float> landmark_point_weights;
  // omega_r: one weight per rig region (empty: 1 each). A pixel's squared residual counts
  // min(omega of the region its target shows, omega of the region the render shows), each
  // read as the nearest region colour (the background's: 1), so that weight 0 leaves a region's
  // pixels out on both sides. Set by the caller (person fit: the regions the identity step of
  // its refinement ignores), not an option of job files.
  std::vector<float> region_weights;
  // Residual colours: false compares the soft render F_seg with the target (consistent cost
  // and derivative); true compares the hard render (exactly zero at the truth for a clean,
  // aliased target) and uses the soft render's derivative as its Gauss-Newton Jacobian.
  bool hard_residual = true;
  // Ceres trust-region stopping: relative cost decrease below which a block stops.
  double function_tolerance = 1e-4;
  // A frame's solve counts as converged when its last epoch lowered the cost by less than
  // this fraction (the blocks themselves usually stop at their iteration limits).
  double convergence_tolerance = 0.01;
  // Soft render: half-width of the antialiased band around region borders and silhouettes
  // (pixels, at every level), background colour, visibility tolerance.
  SoftSegmentationOptions soft;

  template <class V>
  void Visit(V&& v) {
    v("objective", objective, "what the solve matches: segmentation | landmarks");
    v("epochs", epochs, "epochs of block coordinate descent (pose, jaw, rest) at full resolution");
    v("coarse_epochs", coarse_epochs, "epochs at each coarser level");
    v("levels", levels, "coarse-to-fine levels (1: full resolution only)");
    v("pose_iterations", pose_iterations, "Ceres iterations of each rigid-pose block solve");
    v("jaw_iterations", jaw_iterations, "Ceres iterations of each jaw-controls block solve");
    v("expression_iterations", expression_iterations,
      "Ceres iterations of each solve of the remaining controls");
    v("solve_rotation", solve_rotation,
      "solve the rotation of the rigid pose (false: held at its start, the position solved)");
    v("solve_roll", solve_roll, "solve the roll angle of the rigid pose");
    v("solve_scale", solve_scale, "solve the uniform scale of the rigid pose");
    v("weight_prior", weight_prior, "L2 prior lambda |w|^2 towards the neutral (0: off)");
    v("sparsity_prior", sparsity_prior,
      "L1 prior mu sum w on the weights: keeps off a weight the pixels push up only a little, "
      "lowers the others by a constant, not in proportion to their value (0: off)");
    v("landmark_weight", landmark_weight,
      "weight of a 2D landmark term added to the segmentation cost over the 51 points off the "
      "jaw contour, per squared landmark error in units of each point's noise (the noise "
      "person fit measured for the rig, else 1 pixel; 0: off; track: the detected landmarks "
      "of footage, with frames)");
    v("hard_residual", hard_residual,
      "residual of the hard render with the soft render's Jacobian (for aliased targets)");
    v("function_tolerance", function_tolerance, "relative cost decrease that stops a block");
    v("convergence_tolerance", convergence_tolerance,
      "a frame converged when its last epoch lowered the cost by less than this fraction");
    v("edge_width_px", soft.edge_width_px,
      "half-width of the soft band around region borders and silhouettes (pixels)");
  }
  bool Check(std::string* why) const;
};

// One frame's target in the rig's image frame.
struct TrackTarget {
  render::Camera camera;            // intrinsics and size of the image
  ImageF image;                     // width x height x 3 RGB in [0, 1] (segmentation objective)
  Eigen::Matrix<float, Eigen::Dynamic, 2> landmarks;  // 68 x 2 pixels (landmarks objective
                                                      // and initialisation); may be empty
  std::vector<uint8_t> landmark_visible;              // 68 flags; empty: all visible
};

// Per-frame summary, like Ceres's Solver::Summary.
enum class Termination : int { kConvergence = 0, kNoConvergence = 1, kFailure = 2 };
struct FrameSummary {
  Termination termination = Termination::kNoConvergence;
  double initial_cost = 0.;  // 0.5 |r|^2 of the objective (no prior) at the start, full size
  double final_cost = 0.;    // the same at the solution
  int iterations = 0;        // Ceres iterations over all blocks, epochs and levels
  int evaluations = 0;       // renders (or landmark evaluations)
  double seconds = 0.;       // wall time of the solve
  std::string BriefReport() const;
};
const char* TerminationName(Termination t);

struct TrackResult {
  rig::RigidPose pose;
  Eigen::VectorXf weights;
  FrameSummary summary;
};

// The solver of one rig (precompute / solve split). Solve is const and thread-safe.
class Tracker {
 public:
  // region_colors: the texture the model is rendered with (RigRegionColors for T_seg).
  Tracker(const rig::Rig& rig, std::vector<Eigen::Vector3f> region_colors,
          const TrackerOptions& options);
  ~Tracker();

  // Solves one frame from the initial pose and weights.
  TrackResult Solve(const TrackTarget& target, const rig::RigidPose& initial_pose,
                    const Eigen::VectorXf& initial_weights) const;

  // Fits only the rigid pose to the target's landmarks (initialisation "from landmarks").
  rig::RigidPose PoseFromLandmarks(const TrackTarget& target, const rig::RigidPose& initial_pose,
                                   const Eigen::VectorXf& weights) const;

  // 0.5 |F_seg - T|^2 at the given parameters (the segmentation cost, no prior).
  double SegmentationCost(const TrackTarget& target, const rig::RigidPose& pose,
                          const Eigen::VectorXf& weights) const;

  // The objective the solve minimizes (no prior), |r|^2, at `params` (the solver layout of
  // rig/evaluate.h), with its Gauss-Newton normal equations J^T J (*normal) and J^T r
  // (*gradient) over the parameter `columns` (any pose or shape columns). For fits built on
  // the tracker, such as the person's identity over many frames.
  double NormalEquations(const TrackTarget& target, const Eigen::VectorXf& params,
                         const std::vector<int>& columns, Eigen::MatrixXd* normal,
                         Eigen::VectorXd* gradient) const;

  // Holds these shapes at their initial weights in every solve (shapes the caller solves
  // otherwise, such as identity modes appended to a rig). Call before solving.
  void HoldShapesFixed(const std::vector<int>& shapes);

  const rig::RigEvaluator& evaluator() const { return evaluator_; }
  const SoftSegmentationRenderer& renderer() const { return renderer_; }
  const TrackerOptions& options() const { return options_; }

  // The per-solve workspace (tracker.cpp).
  struct Impl;

 private:
  const rig::Rig& rig_;
  TrackerOptions options_;
  rig::RigEvaluator evaluator_;
  SoftSegmentationRenderer renderer_;
  std::vector<int> jaw_shapes_, other_shapes_;
};

// The target at half resolution: 2 x 2 box average, camera intrinsics halved.
TrackTarget Downsample(const TrackTarget& target);

// RGB8 -> float RGB in [0, 1].
ImageF ToFloatImage(const Image8& image);

// Maps each pixel of a segmentation image to the nearest of `from` colours and writes the
// corresponding `to` colour (e.g. a skin albedo per region for the realistic-texture
// baseline), nearest in RGB; pixels nearer to `background` than to any region stay as the
// background.
ImageF RecolorSegmentation(const ImageF& image, const std::vector<Eigen::Vector3f>& from,
                           const std::vector<Eigen::Vector3f>& to,
                           const Eigen::Vector3f& background);

// A realistic, skin-like albedo per region of the demo head (by region name: lips reddish,
// eye whites, iris dark, brows brown, all other skin regions one skin colour), used as
// T_real in the realistic-texture baseline (paper Figs. 20-21): most segmentation borders
// vanish because neighbouring skin regions share one colour.
std::vector<Eigen::Vector3f> SkinRegionColors(const rig::Rig& rig);

}  // namespace facecap::track

#endif  // FACECAP_TRACK_TRACKER_H_
