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
  // Flip segmentation pairs (domain A and paired camera frames) too, with the colours of each
  // left and right region swapped (needs a SideSwap; see AugmentPair). Off by default: at the
  // 20-minute budget it changed the held-out IoU by no more than the run-to-run spread.
  bool flip_segmentation = false;
  float color_jitter = 0.15f;  // brightness, contrast and per-channel gain jitter of domain B
  // Probability that a domain-A input (a flat segmentation render) is repainted with random
  // plausible appearance: per-region albedo around a random skin tone (lips, brows, hair,
  // eye whites, irises by region name), a random smooth shading field, a random background and
  // sensor noise. Its target stays the flat render, so D_A learns to undo the appearance and
  // E sees real-looking inputs in both domains (domain randomization of the synthetic side).
  // 0 is the plain setting of paper 000.
  float randomize_a = 0.f;
  // Probability that a paired camera frame's background (the black pixels of its segmentation
  // that reach the image border) is replaced by another one, drawn from a bank of random
  // procedural backgrounds (gradients, blurred blobs, stripes) through the camera's
  // degradations. A paired clip has the one background of its scene, and a network that has
  // seen one background takes the dark parts of another for mouth interior or hair. 0: off.
  float random_background = 0.f;
  // Probability that a paired camera frame's input gets a random change of look on top of the
  // colour jitter (AugmentAppearance): a Gaussian blur, a linear light ramp across the image,
  // a gamma and per-channel gains (a skin tone and light colour). A paired clip has the one
  // person, light and lens of its scene, and a new person under other light through another
  // lens is what the translation meets. 0: off.
  float paired_appearance = 0.f;

  template <class V>
  void Visit(V&& v) {
    v("warp", warp, "random warp amplitude of the input image, fraction of the image size");
    v("warp_grid", warp_grid, "control points per side of the random warp field");
    v("rotate_deg", rotate_deg, "random rotation range in degrees");
    v("scale", scale, "random scale range: [1 - scale, 1 + scale]");
    v("shift", shift, "random shift range, fraction of the image size");
    v("flip", flip,
      "random horizontal flips of camera frames (domain B; segmentation pairs only with "
      "flip_segmentation)");
    v("flip_segmentation", flip_segmentation,
      "random horizontal flips of segmentation pairs too (domain A and paired camera frames), "
      "with each left region's colour swapped with its right region's");
    v("color_jitter", color_jitter,
      "brightness, contrast and per-channel gain jitter of domain B (0: none)");
    v("randomize_a", randomize_a,
      "probability that a domain-A input is repainted with random skin-like appearance "
      "(its target stays the flat segmentation); 0: the plain setting");
    v("random_background", random_background,
      "probability that a paired camera frame's background is replaced by a random procedural "
      "one (0: never)");
    v("paired_appearance", paired_appearance,
      "probability that a paired camera frame's input is blurred, relit by a light ramp, "
      "gamma-corrected and tinted at random (0: never)");
  }
  bool Check(std::string* why) const;
};

// The packed 0xRRGGBB colours of the regions that trade places under a horizontal flip:
// left_X with right_X, by region name.
struct SideSwap {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  bool empty() const { return pairs.empty(); }
};
SideSwap SideSwapOf(const std::vector<std::string>& region_names,
                    const std::vector<uint32_t>& packed_colors);
// The index of each region's mirror region by name (left_X <-> right_X); its own index for a
// region without one.
std::vector<int> MirrorRegions(const std::vector<std::string>& region_names);
// Copies a uint8 RGB image [size, size, 3], each pixel of a left region's colour painted with
// its right region's and the other way round; other pixels unchanged.
void SwapSides(const uint8_t* image, int size, const SideSwap& sides, uint8_t* out);

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
// With `input_image` (same size as `image`), the input is sampled from it instead (a repainted
// segmentation render, see RepaintSegmentation, or the camera frame of kPairedCamera).
// Camera pairs are flipped with probability 1/2 (options.flip); segmentation pairs only with
// `sides` given and options.flip_segmentation, their segmentation (and a kSegmentation input
// without `input_image`) then read through SwapSides, so that a mirrored left brow is still
// labelled as the right brow it has become.
void AugmentPair(const uint8_t* image, int source_size, int size, const AugmentOptions& options,
                 PairKind kind, Rng* rng, float* input, float* target,
                 const uint8_t* input_image = nullptr, const SideSwap* sides = nullptr);

// A random change of look of a float RGB image [size, size, 3] in [0, 1], in place: a
// Gaussian blur of sigma in [0, 1.5] pixels (half the time), a light ramp
// 1 + a x + b y (x, y in [-1, 1], a, b in [-0.35, 0.35]), a gamma in [0.7, 1.45] and
// per-channel gains in [0.8, 1.2]. Every draw comes from `rng`.
void AugmentAppearance(float* image, int size, Rng* rng);

// What a segmentation region looks like on a person, from its name.
enum class RegionKind { kSkin, kLips, kBrow, kHair, kSclera, kIris, kPupil, kMouth };
RegionKind RegionKindOf(const std::string& region_name);

// The flat region colours of a segmentation render and their kinds.
struct SegmentationPalette {
  std::vector<uint32_t> colors;     // packed 0xRRGGBB, one per region
  std::vector<RegionKind> kinds;    // one per region
  uint32_t background = 0;          // packed colour of the background
};

// Repaints a flat segmentation render (uint8 RGB [size, size, 3]) with a random appearance
// drawn from `rng`: each region an albedo of its kind around one random skin tone, hair and
// brow colour, eye colour, times a smooth random shading field, a random background (a colour
// or a gradient), and Gaussian noise. Pixels whose colour is not in the palette take the
// nearest palette colour's appearance. Writes uint8 RGB [size, size, 3] into `out`.
void RepaintSegmentation(const uint8_t* image, int size, const SegmentationPalette& palette,
                         Rng* rng, uint8_t* out);

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
