// facecap regress train / infer: the personalized regressor of paper 000 Sec. 9 (Fig. 23).
// train fits P, J, W and L (nn/regressor.h) on the codes e = E(D_S(E(I))) of the synthetic
// samples and of the real frames, in the paper's three phases, with the training controller;
// infer predicts each frame's pose and controls from its code and writes a track file.
//   regress train: P (pose), J (jaw controls) and W (the other controls) on the samples' codes
//     against their truth; optionally phase 2, L (landmarks) on the samples' landmarks, and
//     phase 3, P, J, W again with L frozen and the footage crops' detected landmarks as weak
//     supervision; data-parallel over ranks (gradient allreduce), checkpoints, resume;
//   regress infer: each frame's pose and controls from its code, the head placed on the
//     detected landmarks; a track file in the source camera that exports and eval track read;
//     frames spread across ranks, resumable.
#ifndef FACECAP_STAGES_REGRESS_STAGE_H_
#define FACECAP_STAGES_REGRESS_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "io/config.h"
#include "nn/regressor.h"
#include "stages/stage.h"

namespace facecap::stages {

// [regress.train]
struct RegressTrainOptions {
  std::string samples = "samples.h5";             // the synthetic samples
  std::string sample_codes = "samples_codes.h5";  // deepfake infer of the samples
  std::string frame_codes = "";                   // deepfake infer of the footage crops
  std::string frames = "";                        // ingest output of the footage
  std::string track = "";                         // the tracker's solutions of the frames
  std::vector<std::string> more_frame_codes;       // more footage of the person: its codes
  std::vector<std::string> more_frames;            // and its ingest outputs (their landmarks)
  std::vector<std::string> more_tracks;            // none, or the tracker's solutions of each
  std::string rig = "rig.h5";                     // the samples' rig (its jaw controls)
  std::string out = "regressor.h5";               // trained model
  int pose_steps = 3000;        // phase 1: P, J, W on the samples
  int landmark_steps = 0;       // phase 2: L on the samples
  int finetune_steps = 0;       // phase 3: P, J, W on samples and frames, L frozen
  int batch = 64;               // examples per optimizer step, all ranks together
  int checkpoint_every = 1000;  // steps between checkpoints
  double progress_seconds = 10; // interval of the progress lines
  int threads = 0;              // tensor threads per rank (0: the cores divided among ranks)
  int seed = 1;                 // batch order seed
  std::string landmark_source = "projected";  // L's targets
  nn::RegressorOptions net;

  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"samples", "Data and schedule"}, {"model.hidden", "Networks and optimizer"}};
  }
  template <class V>
  void Visit(V&& v) {
    v("samples", samples,
      "samples file (synth samples, contract or expand): each sample's pose, controls and 68 "
      "projected landmarks are the synthetic truth");
    v("sample_codes", sample_codes,
      "deepfake infer's output on the samples (--dataset /samples/segmentation): their codes "
      "E(D_S(E(I_S))) in /frames/latent_of_translation");
    v("frame_codes", frame_codes,
      "deepfake infer's output on the footage crops, from the same model: their codes "
      "E(D_S(E(I_R))) in /frames/latent_of_translation: phase 3's real examples, and the fit "
      "report's (empty: none)");
    v("frames", frames,
      "ingest output of the footage: the landmarks it detected on each crop weakly supervise "
      "phase 3 (frames without a face are left out); with frame_codes");
    v("track", track,
      "the tracker's track of the same footage crops (track --frames): each solved frame's pose "
      "and controls join the synthetic truth in phases 1 and 3, as the paper's offline solver "
      "makes the regressor's ground truth (empty: the samples alone)");
    v("more_frame_codes", more_frame_codes,
      "more footage of the same person, the clips the regressor is to track: deepfake infer's "
      "outputs on their crops (same model), one per file of more_frames; their frames join phase "
      "3's real examples through their landmarks alone (and phase 1 with more_tracks)");
    v("more_frames", more_frames, "ingest outputs of the footage of more_frame_codes, in the same order");
    v("more_tracks", more_tracks,
      "none, or the tracker's tracks of every clip of more_frames (same order, track --frames): their "
      "solved frames join the truth of phases 1 and 3 as track's do, e.g. a clip filmed to cover the "
      "head turns the first clip lacks");
    v("rig", rig, "the samples' rig: its jaw-skinned controls are J's, the others W's");
    v("out", out, "trained model (HDF5): the networks' state, the code normalization, the "
                  "control split");
    v("pose_steps", pose_steps, "phase 1 steps: P, J, W on the samples (losses L_P, L_J, L_W)");
    v("landmark_steps", landmark_steps,
      "phase 2 steps: L alone on the samples, predicting their landmarks from P, J, W's "
      "outputs and from the truth (L_L)");
    v("finetune_steps", finetune_steps,
      "phase 3 steps: P, J, W on the samples and the real frames with L frozen (L_P, L_J, "
      "L_W on the samples, L_L* on both)");
    v("batch", batch, "examples per optimizer step, all ranks together");
    v("checkpoint_every", checkpoint_every, "optimizer steps between checkpoints");
    v("progress_seconds", progress_seconds, "seconds between progress lines");
    v("threads", threads, "tensor threads per rank (0: the cores divided among the node's ranks)");
    v("seed", seed, "batch order seed");
    v("landmark_source", landmark_source,
      "L's targets: projected (the samples' projected landmarks and the landmarks ingest "
      "detected on the real crops) or translations (dlib's landmarks on every example's "
      "translation D_S(E(I)) in the codes files, samples and real frames alike, as the paper)");
    io::VisitGroup("model", net, v);
  }
  bool Check(std::string* why) const {
    if (samples.empty() || sample_codes.empty() || rig.empty() || out.empty()) {
      *why = "samples, sample_codes, rig and out must name files";
      return false;
    }
    if (finetune_steps > 0 && (frame_codes.empty() || frames.empty())) {
      *why = "phase 3 (finetune_steps > 0) needs frame_codes and frames";
      return false;
    }
    if (!track.empty() && frames.empty()) {
      *why = "track needs frame_codes and frames (the codes and crops of the frames it solved)";
      return false;
    }
    if (more_frame_codes.size() != more_frames.size()) {
      *why = "more_frame_codes and more_frames name the same clips: " + std::to_string(more_frame_codes.size()) +
             " and " + std::to_string(more_frames.size()) + " files";
      return false;
    }
    if (!more_frames.empty() && frames.empty()) {
      *why = "more_frames adds to frames: give frame_codes and frames first";
      return false;
    }
    if (!more_tracks.empty() && (more_tracks.size() != more_frames.size() || track.empty())) {
      *why = "more_tracks gives a track for every clip of more_frames (" + std::to_string(more_frames.size()) +
             " files, it has " + std::to_string(more_tracks.size()) + ") and needs track for the first clip";
      return false;
    }
    if (frame_codes.empty() != frames.empty()) {
      *why = "frame_codes and frames go together (the real frames' codes and their landmarks)";
      return false;
    }
    if (pose_steps < 0 || landmark_steps < 0 || finetune_steps < 0) { *why = "steps must be >= 0"; return false; }
    if (pose_steps + landmark_steps + finetune_steps < 1) { *why = "at least one step must be trained"; return false; }
    if (batch < 1) { *why = "batch must be >= 1"; return false; }
    if (checkpoint_every < 1) { *why = "checkpoint_every must be >= 1"; return false; }
    if (!(progress_seconds > 0)) { *why = "progress_seconds must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (landmark_source != "translations" && landmark_source != "projected") {
      *why = "landmark_source must be translations or projected, not " + landmark_source;
      return false;
    }
    if (landmark_source == "translations" && (landmark_steps > 0 || finetune_steps > 0) && frames.empty()) {
      *why = "landmark_source translations places dlib's face box as ingest does: it needs frames";
      return false;
    }
    return net.Check(why);
  }
};

// [regress.infer]
struct RegressInferOptions {
  std::string model = "regressor.h5";   // regress train output
  std::string codes = "translated.h5";  // deepfake infer of the footage crops
  std::string frames = "frames.h5";     // ingest output of the footage
  std::string rig = "rig.h5";           // the person's rig
  std::string out = "track_regressed.h5";
  int batch = 64;                       // frames per rank per round
  int threads = 0;                      // threads per rank (0: the cores divided among ranks)

  template <class V>
  void Visit(V&& v) {
    v("model", model, "regressor (regress train)");
    v("codes", codes,
      "deepfake infer's output on the footage crops, from the deepfake the regressor was trained "
      "with: each frame's code E(D_S(E(I))) in /frames/latent_of_translation");
    v("frames", frames, "ingest output of the footage: each crop's camera, its detected landmarks place the head");
    v("rig", rig, "the person's rig (person fit, or the samples' rig): its controls are matched by name, and its "
                  "landmarks, posed with the predicted angles and controls, fix the head's position");
    v("out", out, "track file (HDF5), in the source camera like track's: every export and evaluation reads it");
    v("batch", batch, "frames per rank per round");
    v("threads", threads, "threads per rank (0: the cores divided among the node's ranks)");
  }
  bool Check(std::string* why) const {
    if (model.empty() || codes.empty() || frames.empty() || rig.empty() || out.empty()) {
      *why = "model, codes, frames, rig and out must name files";
      return false;
    }
    if (batch < 1) { *why = "batch must be >= 1"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    return true;
  }
};

// Trains the regressor on every rank of ctx.comm (collective): the summary counts the
// training's optimizer steps and those this run made (0 when the model was up to date).
StageSummary RunRegressTrain(const RegressTrainOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

// Runs regress infer on every rank of ctx.comm (collective): the summary counts the frames of
// the track and those this run computed (0 when the track was up to date).
StageSummary RunRegressInfer(const RegressInferOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_REGRESS_STAGE_H_
