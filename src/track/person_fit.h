// The person's neutral geometry from many frames (paper 000 Sec. 5.1: an estimate of the
// geometry, refined by inverse rendering with the segmented texture of Sec. 4.1).
//
// Unknowns: the identity coefficients alpha of the rig's identity modes (shared by every
// frame), and per frame the rigid pose and the expression weights. The person's neutral is
//
//   N(alpha) = N + sum_k alpha_k mode_k
//
// and every frame is the rig equation on it (rig/rig.h). The head's overall size is not an
// unknown: through a pinhole camera a head s times larger at s times the distance projects
// to the same image, so footage cannot tell it, and the person keeps the generic size. The fit alternates, for a fixed
// number of rounds:
//   1. per frame, the tracker's solve of pose and expression with the identity fixed
//      (landmarks objective in the landmark phase, the segmentation objective with the
//      landmark term in the refinement phase);
//   2. per frame, the Gauss-Newton normal equations of its objective over its own pose and
//      free expression weights (local) and the identity (global), with the local block
//      eliminated (Schur complement), so that the identity step accounts for the poses and
//      expressions moving with it; each frame weighted by a Cauchy weight of its RMS
//      landmark residual, so that frames where the landmarks failed count little;
//   3. the identity step: the frames' reduced systems summed in frame order, a Gaussian prior
//      alpha ~ N(0, 1) scaled by identity_prior, Levenberg damping.
// Step 1 and 2 are per frame and depend only on the frame and the identity, so a caller may
// spread frames over ranks and gather the contributions; the sum is taken in frame order, so
// the result does not depend on how frames were spread.
#ifndef FACECAP_TRACK_PERSON_FIT_H_
#define FACECAP_TRACK_PERSON_FIT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/pose.h"
#include "rig/rig.h"
#include "track/tracker.h"

namespace facecap::track {

struct PersonFitOptions {
  // Rounds of the landmark phase and of the refinement by inverse rendering.
  int landmark_rounds = 10;
  int refine_rounds = 8;
  // Weight of the Gaussian prior on the identity, in squared landmark pixels of a 128-pixel
  // target (about the variance of the landmark noise there): the MAP estimate of alpha under
  // landmark noise of that variance.
  double identity_prior = 20.0;
  // Robust frame weights 1 / (1 + (e / scale)^2), so that frames whose landmarks or whose
  // translation failed count little: in the landmark phase e is the frame's RMS landmark
  // residual and the scale robust_px (pixels of a 128-pixel target); in the refinement e is
  // the frame's segmentation cost and the scale robust_cost times the median over frames.
  double robust_px = 4.0;
  double robust_cost = 2.0;
  // Levenberg damping of the identity step, relative to the diagonal.
  double damping = 1e-3;
  // Per-frame solves of the landmark phase and of the refinement.
  TrackerOptions landmark_tracker;
  // The refinement's: its region_weights weigh the pixels of the identity step's normal
  // equations only; the per-frame pose and expression solves see every region.
  TrackerOptions refine_tracker;

  PersonFitOptions();
  bool Check(std::string* why) const;
};

// One frame of the fit: its target (camera, landmarks, and a segmentation image for the
// refinement) and its current pose and expression.
struct PersonFrame {
  TrackTarget target;
  rig::RigidPose pose;
  Eigen::VectorXf weights;   // the rig's shapes
};

// What one frame gives the identity step.
struct PersonFrameContribution {
  Eigen::MatrixXd normal;     // reduced J^T J over the identity (one column per mode)
  Eigen::VectorXd gradient;   // reduced J^T r
  double cost = 0.;           // the frame's objective |r|^2 (no prior)
  double landmark_rms = 0.;   // RMS landmark residual, pixels of a 128-pixel target
  double weight = 1.;         // its robust weight
};

class PersonFitter {
 public:
  // `generic`: the rig whose identity modes span the people (its neutral is alpha = 0).
  PersonFitter(const rig::Rig& generic, const PersonFitOptions& options);
  ~PersonFitter();

  int NumIdentityParams() const;  // the identity modes
  // The neutral N(alpha), #V x 3.
  rig::Vertices Neutral(const Eigen::VectorXd& identity) const;
  // The generic rig with its neutral replaced by N(identity) (same shapes: for the per-frame
  // solves; the person's own shapes come from assets::PersonRig).
  rig::Rig WithNeutral(const Eigen::VectorXd& identity) const;

  // Steps 1 and 2 for one frame: solves its pose and expression with the identity fixed
  // (refine: the segmentation objective), updating *frame, and returns its contribution.
  PersonFrameContribution SolveFrame(const Eigen::VectorXd& identity, bool refine,
                                     PersonFrame* frame) const;
  // Step 3: the new identity from the contributions of every frame, in frame order; sets
  // each frame's robust weight first.
  Eigen::VectorXd Step(const Eigen::VectorXd& identity,
                       std::vector<PersonFrameContribution>* frames, bool refine) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::track

#endif  // FACECAP_TRACK_PERSON_FIT_H_
