// facecap person fit: the person's own rig from their footage (paper 000 Sec. 5.1). First the
// identity modes of the generic rig are fitted, jointly with every chosen frame's pose and
// expression, to the 68 landmarks ingest detected (the landmark phase: a baseline, and the
// person's own landmark vertices); then, from the generic head or from that fit
// (refine_from), refined by inverse rendering of the deepfake's segmentation translations
// (track/person_fit.h). The rig's shapes are moved onto the person by deformation transfer
// (assets/person_rig.h). Frames spread across ranks, the same result for any rank count,
// resumable round by round. Writes the person's rig (/rig) and the fit (stages/person_file.h).
#ifndef FACECAP_STAGES_PERSON_STAGE_H_
#define FACECAP_STAGES_PERSON_STAGE_H_

#include <string>
#include <vector>

#include "io/config.h"
#include "io/frames_file.h"
#include "stages/stage.h"
#include "track/person_fit.h"

namespace facecap::stages {

// [person.fit]
struct PersonFitStageOptions {
  std::string rig = "rig.h5";            // the generic rig with identity modes
  std::string frames = "frames.h5";      // ingest output: landmarks, crops, camera
  std::string translations = "";        // deepfake infer output of those frames ("": none)
  std::string translations_dataset = io::frames::kTranslated;
  std::string out = "person.h5";         // the person's rig
  int count = 48;                        // frames chosen for pose variety
  int size = 64;                         // target size without translations (pixels)
  int threads = 0;                       // OpenMP threads per rank (0: cores / node ranks)
  // Where the refinement starts: "generic" (the generic head; the landmark fit is kept as a
  // baseline only) or "landmarks" (the landmark fit).
  std::string refine_from = "generic";
  // The person's own landmark vertices: each of the 68 moves to the vertex within
  // calibrate_radius_cm whose projections best match the frames' landmarks
  // (render::CalibrateLandmarks) at the frames' poses after the last round (the refinement's,
  // or the landmark phase's without translations); 0: the generic rig's.
  float calibrate_radius_cm = 1.5f;
  // Regions of the rig whose pixels the refinement's identity step leaves out (a pixel counts
  // unless its translation or the render shows one of them; the per-frame pose and expression
  // solves see every region): the small regions that translations draw least reliably.
  // Empty: every region.
  std::vector<std::string> refine_ignore_regions = {
      "left_upper_eyelid", "left_lower_eyelid", "right_upper_eyelid", "right_lower_eyelid",
      "sclera", "iris", "upper_lip", "lower_lip", "mouth_interior"};
  track::PersonFitOptions fit;

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "generic rig (HDF5) whose identity modes span the people (rig demo)");
    v("frames", frames, "ingest output (frames.h5): detected landmarks, crop transforms, camera");
    v("translations", translations,
      "deepfake infer output of the same frames: the segmentation translations the "
      "refinement renders against (empty: landmarks only, no refinement)");
    v("translations_dataset", translations_dataset, "image dataset of the translations");
    v("out", out, "the person's rig (HDF5, /rig; every --rig option takes it)");
    v("count", count, "frames chosen for pose variety (farthest-point sampling over yaw, pitch)");
    v("size", size, "size of the crop camera without translations (pixels)");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    v("landmark_rounds", fit.landmark_rounds, "rounds of the fit to the landmarks");
    v("calibrate_radius_cm", calibrate_radius_cm,
      "after the last round, each landmark vertex moves to the vertex within this radius (cm) "
      "that best matches the frames' landmarks at the frames' solved poses: the person's own "
      "landmark positions, and their measured noise (0: the generic rig's, no noise)");
    v("refine_from", refine_from,
      "where the refinement starts: generic (the generic head; the landmark fit is kept as a "
      "baseline, /person/landmarks_only_neutral) or landmarks (the landmark fit)");
    v("refine_rounds", fit.refine_rounds,
      "rounds of the refinement by inverse rendering of the translations (with translations)");
    v("refine_ignore_regions", refine_ignore_regions,
      "regions of the rig whose pixels the refinement's identity step leaves out (where the "
      "translation or the render shows one of them; the per-frame solves see every region): "
      "the eyes' and the mouth's small regions, which translations draw least reliably "
      "(empty: every region)");
    v("identity_prior", fit.identity_prior,
      "weight of the prior alpha ~ N(0, 1) on the identity, in squared landmark pixels of a "
      "128-pixel crop");
    v("robust_px", fit.robust_px,
      "Cauchy scale of a frame's RMS landmark residual (pixels of a 128-pixel crop): frames "
      "whose landmarks fit badly count less");
    v("robust_cost", fit.robust_cost,
      "Cauchy scale of a frame's segmentation cost in the refinement, in medians over the "
      "frames: frames whose translation fits badly count less");
    v("refine_weight_prior", fit.refine_tracker.weight_prior,
      "expression prior of the refinement's per-frame solves");
  }
  bool Check(std::string* why) const {
    if (count < 2 || count > 100000) { *why = "count must be in [2, 100000]"; return false; }
    if (size < 16 || size > 1024) { *why = "size must be in [16, 1024]"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (out.empty()) { *why = "out must name a file"; return false; }
    if (!(calibrate_radius_cm >= 0.f && calibrate_radius_cm <= 5.f)) {
      *why = "calibrate_radius_cm must be in [0, 5]";
      return false;
    }
    if (refine_from != "generic" && refine_from != "landmarks") {
      *why = "refine_from must be generic or landmarks, not " + refine_from;
      return false;
    }
    return fit.Check(why);
  }
};

// Runs person fit on every rank of ctx.comm (collective). The summary counts the fit's rounds
// (landmark rounds, then refinement rounds) and those this run solved (0 when up to date).
StageSummary RunPersonFit(const PersonFitStageOptions& options, const StageContext& ctx,
                          const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_PERSON_STAGE_H_
