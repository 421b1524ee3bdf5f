// facecap synth crops: a synthetic clip's frames as ingest cropped its video, beside the clip's
// segmentation renders warped by the same crop transforms (nearest neighbour, so that every
// pixel keeps a region colour), with the clip's regions. Two uses: paired examples for the
// deepfake (wild frames of other people with their true segmentation) in the framing of real
// crops, and the true segmentation of a clip's crops, for the oracle solves of the demo.
// Rank 0 alone: a copy and a warp per frame.
#ifndef FACECAP_STAGES_SYNTH_CROPS_STAGE_H_
#define FACECAP_STAGES_SYNTH_CROPS_STAGE_H_

#include <string>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [synth.crops]
struct SynthCropsOptions {
  std::string clip = "clip.h5";        // synth clip output (its segmentation and regions)
  std::string frames = "frames.h5";    // ingest output of the clip's video
  std::string out = "crops.h5";

  template <class V>
  void Visit(V&& v) {
    v("clip", clip, "synth clip output (HDF5) with /frames/segmentation and /regions");
    v("frames", frames, "ingest output of that clip's video (its crops and crop transforms)");
    v("out", out, "output (HDF5): /frames/image (the crops), /frames/segmentation (warped), "
                  "/frames/found, /regions");
  }
  bool Check(std::string* why) const {
    if (clip.empty() || frames.empty() || out.empty()) {
      *why = "clip, frames and out are required";
      return false;
    }
    return true;
  }
};

// synth crops, rank 0 alone: the crops and warped segmentations to options.out. The summary
// counts frames (every frame of the ingest output, written by every run); 0 on the other ranks,
// which do nothing.
StageSummary RunSynthCrops(const SynthCropsOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SYNTH_CROPS_STAGE_H_
