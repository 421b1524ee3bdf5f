// facecap track and lipsync track: inverse-rendering tracking (paper 000 Sec. 8) of every
// frame of a file of segmentation targets (a rig's samples, or the translations of an
// ingest output's crops), frames handed out by the dynamic work queue, resumable, identical
// for any number of ranks. Writes a track file (stages/track_file.h).
#ifndef FACECAP_STAGES_TRACK_STAGE_H_
#define FACECAP_STAGES_TRACK_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "io/config.h"
#include "io/frames_file.h"
#include "lipsync/visemes.h"
#include "stages/lip_track_filter.h"
#include "stages/stage.h"
#include "track/tracker.h"

namespace facecap::stages {

// The solver's settings as the track stage defaults them: the landmark term on, each point
// weighed by its inverse squared measured noise.
inline track::TrackerOptions TrackStageSolverDefaults() {
  track::TrackerOptions t;
  t.landmark_weight = 1.f;
  return t;
}

// [track]
struct TrackOptions {
  std::string rig = "rig.h5";             // rig file (HDF5, /rig)
  std::string targets = "targets.h5";     // file of segmentation targets
  std::string out = "track.h5";           // output file
  // Frame dataset of target images [N, H, W, 3] u8; when absent, /samples/segmentation.
  std::string targets_dataset = io::frames::kSegmentation;
  // Ingest output whose crops the targets translate (real footage, or a synthetic clip's
  // video): each frame is tracked in its crop's camera (the source camera assumed by ingest,
  // seen through the crop transform), the detected landmarks initialise each segment and
  // feed the landmark term, and the track is written in the source camera, with the source
  // frame indices, timecodes and frame rate. Empty: the targets file's own camera.
  std::string frames = "";
  // Initialisation: "neutral" (frontal neutral, frames independent), "landmarks" (the pose
  // fitted to the file's 2D landmarks, neutral expression) or "previous" (each frame starts
  // from the previous frame's solution; frames are solved in segments of segment_frames).
  std::string init = "neutral";
  int segment_frames = 16;                // frames per sequential segment (init = previous)
  // Texture of model and target: "segmentation" (T_seg) or "skin" (a realistic skin albedo
  // per region, targets recoloured region by region: the realistic-texture baseline).
  std::string texture = "segmentation";
  int count = 0;                          // frames to track from the first (0: all)
  // A frontal source (a lip-sync network's output, a frontal camera): the head's rotation is
  // held frontal to the source camera and only its position solved.
  bool frontal = false;
  // The only controls solved; the others stay at the neutral (empty: all).
  std::vector<std::string> solve_controls;
  int batch = 16;                         // work units per rank per round (a checkpoint each)
  int threads = 0;                        // OpenMP threads per rank (0: cores / node ranks)
  track::TrackerOptions tracker = TrackStageSolverDefaults();  // the solver

  // --help's sections, by the first key of each.
  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"rig", "Inputs and output"}, {"init", "Start and work"}, {"solver.objective", "Solver"}};
  }
  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5)");
    v("targets", targets, "file of segmentation targets (HDF5) with /camera/intrinsics");
    v("out", out, "output file (HDF5)");
    v("targets_dataset", targets_dataset,
      "frame dataset of target images [N,H,W,3] u8 (falls back to /samples/segmentation)");
    v("frames", frames,
      "ingest output (frames.h5) whose crops the targets translate: frames are tracked in "
      "their crop's camera, with the detected landmarks, and written in the source camera "
      "(empty: the targets' own camera)");
    v("init", init, "initialisation: neutral | landmarks | previous");
    v("segment_frames", segment_frames, "frames per sequential segment when init = previous");
    v("texture", texture, "texture of model and targets: segmentation | skin");
    v("count", count, "frames to track from the first (0: all)");
    v("frontal", frontal,
      "hold the head frontal to the source camera (rotation 0) and solve its position only");
    v("solve_controls", solve_controls,
      "the only controls solved, by name; every other control stays at the neutral (empty: all)");
    v("batch", batch, "work units per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    io::VisitGroup("solver", tracker, v);
  }
  bool Check(std::string* why) const {
    if (init != "neutral" && init != "landmarks" && init != "previous") {
      *why = "init must be neutral, landmarks or previous, not " + init;
      return false;
    }
    if (texture != "segmentation" && texture != "skin") {
      *why = "texture must be segmentation or skin, not " + texture;
      return false;
    }
    if (segment_frames < 1) { *why = "segment_frames must be >= 1"; return false; }
    if (count < 0) { *why = "count must be >= 0"; return false; }
    if (batch <= 0) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    return tracker.Check(why);
  }
};

// [lipsync.track]: the track stage set up for a frontal lip source.
struct LipsyncTrackOptions : TrackOptions {
  LipsyncTrackOptions() {
    frontal = true;
    solve_controls = lipsync::DefaultMouthControls();
    init = "previous";
    // Many mouth controls draw nearly the same segmentation of a frontal mouth: a strong
    // prior keeps the ones the image does not ask for at the neutral.
    tracker.weight_prior = 3000.f;
  }
  LipTrackFilterOptions filter;

  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    auto sections = TrackOptions::HelpSections();
    sections.emplace_back("rest_calibration", "After the solve: the mouth at rest, flicker, the phones");
    return sections;
  }
  template <class V>
  void Visit(V&& v) {
    TrackOptions::Visit(v);
    filter.Visit(v);
  }
  bool Check(std::string* why) const { return TrackOptions::Check(why) && filter.Check(why); }
};

// Runs the stage on every rank of ctx.comm (collective); `resolved` is the stage's table as
// the output stores it. The summary counts the frames of the track.
StageSummary RunTrack(const TrackOptions& options, const StageContext& ctx,
                      const io::Config& resolved);

// The track stage with a frontal source, then the mouth zeroed where the sound is silent and
// one-frame flicker removed (collective).
StageSummary RunLipsyncTrack(const LipsyncTrackOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TRACK_STAGE_H_
