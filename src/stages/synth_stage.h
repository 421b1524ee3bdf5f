// facecap synth samples | expand: rig samples rendered as segmentation images with landmarks
// (paper 000 Sec. 7), spread across ranks, identical for any rank count, resumable.
//   synth samples: random samples (controls uniform under per-region sparsity limits, pose
//     from a truncated Gaussian);
//   synth expand: a contracted sample set expanded (paper 000 Sec. 7.2): the real frames whose
//     deepfake codes lie farthest from every sample's are gaps; the tracker's solutions on them,
//     jittered per control and interpolated between pairs, are rendered as new samples with
//     the set's own sampling options.
#ifndef FACECAP_STAGES_SYNTH_STAGE_H_
#define FACECAP_STAGES_SYNTH_STAGE_H_

#include <cstdint>
#include <string>

#include "face/align.h"
#include "io/config.h"
#include "stages/stage.h"
#include "synth/sample_set.h"
#include "synth/samples.h"

namespace facecap::stages {

// [synth.samples]
struct SynthSamplesOptions {
  std::string rig = "rig.h5";        // rig file
  std::string out = "samples.h5";    // output file
  int batch = 32;                    // samples per rank per round (a checkpoint per round)
  int threads = 0;                   // OpenMP threads per rank (0: cores / ranks on the node)
  // Framing: "centered" (the head framed on the optical axis, fill of the image) or "crop"
  // (each sample framed as ingest crops footage: the head filmed by a camera of fov_deg at
  // fill, then the similarity-aligned crop of its 68 landmarks with crop_padding and
  // crop_raise, rendered directly through the crop's camera).
  std::string framing = "centered";
  double crop_padding = 0.4;
  double crop_raise = 0.04;
  synth::SampleOptions sample;       // the sampling and rendering options

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5)");
    v("out", out, "output file (HDF5)");
    v("batch", batch, "samples per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    v("framing", framing,
      "centered: the head on the optical axis filling `fill` of the image; crop: framed as "
      "ingest crops footage (the aligned crop of the 68 landmarks, crop_padding, crop_raise), "
      "so that the samples look like the crops a deepfake translates; each sample's camera in "
      "/samples/camera");
    v("crop_padding", crop_padding, "framing = crop: ingest's crop_padding");
    v("crop_raise", crop_raise, "framing = crop: ingest's crop_raise");
    sample.Visit(v);
  }
  bool Check(std::string* why) const {
    if (batch <= 0) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (framing != "centered" && framing != "crop") {
      *why = "framing must be centered or crop, not " + framing;
      return false;
    }
    face::CropOptions crop{sample.size, crop_padding, crop_raise};
    if (!crop.Check(why)) return false;
    return sample.Check(why);
  }
};

// [synth.expand]
struct SynthExpandOptions {
  std::string rig = "rig.h5";                 // the rig the samples were rendered with
  std::string samples = "contracted.h5";      // the set to expand (synth contract's output)
  std::string frame_codes = "translated.h5";  // deepfake infer of the footage crops
  std::string track = "track.h5";             // the tracker's solutions on those frames
  std::string out = "expanded.h5";            // output file
  int64_t count = 0;                          // samples in the output (0: the random set's)
  double gap_fraction = 0.2;                  // real frames taken as gaps
  int neighbors = 5;                          // k of the mean distance to the k nearest codes
  int batch = 32;
  int threads = 0;
  synth::ExpansionOptions expansion;

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file the samples were rendered with (HDF5)");
    v("samples", samples, "samples to expand: synth contract's output (with /samples/latent)");
    v("frame_codes", frame_codes,
      "deepfake infer's output on the footage crops (/frames/latent_of_translation: each "
      "frame's translation's code E(D_A(E(I))))");
    v("track", track, "the tracker's solutions on the same frames: its track of the footage, a "
      "row per frame of frame_codes");
    v("out", out, "output file (HDF5): the samples, then the new ones");
    v("count", count,
      "samples in the output, the kept ones included (0: the count the random set was drawn "
      "with, so that the expanded set is as large as the raw one)");
    v("gap_fraction", gap_fraction,
      "fraction of the real frames, those farthest from every sample's code, whose solutions "
      "seed the new samples");
    v("neighbors", neighbors, "k of the mean distance to the k nearest codes");
    v("batch", batch, "samples per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    expansion.Visit(v);
  }
  bool Check(std::string* why) const {
    if (count < 0) { *why = "count must be >= 0"; return false; }
    if (!(gap_fraction > 0 && gap_fraction <= 1)) {
      *why = "gap_fraction must be in (0, 1]";
      return false;
    }
    if (neighbors < 1) { *why = "neighbors must be at least 1"; return false; }
    if (batch <= 0) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    return expansion.Check(why);
  }
};

// synth samples, collective: the samples rendered across ranks, written by rank 0 to
// options.out. The summary counts samples (computed: those this run rendered;
// 0 when the output was up to date).
StageSummary RunSynthSamples(const SynthSamplesOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

// synth expand, collective: the kept samples copied and the new ones rendered across ranks,
// written by rank 0 to options.out. The summary counts samples (computed: those this run
// copied or rendered; 0 when the output was up to date).
StageSummary RunSynthExpand(const SynthExpandOptions& options, const StageContext& ctx,
                            const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SYNTH_STAGE_H_
