// The truth of a clip: what synth clip writes under /frames is what ReadClipTruth returns,
// translation and frame rate are optional, and a file whose shapes do not agree is refused
// naming the file and the dataset.
#include "io/clip_file.h"

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "io/camera_file.h"
#include "io/frames_file.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

constexpr int64_t kFrames = 4;

// What a clip's truth holds, written frame by frame as synth clip writes it; `shapes` names
// and `weight_columns` columns of weights, `pose_frames` rows of pose.
struct ClipLayout {
  int64_t shapes = 2, weight_columns = 2, pose_frames = kFrames, pose_columns = 3;
  bool translation = true;
  int64_t translation_columns = 3;
  bool camera = true;
  bool pose = true;
};

void WriteClip(const std::string& path, const ClipLayout& c) {
  H5File f = H5File::CreateAtomic(path);
  std::vector<std::string> names;
  for (int64_t s = 0; s < c.shapes; ++s) names.push_back("shape" + std::to_string(s));
  f.WriteStrings(frames::kShapeNames, names);
  f.CreateFrames<float>(frames::kWeights, {c.weight_columns}, kFrames, 256);
  if (c.pose) f.CreateFrames<float>(frames::kPose, {c.pose_columns}, c.pose_frames, 1024);
  if (c.translation) {
    f.CreateFrames<float>(frames::kTranslation, {c.translation_columns}, kFrames, 1024);
  }
  for (int64_t n = 0; n < kFrames; ++n) {
    std::vector<float> weights(c.weight_columns);
    for (int64_t s = 0; s < c.weight_columns; ++s) weights[s] = 0.1f * n + 0.01f * s;
    f.WriteFrames<float>(frames::kWeights, n, 1, weights.data());
    if (c.translation) {
      std::vector<float> t(c.translation_columns, 0.f);
      t[0] = static_cast<float>(n);
      f.WriteFrames<float>(frames::kTranslation, n, 1, t.data());
    }
  }
  for (int64_t n = 0; c.pose && n < c.pose_frames; ++n) {
    std::vector<float> pose(c.pose_columns, 0.f);
    pose[0] = -0.5f * n;
    f.WriteFrames<float>(frames::kPose, n, 1, pose.data());
  }
  if (c.camera) {
    CameraRecord camera;
    camera.fx = camera.fy = 300.;
    camera.cx = camera.cy = 32.;
    camera.fps = 25.;
    WriteCamera(&f, camera);
  }
  f.Commit();
}

// The FileIOError of reading `path`'s truth (empty when it was read).
std::string ReadError(const std::string& path) {
  try {
    ReadClipTruth(H5File::OpenRead(path));
  } catch (const FileIOError& e) {
    return e.what();
  }
  return "";
}

TEST(ClipFile, WhatSynthClipWritesIsRead) {
  testing::TempDir dir;
  WriteClip(dir.File("clip.h5"), ClipLayout{});
  const ClipTruth t = ReadClipTruth(H5File::OpenRead(dir.File("clip.h5")));
  EXPECT_EQ(t.names, (std::vector<std::string>{"shape0", "shape1"}));
  EXPECT_EQ(t.frames(), kFrames);
  ASSERT_EQ(t.weights.cols(), 2);
  EXPECT_FLOAT_EQ(t.weights(3, 1), 0.31f);
  ASSERT_EQ(t.pose.rows(), kFrames);
  ASSERT_EQ(t.pose.cols(), 3);
  EXPECT_FLOAT_EQ(t.pose(2, 0), -1.f);
  ASSERT_EQ(t.translation.rows(), kFrames);
  EXPECT_FLOAT_EQ(t.translation(3, 0), 3.f);
  EXPECT_EQ(t.fps, 25.);
}

TEST(ClipFile, TranslationAndFrameRateAreOptional) {
  testing::TempDir dir;
  ClipLayout layout;
  layout.translation = false;
  layout.camera = false;
  WriteClip(dir.File("clip.h5"), layout);
  const ClipTruth t = ReadClipTruth(H5File::OpenRead(dir.File("clip.h5")));
  EXPECT_EQ(t.translation.rows(), 0);
  EXPECT_EQ(t.fps, 0.);
  EXPECT_EQ(t.pose.rows(), kFrames);
}

TEST(ClipFile, AFileWithoutPoseIsNotAClip) {
  testing::TempDir dir;
  const std::string path = dir.File("clip.h5");
  ClipLayout layout;
  layout.pose = false;
  WriteClip(path, layout);
  const std::string error = ReadError(path);
  EXPECT_NE(error.find(path + ": no /frames/pose"), std::string::npos) << error;
}

TEST(ClipFile, ShapesThatDoNotAgreeAreRefusedByName) {
  testing::TempDir dir;
  ClipLayout weights;  // 3 columns of weights for 2 shape names
  weights.weight_columns = 3;
  ClipLayout pose_rows;
  pose_rows.pose_frames = kFrames - 1;
  ClipLayout pose_columns;
  pose_columns.pose_columns = 4;
  ClipLayout translation;
  translation.translation_columns = 2;
  const std::vector<std::pair<ClipLayout, std::string>> cases = {
      {weights, "/frames/weights has shape [4, 3], expected [*, 2]"},
      {pose_rows, "/frames/pose has shape [3, 3], expected [4, 3]"},
      {pose_columns, "/frames/pose has shape [4, 4], expected [4, 3]"},
      {translation, "/frames/translation has shape [4, 2], expected [4, 3]"}};
  for (size_t k = 0; k < cases.size(); ++k) {
    const std::string path = dir.File("clip" + std::to_string(k) + ".h5");
    WriteClip(path, cases[k].first);
    const std::string error = ReadError(path);
    EXPECT_NE(error.find(path + ": " + cases[k].second), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace facecap::io
