#include "nn/deepfake_batches.h"

#include <utility>

namespace facecap::nn {

DeepfakeBatchComposer::DeepfakeBatchComposer(const BatchSources& sources,
                                             const BatchComposition& composition,
                                             std::vector<Image8> backgrounds)
    : s_(sources),
      c_(composition),
      image_floats_(3LL * composition.size * composition.size),
      backgrounds_(std::move(backgrounds)) {
  if (backgrounds_.empty()) return;
  const int size = s_.paired_target->size;
  for (int64_t i = 0; i < s_.paired_target->count(); ++i) {
    paired_masks_.push_back(BorderBackgroundMask(s_.paired_target->image(i), size));
  }
  composite_.resize(3LL * size * size);
}

void DeepfakeBatchComposer::AddExample(int i, Rng* rng, TrainingBatch* batch) {
  const int64_t ia = rng->UniformInt(s_.a->count()), ib = rng->UniformInt(s_.b->count());
  const uint8_t* input_a = nullptr;
  const ImageStack* target_a = s_.a;
  int64_t index_a = ia;
  PairKind kind_a = PairKind::kSegmentation;
  if (c_.paired && rng->Uniform() < c_.paired_fraction) {
    // A paired example: a camera-like frame of another person, its true segmentation.
    index_a = rng->UniformInt(s_.paired_target->count());
    target_a = s_.paired_target;
    input_a = s_.paired_image->image(index_a);
    kind_a = PairKind::kPairedCamera;
    if (!backgrounds_.empty() && rng->Uniform() < c_.augment.random_background) {
      const Image8& background = backgrounds_[rng->UniformInt(backgrounds_.size())];
      ReplaceBackground(input_a, background.data.data(), paired_masks_[index_a],
                        s_.paired_image->size, composite_.data());
      input_a = composite_.data();
    }
  }
  AugmentPair(target_a->image(index_a), target_a->size, c_.size, c_.augment, kind_a, rng,
              &batch->input_a[i * image_floats_], &batch->target_a[i * image_floats_], input_a);
  AugmentPair(s_.b->image(ib), s_.b->size, c_.size, c_.augment, PairKind::kCamera, rng,
              &batch->input_b[i * image_floats_], &batch->target_b[i * image_floats_]);
}

}  // namespace facecap::nn
