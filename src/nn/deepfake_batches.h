// How a deepfake training batch is composed (paper 000 Sec. 4): each example is an A pair and
// a B pair, augmented (augment.h). The A pair is a segmentation render and itself, or, with
// paired clips, a camera-like frame of another person and its true segmentation, that frame's
// background replaced by one of a bank of backgrounds at random. The B pair is a frame of the
// footage and itself. Plain C++: every draw comes from the caller's Rng, so a batch is a
// function of its seed.
#ifndef FACECAP_NN_DEEPFAKE_BATCHES_H_
#define FACECAP_NN_DEEPFAKE_BATCHES_H_

#include <cstdint>
#include <vector>

#include "nn/augment.h"
#include "nn/deepfake.h"
#include "util/image.h"
#include "util/random.h"

namespace facecap::nn {

// Square uint8 RGB images of one size, [count, size, size, 3] in one buffer.
struct ImageStack {
  int size = 0;
  std::vector<uint8_t> pixels;
  int64_t count() const {
    return size ? static_cast<int64_t>(pixels.size()) / (3LL * size * size) : 0;
  }
  const uint8_t* image(int64_t i) const { return pixels.data() + i * 3LL * size * size; }
};

// The images a batch is drawn from (held by the caller while the composer is used).
struct BatchSources {
  const ImageStack* a = nullptr;              // domain A: segmentation renders
  const ImageStack* b = nullptr;              // domain B: frames of the footage
  const ImageStack* paired_image = nullptr;   // paired clips' frames (null or empty: none)
  const ImageStack* paired_target = nullptr;  // their true segmentations, same order and size
};

struct BatchComposition {
  int size = 0;                  // the network's image size
  bool paired = false;           // A pairs may be paired frames (paired clips are given)
  double paired_fraction = 0.;   // the fraction of A pairs that are paired frames
  AugmentOptions augment;        // augment.random_background: the background swap's probability
};

class DeepfakeBatchComposer {
 public:
  // `backgrounds`: uint8 RGB images of the paired frames' size that replace a paired frame's
  // background (empty: never replaced).
  DeepfakeBatchComposer(const BatchSources& sources, const BatchComposition& composition,
                        std::vector<Image8> backgrounds);

  // Writes example `i` of `batch` (count and size set, buffers allocated) from `rng`.
  void AddExample(int i, Rng* rng, TrainingBatch* batch);

 private:
  BatchSources s_;
  BatchComposition c_;
  int64_t image_floats_;
  std::vector<Image8> backgrounds_;
  std::vector<std::vector<uint8_t>> paired_masks_;  // each paired frame's background
  std::vector<uint8_t> composite_;                  // a paired frame on a new background
};

}  // namespace facecap::nn

#endif  // FACECAP_NN_DEEPFAKE_BATCHES_H_
