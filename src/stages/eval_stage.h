// facecap eval track | landmarks | person | appearance | rerender: metrics of a stage's
// output, each printed as one JSON object (or a readable table) by rank 0 and optionally
// written to a file.
//   eval track: accuracy of a track.h5 against the truth of a synthetic file (samples or
//     clip): pose error, weight error per shape, landmark NME and vertex error over the
//     inter-ocular distance, and the solve time per frame.
//   eval landmarks: for real footage, which has no true parameters, the reprojection error of
//     the tracked rig's 68 landmarks against the landmarks dlib detected in the crops, on all
//     frames with a face and on the frames held out of deepfake training.
//   eval person: the person fit's neutral against the true person of a synthetic clip (vertex
//     RMS after a similarity alignment), beside the generic head's and the landmarks-only fit's.
//   eval appearance: a captured texture against a synthetic person's true albedo: face-region
//     PSNR after one gain per colour channel, coverage, and the eye and mouth corners'
//     alignment.
//   eval rerender: tracked footage re-rendered with a captured texture against the footage
//     itself (no truth needed): PSNR over the face pixels of held-out frames.
#ifndef FACECAP_STAGES_EVAL_STAGE_H_
#define FACECAP_STAGES_EVAL_STAGE_H_

#include <string>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [eval.track]
struct EvalTrackOptions {
  std::string truth = "clip.h5";   // file with the true pose and weights of every frame
  std::string track = "track.h5";  // output of facecap track
  // The rig that was tracked; empty: the truth's rig (a track made with the true rig).
  std::string rig = "";
  // Rig of the truth (HDF5 /rig); empty: the truth file's /rig.
  std::string truth_rig = "";
  bool json = true;                // print the metrics as one JSON object (else a table)
  std::string out = "";            // also write the JSON to this file (empty: none)
  bool per_frame = false;          // add each scored frame's errors to the JSON object

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "file with the true pose and weights per frame (synth samples or clip)");
    v("track", track, "track.h5 written by facecap track");
    v("rig", rig, "the rig that was tracked (empty: the truth's own rig)");
    v("truth_rig", truth_rig,
      "rig file of the truth (empty: the truth file's /rig, else the rig that was tracked)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
    v("per_frame", per_frame,
      "add \"per_frame\" to the JSON object: each scored frame's index, pose error (deg), "
      "weight MAE and landmark NME, to find the frames that fail");
  }
  bool Check(std::string* why) const {
    if (truth.empty() || track.empty()) {
      *why = "truth and track are required";
      return false;
    }
    return true;
  }
};

// Runs eval track on rank 0 (the other ranks return at once); the summary counts the JSON
// file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalTrack(const EvalTrackOptions& options, const StageContext& ctx,
                          const io::Config& resolved);

// [eval.landmarks]
struct EvalLandmarksOptions {
  std::string frames = "frames.h5";  // ingest output: detected landmarks, crops, camera
  std::string track = "track.h5";    // tracking of the frames' translations
  std::string rig = "rig.h5";        // the rig that was tracked
  int holdout_every = 0;             // frames i % n == n - 1 were held out of training
  bool json = true;                  // print one JSON object (else a table)
  std::string out = "";              // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("frames", frames, "ingest output (frames.h5): dlib's landmarks in source pixels");
    v("track", track, "track.h5 of the frames' crops (track --frames: in the source camera)");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("holdout_every", holdout_every,
      "frames i % n == n - 1 were held out of deepfake training: reported apart (0: none)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (holdout_every < 0 || holdout_every == 1) { *why = "holdout_every must be 0 or >= 2"; return false; }
    return true;
  }
};

// Runs eval landmarks on rank 0 (the other ranks return at once); the summary counts the
// JSON file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalLandmarks(const EvalLandmarksOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

// [eval.person]
struct EvalPersonOptions {
  std::string truth = "clip.h5";     // a synthetic clip: its /rig is the true person
  std::string person = "person.h5";  // person fit output
  bool json = true;                  // print one JSON object (else a table)
  std::string out = "";              // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "file whose /rig is the true person (synth clip)");
    v("person", person, "person fit output (HDF5): the estimated rig, the landmarks-only "
                        "neutral and the generic neutral it started from");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (truth.empty() || person.empty()) { *why = "truth and person are required"; return false; }
    return true;
  }
};

// Runs eval person on rank 0 (the other ranks return at once); the summary counts the JSON
// file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalPerson(const EvalPersonOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

// [eval.appearance]
struct EvalAppearanceOptions {
  std::string truth = "clip.h5";      // a synthetic clip: its /identity/albedo and /rig
  std::string texture = "texture.h5"; // appearance gather output
  std::string naive = "";             // the naive capture of the same views ("": none)
  bool json = true;                   // print one JSON object (else a table)
  std::string out = "";               // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "synthetic clip whose /identity/albedo is the true albedo and /rig the person");
    v("texture", texture, "captured texture (appearance gather output)");
    v("naive", naive, "the naive capture (appearance gather of appearance frames: the footage's "
                      "own pixels splatted through the tracked rig), scored beside it (\"\": none)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (truth.empty() || texture.empty()) { *why = "truth and texture are required"; return false; }
    return true;
  }
};

// Runs eval appearance on rank 0 (the other ranks return at once); the summary counts the
// JSON file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalAppearance(const EvalAppearanceOptions& options, const StageContext& ctx,
                               const io::Config& resolved);

// [eval.rerender]
struct EvalRerenderOptions {
  std::string views = "frame_views.h5";  // appearance frames output: the tracked footage as views
  std::string texture = "person_textured.h5";  // the captured texture (appearance gather)
  std::string naive = "";                // the naive capture, scored beside it ("": none)
  int holdout_every = 5;                 // frames i % n == n - 1 are scored (0: every frame)
  int edge_margin_px = 2;                // pixels this close to the silhouette are not scored
  bool json = true;                      // print one JSON object (else a table)
  std::string out = "";                  // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("views", views, "appearance frames output: each frame's crop with the tracked rig's U(I)");
    v("texture", texture, "captured texture (appearance gather output)");
    v("naive", naive, "the naive capture (gathered from the same views' frames without the "
                      "held-out ones), scored beside it (\"\": none)");
    v("holdout_every", holdout_every,
      "score frames i % n == n - 1, those deepfake train's b_holdout_every kept out of training "
      "(0: every frame)");
    v("edge_margin_px", edge_margin_px, "pixels within this distance of the head's silhouette "
                                        "are not scored");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (views.empty() || texture.empty()) { *why = "views and texture are required"; return false; }
    if (holdout_every < 0 || holdout_every == 1) {
      *why = "holdout_every must be 0 (every frame) or at least 2";
      return false;
    }
    if (edge_margin_px < 0 || edge_margin_px > 32) {
      *why = "edge_margin_px must be in [0, 32]";
      return false;
    }
    return true;
  }
};

// Runs eval rerender on rank 0 (the other ranks return at once); the summary counts the
// JSON file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalRerender(const EvalRerenderOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_EVAL_STAGE_H_
