// Each example of a deepfake batch comes from where the composition says. With augmentation
// off: a segmentation pair is an A image twice; a paired example is a paired frame and its
// own segmentation; a swapped background shows the bank's background exactly where the
// segmentation is border background, and the frame elsewhere; a B pair is a B image twice.
#include "nn/deepfake_batches.h"

#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace facecap::nn {
namespace {

constexpr int kSize = 8;

// `count` images, image k filled by fill(k, x, y, channel).
template <class Fill>
ImageStack Stack(int count, Fill fill) {
  ImageStack s;
  s.size = kSize;
  s.pixels.resize(3LL * kSize * kSize * count);
  for (int k = 0; k < count; ++k) {
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        for (int c = 0; c < 3; ++c) {
          s.pixels[((k * kSize + y) * kSize + x) * 3 + c] = fill(k, x, y, c);
        }
      }
    }
  }
  return s;
}

bool Inside(int x, int y) { return x >= 2 && x < 6 && y >= 2 && y < 6; }

class DeepfakeBatches : public ::testing::Test {
 protected:
  DeepfakeBatches() {
    a_ = Stack(3, [](int k, int, int, int) { return 10 * (k + 1); });
    b_ = Stack(2, [](int k, int, int, int) { return 200 + k; });
    // Paired frame k is flat grey 50 + k; its segmentation is a square of (255, 100 k, 0) on
    // black, so a frame and its segmentation are recognised as a pair.
    paired_image_ = Stack(2, [](int k, int, int, int) { return 50 + k; });
    paired_target_ = Stack(2, [](int k, int x, int y, int c) {
      if (!Inside(x, y)) return 0;
      return c == 0 ? 255 : c == 1 ? 100 * k : 0;
    });
    composition_.size = kSize;
    AugmentOptions& a = composition_.augment;
    a.warp = a.rotate_deg = a.scale = a.shift = a.color_jitter = 0.f;
    a.flip = false;
    batch_.count = 16;
    batch_.size = kSize;
    for (auto* v : {&batch_.input_a, &batch_.target_a, &batch_.input_b, &batch_.target_b}) {
      v->resize(batch_.count * 3LL * kSize * kSize);
    }
  }

  void Compose(std::vector<Image8> backgrounds) {
    DeepfakeBatchComposer composer({&a_, &b_, &paired_image_, &paired_target_}, composition_,
                                   std::move(backgrounds));
    Rng rng(7, 0);
    for (int i = 0; i < batch_.count; ++i) composer.AddExample(i, &rng, &batch_);
  }
  // Channel c of pixel (x, y) of example i in a batch buffer, as 0-255.
  static int At(const std::vector<float>& v, int i, int x, int y, int c) {
    return static_cast<int>(std::lround(v[((i * kSize + y) * kSize + x) * 3 + c] * 255.f));
  }

  ImageStack a_, b_, paired_image_, paired_target_;
  BatchComposition composition_;
  TrainingBatch batch_;
};

TEST_F(DeepfakeBatches, SegmentationAndCameraPairsAreTheirImagesTwice) {
  Compose({});
  std::set<int> a_seen;
  for (int i = 0; i < batch_.count; ++i) {
    const int a = At(batch_.target_a, i, 3, 3, 0), b = At(batch_.target_b, i, 3, 3, 0);
    EXPECT_TRUE(a == 10 || a == 20 || a == 30) << a;
    EXPECT_TRUE(b == 200 || b == 201) << b;
    a_seen.insert(a);
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(At(batch_.input_a, i, x, y, c), a);
          ASSERT_EQ(At(batch_.target_a, i, x, y, c), a);
          ASSERT_EQ(At(batch_.input_b, i, x, y, c), b);
          ASSERT_EQ(At(batch_.target_b, i, x, y, c), b);
        }
      }
    }
  }
  EXPECT_GE(a_seen.size(), 2u);  // examples are drawn, not all the first image
}

TEST_F(DeepfakeBatches, PairedExamplesAreAFrameAndItsOwnSegmentation) {
  composition_.paired = true;
  composition_.paired_fraction = 1.;
  Compose({});
  for (int i = 0; i < batch_.count; ++i) {
    const int k = At(batch_.target_a, i, 3, 3, 1) / 100;
    ASSERT_TRUE(k == 0 || k == 1);
    EXPECT_EQ(At(batch_.target_a, i, 3, 3, 0), 255);
    EXPECT_EQ(At(batch_.target_a, i, 0, 0, 0), 0);
    EXPECT_EQ(At(batch_.input_a, i, 0, 0, 0), 50 + k);  // the frame, background and all
    EXPECT_EQ(At(batch_.input_a, i, 3, 3, 2), 50 + k);
  }
}

TEST_F(DeepfakeBatches, ASwappedBackgroundReplacesTheBorderBackgroundOnly) {
  composition_.paired = true;
  composition_.paired_fraction = 1.;
  composition_.augment.random_background = 1.f;
  Image8 background(kSize, kSize, 3);
  for (uint8_t& v : background.data) v = 123;
  Compose({background});
  for (int i = 0; i < batch_.count; ++i) {
    const int k = At(batch_.target_a, i, 3, 3, 1) / 100;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        ASSERT_EQ(At(batch_.input_a, i, x, y, 0), Inside(x, y) ? 50 + k : 123) << x << "," << y;
      }
    }
  }
}

}  // namespace
}  // namespace facecap::nn
