// Augmentation of deepfake training images (as DeepFaceLab does): a random similarity
// transform shared by the input and its target, a horizontal flip of camera pairs, a smooth
// random warp of the input (so the autoencoder must undo it and cannot copy pixels), and
// colour jitter.
// Plain C++; every draw comes from the caller's Rng, so a batch is a function of the seed.
#ifndef FACECAP_NN_AUGMENT_H_
#define FACECAP_NN_AUGMENT_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "util/random.h"

namespace facecap::nn {

struct AugmentOptions {
  float warp = 0.04f;          // random warp amplitude of the input, fraction of the image size
  int warp_grid = 5;           // control points per side of the warp field
  float rotate_deg = 8.f;      // random rotation in [-rotate_deg, rotate_deg]
  float scale = 0.05f;         // random scale in [1 - scale, 1 + scale]
  float shift = 0.04f;         // random shift in [-shift, shift] of the image size
  bool flip = true;            // random horizontal flip of domain B's pairs (probability 1/2)
  float color_jitter = 0.15f;  // brightness, contrast and per-channel gain jitter of domain B
  // Probability that a paired camera frame's background (the black pixels of its segmentation
  // that reach the image border) is replaced by another one, drawn from a bank of random
  // procedural backgrounds (gradients, blurred blobs, stripes) through the camera's
  // degradations. A paired clip has the one background of its scene, and a network that has
  // seen one background takes the dark parts of another for mouth interior or hair. 0: off.
  float random_background = 0.f;

  bool Check(std::string* why) const;
};

// The index of each region's mirror region by name (left_X <-> right_X); its own index for a
// region without one.
std::vector<int> MirrorRegions(const std::vector<std::string>& region_names);

// What an (input, target) pair is, which decides where the warp and the colour jitter go.
enum class PairKind {
  // Domain A: a segmentation render and itself. The warp moves the input only (the
  // autoencoder must undo it and cannot copy pixels); no colour jitter (colours are labels).
  kSegmentation,
  // Domain B: a camera frame and itself. The warp moves the input only; the colour jitter
  // applies to both (colours are not labels there).
  kCamera,
  // A camera frame (`input_image`) and its true segmentation (`image`): the warp moves both
  // alike, since the target must stay where the input shows it (a region a few pixels wide
  // moved by the warp alone is a wrong label); the colour jitter applies to the input only.
  kPairedCamera,
};

// From one uint8 RGB image [source_size, source_size, 3], writes `input` and `target` as float
// RGB in [0, 1], [size, size, 3] (resampled bilinearly, except a segmentation target, which is
// sampled nearest: its labels must not blend), under a random
// similarity transform shared by both, a flip, and a warp and a colour jitter placed by `kind`.
// With `input_image` (same size as `image`), the input is sampled from it instead (the camera
// frame of kPairedCamera). Camera pairs are flipped with probability 1/2 (options.flip);
// segmentation pairs never (a mirrored left brow would keep the left brow's colour).
void AugmentPair(const uint8_t* image, int source_size, int size, const AugmentOptions& options,
                 PairKind kind, Rng* rng, float* input, float* target,
                 const uint8_t* input_image = nullptr);

// The background of a segmentation render (uint8 RGB [size, size, 3]) as a mask [size, size]
// (1: background): its black pixels (every channel at most 8) connected to the image border,
// so that a black region inside the face (the pupil) is not background.
std::vector<uint8_t> BorderBackgroundMask(const uint8_t* segmentation, int size);

// `image` with the pixels of `mask` taken from `background` (all uint8 RGB [size, size, 3]).
void ReplaceBackground(const uint8_t* image, const uint8_t* background,
                       const std::vector<uint8_t>& mask, int size, uint8_t* out);

// Bilinear resampling of a uint8 RGB image to size x size floats in [0, 1] (no augmentation).
void ResizeToFloat(const uint8_t* image, int source_size, int size, float* out);

}  // namespace facecap::nn

#endif  // FACECAP_NN_AUGMENT_H_
