// facecap synth clip: a wild clip of one person (identity_seed) with the truth of every frame
// (pose, weights, landmarks, the segmentation render of the same frame): a smooth random or
// scripted performance of expressions and head motion, skin-like texture, moving lights,
// backgrounds, blur, noise and JPEG, optionally speech; spread across ranks, resumable,
// identical for any rank count; `--video` adds an mp4. facecap synth sheet: wild frames beside
// their segmentation renders in one contact sheet.
#ifndef FACECAP_STAGES_SYNTH_CLIP_STAGE_H_
#define FACECAP_STAGES_SYNTH_CLIP_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "io/config.h"
#include "stages/stage.h"
#include "stages/stage_paths.h"
#include "synth/clip.h"

namespace facecap::stages {

// [synth.clip]
struct SynthClipOptions {
  std::string rig = "rig.h5";        // rig file (the mean person; identity_seed personalizes it)
  std::string out = "clip.h5";       // output file
  bool video = false;                // also write the frames to an mp4 beside `out`
  std::string background_folder;     // photos for the background ("": procedural backgrounds)
  int batch = 8;                     // frames per rank per round (a checkpoint per round)
  int threads = 0;                   // OpenMP threads per rank (0: cores / ranks on the node)
  std::string speech;                // text the person speaks ("": no speech)
  std::string voice = "en";          // espeak-ng voice of the speech
  float speech_start_seconds = 0.5f; // when the speech starts in the clip
  bool lips_view = false;            // the frontal lip-sync view of the performance
  synth::ClipOptions clip;           // the performance, appearance and camera

  // --help's sections, by the first key of each.
  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"rig", "Input and output"}, {"speech", "Speech"}, {"frames", "Clip"},
            {"identity_seed", "Person and seeds"}, {"expressions.expression_seconds", "Expressions"},
            {"head_motion.pose_seconds", "Head motion"}, {"lighting.light_period_seconds", "Lighting"},
            {"skin.texture_size", "Skin texture"}, {"camera.exposure_min", "Camera degradations"}};
  }
  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5); identity_seed makes a person of it");
    v("out", out, "output file (HDF5)");
    v("video", video, "also write the wild frames to an mp4 next to out (same name, .mp4)");
    v("background_folder", background_folder,
      "folder of photos (png, jpg, ...) for backgrounds, one picked by background_seed; "
      "empty: procedural backgrounds");
    v("batch", batch, "frames per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    v("speech", speech,
      "text the person speaks (espeak-ng): the mouth controls follow the phones by the "
      "person's own coarticulation, the phones and audio are kept as truth, and the mp4 "
      "carries the sound (also written as a WAV beside out); empty: no speech");
    v("voice", voice, "espeak-ng voice of the speech (en, en-us, en+f3, ...; espeak-ng --voices)");
    v("speech_start_seconds", speech_start_seconds, "time in the clip at which the speech starts");
    v("lips_view", lips_view,
      "film the frontal view a lip-sync source gives: the head frontal and still, every "
      "control outside the mouth at the neutral, the same speech");
    clip.Visit(v);
  }
  // The files written beside out: the mp4 with video, the WAV with speech.
  void DerivedOutputs(std::vector<NamedPath>* outputs) const;
  bool Check(std::string* why) const {
    if (batch <= 0) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (out.empty()) { *why = "out must name a file"; return false; }
    if (speech_start_seconds < 0.f) { *why = "speech_start_seconds must be >= 0"; return false; }
    if (lips_view && speech.empty()) { *why = "lips_view needs a speech"; return false; }
    return clip.Check(why);
  }
};

// [synth.sheet]
struct SynthSheetOptions {
  std::string clip = "clip.h5";        // clip file made by synth clip
  std::string out = "clip_sheet.png";  // contact sheet image
  int frames = 12;                     // frames shown, evenly spaced over the clip
  int pairs_per_row = 4;               // (wild, segmentation) pairs per row
  int scale = 2;                       // nearest-neighbour magnification of each tile
  bool landmarks = true;               // mark the visible true landmarks on the segmentation

  template <class V>
  void Visit(V&& v) {
    v("clip", clip, "clip file (HDF5) made by synth clip");
    v("out", out, "contact sheet image (png, jpg, ...)");
    v("frames", frames, "frames shown, evenly spaced over the clip");
    v("pairs_per_row", pairs_per_row, "(wild frame, segmentation) pairs per row");
    v("scale", scale, "nearest-neighbour magnification of each tile");
    v("landmarks", landmarks, "mark the visible true landmarks on the segmentation tiles");
  }
  bool Check(std::string* why) const {
    if (frames <= 0) { *why = "frames must be positive, got " + std::to_string(frames); return false; }
    if (pairs_per_row <= 0) { *why = "pairs_per_row must be positive"; return false; }
    if (scale < 1 || scale > 16) { *why = "scale must be in [1, 16]"; return false; }
    if (out.empty()) { *why = "out must name a file"; return false; }
    return true;
  }
};

// synth clip, collective: the frames rendered across ranks, written by rank 0 to options.out,
// then the WAV (with speech) and the mp4 (with video) beside it. The summary counts frames
// (computed: those this run rendered; 0 when the output was up to date).
StageSummary RunSynthClip(const SynthClipOptions& options, const StageContext& ctx,
                          const io::Config& resolved);

// synth sheet, rank 0 alone: the contact sheet to options.out. The summary counts files (1 on
// rank 0; 0 on the other ranks, which do nothing).
StageSummary RunSynthSheet(const SynthSheetOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SYNTH_CLIP_STAGE_H_
