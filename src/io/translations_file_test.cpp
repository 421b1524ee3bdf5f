// The translations of deepfake infer: what it writes frame by frame is what TranslationsFile
// reads, one frame or all, and a file without square RGB translations, or a frame it does not
// hold, is refused naming the file.
#include "io/translations_file.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io/frames_file.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

// `count` translations of [height, width, channels], frame by frame as deepfake infer writes
// them; pixel value (frame * 7 + index) mod 256.
void WriteTranslations(const std::string& path, int64_t count, int64_t height, int64_t width,
                       int64_t channels = 3) {
  H5File f = H5File::CreateAtomic(path);
  f.CreateFrames<uint8_t>(frames::kTranslated, {height, width, channels}, count, 16);
  std::vector<uint8_t> image(static_cast<size_t>(height * width * channels));
  for (int64_t n = 0; n < count; ++n) {
    for (size_t i = 0; i < image.size(); ++i) image[i] = static_cast<uint8_t>((n * 7 + i) % 256);
    f.WriteFrames<uint8_t>(frames::kTranslated, n, 1, image.data());
  }
  f.Commit();
}

// The FileIOError of opening `path` (empty when it opened).
std::string OpenError(const std::string& path) {
  try {
    TranslationsFile translations(path);
  } catch (const FileIOError& e) {
    return e.what();
  }
  return "";
}

TEST(TranslationsFile, WhatDeepfakeInferWritesIsRead) {
  testing::TempDir dir;
  WriteTranslations(dir.File("t.h5"), 3, 8, 8);
  const TranslationsFile translations(dir.File("t.h5"));
  EXPECT_EQ(translations.count(), 3);
  EXPECT_EQ(translations.size(), 8);
  const Image8 frame = translations.ReadFrame(2);
  EXPECT_EQ(frame.width, 8);
  EXPECT_EQ(frame.height, 8);
  EXPECT_EQ(frame.channels, 3);
  EXPECT_EQ(frame.at(1, 0, 2), static_cast<uint8_t>(2 * 7 + 5));
  const std::vector<uint8_t> all = translations.ReadAll();
  ASSERT_EQ(all.size(), 3u * 8 * 8 * 3);
  EXPECT_TRUE(std::equal(frame.data.begin(), frame.data.end(), all.begin() + 2 * 8 * 8 * 3));
}

TEST(TranslationsFile, AFrameItDoesNotHoldIsRefusedByName) {
  testing::TempDir dir;
  const std::string path = dir.File("t.h5");
  WriteTranslations(path, 2, 4, 4);
  const TranslationsFile translations(path);
  for (int64_t frame : {int64_t{-1}, int64_t{2}}) {
    try {
      translations.ReadFrame(frame);
      ADD_FAILURE() << "frame " << frame << " was read";
    } catch (const FileIOError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ": no translation of frame " +
                                           std::to_string(frame)),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(TranslationsFile, OtherFilesAreRefusedByName) {
  testing::TempDir dir;
  const std::string none = dir.File("none.h5");
  {
    H5File f = H5File::CreateAtomic(none);
    f.WriteVector<float>(frames::kLatent, {1.f, 2.f});
    f.Commit();
  }
  const std::string wide = dir.File("wide.h5");
  WriteTranslations(wide, 2, 4, 6);
  const std::string gray = dir.File("gray.h5");
  WriteTranslations(gray, 2, 4, 4, 1);
  std::string error = OpenError(none);
  EXPECT_NE(error.find(none + ": no /frames/translated"), std::string::npos) << error;
  error = OpenError(wide);
  EXPECT_NE(error.find(wide + ": /frames/translated has shape [2, 4, 6, 3], expected [N, S, S, 3]"),
            std::string::npos)
      << error;
  error = OpenError(gray);
  EXPECT_NE(error.find(gray + ": dataset /frames/translated has shape [2, 4, 4, 1]"),
            std::string::npos)
      << error;
}

}  // namespace
}  // namespace facecap::io
