// Augmentation of deepfake training images (as DeepFaceLab does): a random similarity
// transform and flip shared by the input and its target, a smooth random warp of the input
// only (so the autoencoder must undo it and cannot copy pixels), and colour jitter.
// Plain C++; every draw comes from the caller's Rng, so a batch is a function of the seed.
#ifndef FACECAP_NN_AUGMENT_H_
#define FACECAP_NN_AUGMENT_H_

#include <cstdint>
#include <string>

#include "util/random.h"

namespace facecap::nn {

struct AugmentOptions {
  float warp = 0.04f;          // random warp amplitude of the input, fraction of the image size
  int warp_grid = 5;           // control points per side of the warp field
  float rotate_deg = 8.f;      // random rotation in [-rotate_deg, rotate_deg]
  float scale = 0.05f;         // random scale in [1 - scale, 1 + scale]
  float shift = 0.04f;         // random shift in [-shift, shift] of the image size
  bool flip = true;            // random horizontal flip (probability 1/2)
  float color_jitter = 0.15f;  // brightness, contrast and per-channel gain jitter of domain B

  template <class V>
  void Visit(V&& v) {
    v("warp", warp, "random warp amplitude of the input image, fraction of the image size");
    v("warp_grid", warp_grid, "control points per side of the random warp field");
    v("rotate_deg", rotate_deg, "random rotation range in degrees");
    v("scale", scale, "random scale range: [1 - scale, 1 + scale]");
    v("shift", shift, "random shift range, fraction of the image size");
    v("flip", flip, "random horizontal flips");
    v("color_jitter", color_jitter,
      "brightness, contrast and per-channel gain jitter of domain B (0: none)");
  }
  bool Check(std::string* why) const;
};

// From one uint8 RGB image [source_size, source_size, 3], writes `input` and `target` as float
// RGB in [0, 1], [size, size, 3] (resampled bilinearly when the sizes differ). With
// `jitter_colors`, the colour jitter applies to both (domain B: colours are not labels there).
void AugmentPair(const uint8_t* image, int source_size, int size, const AugmentOptions& options,
                 bool jitter_colors, Rng* rng, float* input, float* target);

// Bilinear resampling of a uint8 RGB image to size x size floats in [0, 1] (no augmentation).
void ResizeToFloat(const uint8_t* image, int source_size, int size, float* out);

}  // namespace facecap::nn

#endif  // FACECAP_NN_AUGMENT_H_
