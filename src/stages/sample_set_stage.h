// facecap synth contract: the random samples that no real frame resembles, judged in a first
// deepfake's latent space, removed (paper 000 Sec. 7.1, Fig. 16). The samples' codes E(I_S)
// are compared with the real frames' E(D_A(E(I_R))) (stages/sample_file.h): a sample whose
// code lies far from every real frame's (mean distance to the k nearest) is out of
// distribution; the remove_fraction highest-scoring samples (or those above an earlier
// contraction's bound) are removed, with a contact sheet of the most and least
// in-distribution samples beside their nearest real frames.
#ifndef FACECAP_STAGES_SAMPLE_SET_STAGE_H_
#define FACECAP_STAGES_SAMPLE_SET_STAGE_H_

#include <string>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [synth.contract]
struct SynthContractOptions {
  std::string samples = "samples.h5";              // the random samples
  std::string sample_codes = "samples_codes.h5";   // deepfake infer of the samples
  std::string frame_codes = "translated.h5";       // deepfake infer of the footage crops
  std::string frames = "";                         // the footage crops, for the sheet
  std::string out = "contracted.h5";               // output file
  std::string sheet = "";                          // PNG ("": beside out; "none": no sheet)
  int neighbors = 5;                               // k of the mean k-nearest distance
  double remove_fraction = 0.2;                    // samples removed (without bound)
  std::string bound = "";                          // an earlier contraction's output
  int sheet_rows = 6;                              // samples per side of the sheet

  template <class V>
  void Visit(V&& v) {
    v("samples", samples, "samples file (synth samples, or a set synth expand made)");
    v("sample_codes", sample_codes,
      "deepfake infer's output on the samples (--dataset /samples/segmentation): their codes "
      "E(I) in /frames/latent");
    v("frame_codes", frame_codes,
      "deepfake infer's output on the footage crops, from the same model: their translations' "
      "codes E(D_A(E(I))) in /frames/latent_of_translation");
    v("frames", frames,
      "the footage crops (ingest's output) shown on the sheet beside each sample (empty: their "
      "translations from frame_codes)");
    v("out", out, "output file (HDF5): the kept samples, their codes, every sample's score");
    v("sheet", sheet,
      "contact sheet PNG: the most and least in-distribution samples, each beside its nearest "
      "real frame, kept ones framed green and removed ones red (default: beside out; none: no "
      "sheet)");
    v("neighbors", neighbors,
      "k: a sample's score is the mean distance from its code to the k nearest real frames' codes");
    v("remove_fraction", remove_fraction,
      "fraction of the samples removed, those of the highest scores (unless bound is given)");
    v("bound", bound,
      "an earlier synth contract output: remove the samples scoring above its bound "
      "(/contraction@threshold) instead of remove_fraction, e.g. to check an expanded set's new "
      "samples against the first contraction (codes from the same deepfake)");
    v("sheet_rows", sheet_rows, "rows of the sheet");
  }
  bool Check(std::string* why) const {
    if (neighbors < 1) { *why = "neighbors must be at least 1"; return false; }
    if (!(remove_fraction >= 0 && remove_fraction < 1)) {
      *why = "remove_fraction must be in [0, 1)";
      return false;
    }
    if (sheet_rows < 1) { *why = "sheet_rows must be at least 1"; return false; }
    return true;
  }
};

// synth contract, rank 0 alone: the kept samples, their codes and every sample's score to
// options.out, and the sheet. The summary counts the kept samples (all written by every run);
// 0 on the other ranks, which do nothing.
StageSummary RunSynthContract(const SynthContractOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SAMPLE_SET_STAGE_H_
