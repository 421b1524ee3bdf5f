// Wild clips: trajectories that are smooth, bounded and reproducible, scripted keyframes,
// option checks, and frames whose appearance differs from their segmentation render while
// sharing its silhouette.
#include "synth/clip.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "rig/demo_head.h"
#include "synth/appearance.h"
#include "testing/testing.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {
namespace {

const rig::Rig& Person() {
  static const rig::Rig person = [] {
    rig::DemoHeadOptions options;
    options.resolution = 60;
    options.num_identity_modes = 8;
    return rig::WithIdentity(rig::MakeDemoHead(options), 7);
  }();
  return person;
}

ClipOptions SmallClip() {
  ClipOptions o;
  o.frames = 150;
  o.size = 48;
  o.texture.texture_size = 128;
  return o;
}

TEST(ClipTrajectory, WeightsStayInUnitRangeAndChangeSmoothly) {
  ClipOptions o = SmallClip();
  o.blinks_per_minute = 0.f;  // blinks are fast on purpose; checked separately below
  const auto frames = MakeClipTrajectory(Person(), o);
  ASSERT_EQ(frames.size(), 150u);
  float max_step = 0.f, max_weight = 0.f;
  for (size_t f = 0; f < frames.size(); ++f) {
    ASSERT_EQ(frames[f].weights.size(), Person().NumShapes());
    EXPECT_GE(frames[f].weights.minCoeff(), 0.f);
    EXPECT_LE(frames[f].weights.maxCoeff(), 1.f);
    max_weight = std::max(max_weight, frames[f].weights.maxCoeff());
    if (f > 0) {
      max_step = std::max(max_step, (frames[f].weights - frames[f - 1].weights).cwiseAbs().maxCoeff());
    }
  }
  // Smoothstep between keyframes at least 0.6 * expression_seconds apart: the steepest step
  // is 1.5 / (0.6 * 1.2 s * 30 fps) = 0.07 per frame.
  EXPECT_LE(max_step, 0.075f);
  EXPECT_GT(max_weight, 0.3f);  // the face does move
}

TEST(ClipTrajectory, HeadPoseIsSmoothBoundedAndReachesExtremeYaw) {
  ClipOptions o = SmallClip();
  o.frames = 300;
  const auto frames = MakeClipTrajectory(Person(), o);
  constexpr float kDeg = static_cast<float>(M_PI / 180.0);
  float max_yaw = 0.f, max_yaw_step = 0.f, max_pitch_step = 0.f, max_offset_step = 0.f;
  for (size_t f = 0; f < frames.size(); ++f) {
    EXPECT_LE(std::abs(frames[f].yaw), o.yaw_limit_deg * kDeg + 1e-5f);
    EXPECT_LE(std::abs(frames[f].pitch), o.pitch_limit_deg * kDeg + 1e-5f);
    EXPECT_LE(std::abs(frames[f].roll), o.roll_limit_deg * kDeg + 1e-5f);
    EXPECT_LE(frames[f].translation_offset.head<2>().cwiseAbs().maxCoeff(), o.translation_jitter_cm + 1e-5f);
    max_yaw = std::max(max_yaw, std::abs(frames[f].yaw));
    if (f > 0) {
      max_yaw_step = std::max(max_yaw_step, std::abs(frames[f].yaw - frames[f - 1].yaw));
      max_pitch_step = std::max(max_pitch_step, std::abs(frames[f].pitch - frames[f - 1].pitch));
      max_offset_step = std::max(max_offset_step,
                                 (frames[f].translation_offset - frames[f - 1].translation_offset).norm());
    }
  }
  EXPECT_GE(max_yaw, o.extreme_yaw_min_deg * kDeg - 1e-5f) << "no extreme yaw in 10 s";
  // Peak yaw speed yaw_speed_deg per second.
  EXPECT_LE(max_yaw_step, o.yaw_speed_deg / o.fps * kDeg + 1e-4f);
  EXPECT_LE(max_pitch_step, 2.f * kDeg);
  EXPECT_LE(max_offset_step, 0.5f);
}

TEST(ClipTrajectory, BlinksCloseBothEyesBriefly) {
  ClipOptions o = SmallClip();
  o.frames = 600;
  o.blinks_per_minute = 30.f;
  o.sparsity_max_active = {0, 2, 1, 1, 1, 3, 0};  // no random eye shapes
  const auto frames = MakeClipTrajectory(Person(), o);
  const int left = Person().ShapeIndex("eyeBlinkLeft"), right = Person().ShapeIndex("eyeBlinkRight");
  ASSERT_GE(left, 0);
  int closed = 0;
  for (const auto& f : frames) {
    EXPECT_FLOAT_EQ(f.weights[left], f.weights[right]);
    if (f.weights[left] > 0.9f) ++closed;
  }
  EXPECT_GT(closed, 0);
  EXPECT_LT(closed, 600 / 4);
}

TEST(ClipTrajectory, SameSeedSameClipOtherSeedOtherClip) {
  ClipOptions o = SmallClip();
  const auto a = MakeClipTrajectory(Person(), o);
  const auto b = MakeClipTrajectory(Person(), o);
  o.motion_seed = 2;
  const auto c = MakeClipTrajectory(Person(), o);
  bool differs = false;
  for (size_t f = 0; f < a.size(); ++f) {
    EXPECT_EQ(a[f].weights, b[f].weights);
    EXPECT_EQ(a[f].yaw, b[f].yaw);
    differs = differs || a[f].yaw != c[f].yaw;
  }
  EXPECT_TRUE(differs);
}

TEST(ClipTrajectory, ScriptedKeyframesAreFollowed) {
  ClipOptions o = SmallClip();
  o.frames = 61;
  o.keyframes = {"0 yaw_deg=0", "1.0 yaw_deg=60 jawOpen=0.8", "2 pitch_deg=10, mouthSmileLeft=1"};
  const auto frames = MakeClipTrajectory(Person(), o);
  const int jaw = Person().ShapeIndex("jawOpen"), smile = Person().ShapeIndex("mouthSmileLeft");
  constexpr float kDeg = static_cast<float>(M_PI / 180.0);
  EXPECT_NEAR(frames[0].yaw, 0.f, 1e-6f);
  EXPECT_NEAR(frames[30].yaw, 60.f * kDeg, 1e-5f);
  EXPECT_NEAR(frames[30].weights[jaw], 0.8f, 1e-6f);
  EXPECT_NEAR(frames[60].pitch, 10.f * kDeg, 1e-5f);
  EXPECT_NEAR(frames[60].weights[smile], 1.f, 1e-6f);
  EXPECT_NEAR(frames[60].weights[jaw], 0.f, 1e-6f);
  EXPECT_GT(frames[15].yaw, 0.f);
  EXPECT_LT(frames[15].yaw, 60.f * kDeg);
}

TEST(ClipTrajectory, BadKeyframesAndOptionsSayWhy) {
  ClipOptions o = SmallClip();
  o.keyframes = {"0 smileHuge=1"};
  try {
    MakeClipTrajectory(Person(), o);
    ADD_FAILURE() << "unknown shape accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("smileHuge"), std::string::npos) << e.what();
  }
  std::string why;
  o.keyframes = {"1 jawOpen=0.5", "0.5 jawOpen=0"};
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("ascending"), std::string::npos) << why;
  o.keyframes = {"x jawOpen=0.5"};
  EXPECT_FALSE(o.Check(&why));
  o.keyframes = {"0 jawOpen"};
  EXPECT_FALSE(o.Check(&why));
  o = SmallClip();
  o.frames = -3;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("frames"), std::string::npos);
  o = SmallClip();
  o.extreme_yaw_min_deg = 85.f;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("empty"), std::string::npos) << why;
  o = SmallClip();
  o.degradation.jpeg_quality_min = 90;
  o.degradation.jpeg_quality_max = 40;
  EXPECT_FALSE(o.Check(&why));
  o = SmallClip();
  o.sparsity_groups = {"lips"};
  o.sparsity_max_active = {2};
  EXPECT_THROW(MakeClipTrajectory(Person(), o), InvalidInputError);
}

TEST(ClipLighting, MovesOverTimeAndDependsOnTheSeed) {
  ClipOptions o = SmallClip();
  const render::Lighting a = ClipLighting(o, 0), b = ClipLighting(o, 90);
  ASSERT_EQ(a.directional_lights.size(), 2u);
  EXPECT_GT((a.directional_lights[0].direction - b.directional_lights[0].direction).norm(), 0.05f);
  EXPECT_EQ(ClipLighting(o, 90).directional_lights[0].direction, b.directional_lights[0].direction);
  o.lighting_seed = 5;
  EXPECT_NE(ClipLighting(o, 0).directional_lights[0].color, a.directional_lights[0].color);
}

// Mean colour and mean absolute difference of two images over the pixels where `mask` is
// not black.
struct Stats {
  Eigen::Vector3f image_mean = Eigen::Vector3f::Zero(), segmentation_mean = Eigen::Vector3f::Zero();
  float mean_abs_difference = 0.f;
  int covered = 0;
};
Stats Compare(const Image8& image, const Image8& segmentation) {
  Stats s;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = segmentation.pixel(x, y);
      if (p[0] == 0 && p[1] == 0 && p[2] == 0) continue;
      ++s.covered;
      for (int c = 0; c < 3; ++c) {
        s.image_mean[c] += image.at(x, y, c);
        s.segmentation_mean[c] += p[c];
        s.mean_abs_difference += std::abs(image.at(x, y, c) - p[c]);
      }
    }
  }
  if (s.covered > 0) {
    s.image_mean /= s.covered;
    s.segmentation_mean /= s.covered;
    s.mean_abs_difference /= 3.f * s.covered;
  }
  return s;
}

TEST(ClipRenderer, WildFrameLooksUnlikeItsSegmentationAndIsReproducible) {
  const ClipOptions o = SmallClip();
  const auto trajectory = MakeClipTrajectory(Person(), o);
  const ClipRenderer renderer(Person(), o, nullptr);
  ClipRenderer::Workspace w;
  ClipRenderer::Frame a, b;
  renderer.Render(10, trajectory[10], &w, &a);
  ASSERT_EQ(a.image.width, 48);
  ASSERT_EQ(a.segmentation.width, 48);
  ASSERT_EQ(a.landmarks.size(), 68u);
  const Stats s = Compare(a.image, a.segmentation);
  EXPECT_GT(s.covered, 48 * 48 / 5);
  EXPECT_GT(s.mean_abs_difference, 25.f);
  // Skin-like: red above green above blue on the face, unlike the flat region colours.
  EXPECT_GT(s.image_mean[0], s.image_mean[1]);
  EXPECT_GT(s.image_mean[1], s.image_mean[2]);
  // The background is not the segmentation's black.
  EXPECT_GT(a.image.at(0, 0, 0) + a.image.at(0, 0, 1) + a.image.at(0, 0, 2), 0);
  // A frame rendered again (another workspace, after another frame) is the same.
  ClipRenderer::Workspace w2;
  renderer.Render(3, trajectory[3], &w2, &b);
  renderer.Render(10, trajectory[10], &w2, &b);
  EXPECT_EQ(a.image.data, b.image.data);
  EXPECT_EQ(a.segmentation.data, b.segmentation.data);
}

TEST(SkinTexture, PeopleDiffer) {
  SkinTextureOptions options;
  options.texture_size = 64;
  const ImageF a = MakeSkinTexture(Person(), DrawPersonColors(1), 1, options);
  const ImageF b = MakeSkinTexture(Person(), DrawPersonColors(2), 2, options);
  ASSERT_EQ(a.width, 64);
  double diff = 0.0;
  for (size_t i = 0; i < a.data.size(); ++i) {
    EXPECT_GE(a.data[i], 0.f);
    EXPECT_LE(a.data[i], 1.f);
    diff += std::abs(a.data[i] - b.data[i]);
  }
  EXPECT_GT(diff / a.data.size(), 0.01);
}

// The video writer's output is a function of the frames alone: the same 160-pixel frames
// (a width whose chroma plane the encoder pads) give the same file bytes after the heap has
// held other data, as they do in two runs of a stage with different histories.
TEST(WriteVideo, SameFramesGiveTheSameFileWhateverTheHeapHeld) {
  Rng rng(5, 0);
  std::vector<Image8> frames(24, Image8(160, 160, 3));
  for (size_t f = 0; f < frames.size(); ++f) {
    for (int y = 0; y < 160; ++y) {
      for (int x = 0; x < 160; ++x) {
        for (int c = 0; c < 3; ++c) {
          frames[f].at(x, y, c) = static_cast<uint8_t>((x + 2 * y + 3 * static_cast<int>(f) + 40 * c) % 200 +
                                                       static_cast<int>(rng.NextU64() % 50));
        }
      }
    }
  }
  testing::TempDir dir;
  ASSERT_EQ(WriteVideo(dir.File("first.mp4"), frames, 25.), "avc1");
  std::vector<void*> blocks;
  for (int k = 0; k < 500; ++k) {
    const size_t n = 1000 + rng.NextU64() % 100000;
    void* p = std::malloc(n);
    std::memset(p, static_cast<int>(rng.NextU64() % 256), n);
    blocks.push_back(p);
  }
  for (void* p : blocks) std::free(p);
  WriteVideo(dir.File("second.mp4"), frames, 25.);
  const std::string first = testing::ReadText(dir.File("first.mp4"));
  EXPECT_GT(first.size(), 1000u);
  EXPECT_TRUE(first == testing::ReadText(dir.File("second.mp4")));
}

}  // namespace
}  // namespace facecap::synth
