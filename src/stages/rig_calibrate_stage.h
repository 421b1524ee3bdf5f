// facecap rig calibrate: places a rig's 68 landmark vertices where dlib's landmark detector
// finds the iBUG points on renders of the rig (render/landmark_calibration.h). People of the
// rig's identity modes (seeds that no other stage uses) are rendered as wild clips over a
// range of poses and expressions, dlib detects their landmarks as ingest does, and each
// landmark moves to the vertex whose projections match the detections best, so that fits to
// dlib's landmarks on footage measure the face, not the difference of conventions. Views are
// rendered and detected across ranks; the choice is made on rank 0 from the views in order,
// so the result is the same for any number of ranks.
#ifndef FACECAP_STAGES_RIG_CALIBRATE_STAGE_H_
#define FACECAP_STAGES_RIG_CALIBRATE_STAGE_H_

#include <string>

#include "face/face_analyzer.h"
#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [rig.calibrate]
struct RigCalibrateOptions {
  std::string rig = "rig.h5";          // the rig whose landmarks are placed
  std::string out = "rig_calibrated.h5";
  int people = 8;                      // identities rendered
  int first_identity_seed = 9001;      // their seeds: first_identity_seed, +1, ...
  int frames = 24;                     // frames per person
  int size = 192;                      // render size (pixels)
  float fov_deg = 40.f;                // vertical field of view of the renders' camera
  float fill = 0.5f;                   // fraction of the frame height the face spans
  float max_yaw_deg = 25.f;            // head yaw range of the renders
  float radius_cm = 2.5f;              // search radius around each landmark vertex
  std::string landmark_model = face::kDefaultLandmarkModel;
  int threads = 0;

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5) with identity modes and 68 landmarks");
    v("out", out, "the rig with its landmark vertices placed (HDF5)");
    v("people", people, "people (identities of the rig's modes) rendered");
    v("first_identity_seed", first_identity_seed,
      "identity seed of the first person; the others follow (keep them apart from the seeds "
      "of clips that are evaluated)");
    v("frames", frames, "frames rendered per person");
    v("size", size, "render size in pixels");
    v("fov_deg", fov_deg, "vertical field of view of the renders' camera (degrees): the one "
                          "ingest assumes for footage, so that perspective matches");
    v("fill", fill, "fraction of the frame height the face spans when frontal");
    v("max_yaw_deg", max_yaw_deg, "largest head yaw of the renders (degrees)");
    v("radius_cm", radius_cm, "each landmark moves to a vertex at most this far (cm)");
    v("landmark_model", landmark_model, "dlib 68-point shape predictor (Debian libdlib-data)");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
  }
  bool Check(std::string* why) const {
    if (people < 1 || people > 1000) { *why = "people must be in [1, 1000]"; return false; }
    if (frames < 1 || frames > 10000) { *why = "frames must be in [1, 10000]"; return false; }
    if (size < 96 || size > 1024) { *why = "size must be in [96, 1024]"; return false; }
    if (!(max_yaw_deg >= 0.f && max_yaw_deg <= 60.f)) { *why = "max_yaw_deg must be in [0, 60]"; return false; }
    if (!(radius_cm > 0.f && radius_cm <= 10.f)) { *why = "radius_cm must be in (0, 10]"; return false; }
    if (!(fov_deg > 5.f && fov_deg < 120.f)) { *why = "fov_deg must be in (5, 120)"; return false; }
    if (!(fill > 0.1f && fill <= 1.f)) { *why = "fill must be in (0.1, 1]"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (out.empty()) { *why = "out must name a file"; return false; }
    return true;
  }
};

// rig calibrate, collective: renders and detects the views across ranks, then rank 0 writes
// the calibrated rig to options.out. The summary counts views (people x frames, every one
// rendered by every run), the same on every rank.
StageSummary RunRigCalibrate(const RigCalibrateOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RIG_CALIBRATE_STAGE_H_
