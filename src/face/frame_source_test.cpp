// Bad input on the way in: unreadable and empty videos, grayscale, 16-bit, float and huge
// images, corrupt files, empty folders. Each is a clear message or a flagged conversion.
#include "face/frame_source.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "util/errors.h"

namespace facecap::face {
namespace {

namespace fs = std::filesystem;

class FrameSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("facecap_frame_source_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string File(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(FrameSourceTest, UnreadableAndEmptyVideosAreInputErrors) {
  std::ofstream(File("text.mp4")) << "this is not a video\n";
  std::ofstream(File("empty.mp4"));
  for (const char* name : {"text.mp4", "empty.mp4", "missing.mp4"}) {
    try {
      FrameSource::OpenVideo(File(name), 0);
      FAIL() << name << ": expected FileIOError";
    } catch (const FileIOError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

TEST_F(FrameSourceTest, VideoFramesReadInAnyOrderAreTheSame) {
  std::vector<Image8> frames;
  for (int i = 0; i < 6; ++i) frames.emplace_back(64, 48, 3, static_cast<uint8_t>(40 * i));
  WriteVideo(File("clip.avi"), frames, 10.0);
  auto a = FrameSource::OpenVideo(File("clip.avi"), 0);
  auto b = FrameSource::OpenVideo(File("clip.avi"), 0);
  ASSERT_EQ(a->NumFrames(), 6);
  EXPECT_NEAR(a->Fps(), 10.0, 1e-6);
  EXPECT_NEAR(a->TimecodeOf(3), 0.3, 1e-9);
  std::vector<Image8> forward;
  for (int i = 0; i < 6; ++i) forward.push_back(a->Read(i).image);
  for (int i : {4, 1, 5, 0, 3, 2}) {
    const DecodedFrame f = b->Read(i);
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_EQ(f.image.data, forward[i].data) << "frame " << i;
  }
  EXPECT_FALSE(b->Read(6).ok);
}

TEST_F(FrameSourceTest, GrayscaleSixteenBitFloatAndAlphaImagesAreConverted) {
  cv::Mat gray16(40, 30, CV_16UC1, cv::Scalar(65535));
  ASSERT_TRUE(cv::imwrite(File("gray16.png"), gray16));
  DecodedFrame f = ReadImageFile(File("gray16.png"), 0);
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_EQ(f.image.channels, 3);
  EXPECT_EQ(f.image.at(5, 5, 1), 255);
  EXPECT_TRUE(f.input_flags & kInputFromGrayscale);
  EXPECT_TRUE(f.input_flags & kInputFrom16Bit);
  cv::Mat rgba(20, 20, CV_8UC4, cv::Scalar(10, 20, 30, 128));  // B, G, R, A
  ASSERT_TRUE(cv::imwrite(File("rgba.png"), rgba));
  f = ReadImageFile(File("rgba.png"), 0);
  ASSERT_TRUE(f.ok);
  EXPECT_EQ(f.image.at(0, 0, 0), 30);  // red first
  EXPECT_TRUE(f.input_flags & kInputDroppedAlpha);
  const float pixels[4] = {0.f, 0.5f, 1.f, 2.f};
  int32_t flags = 0;
  const Image8 converted = ToRgb8(pixels, 4, 1, 1, 32, &flags);
  EXPECT_EQ(converted.at(1, 0), 128);
  EXPECT_EQ(converted.at(3, 0), 255);  // clamped
  EXPECT_TRUE(flags & kInputFromFloat);
}

TEST_F(FrameSourceTest, HugeImagesAreScaledDownAndFlagged) {
  cv::Mat big(2000, 3000, CV_8UC3, cv::Scalar(50, 100, 150));
  ASSERT_TRUE(cv::imwrite(File("big.jpg"), big));
  const DecodedFrame f = ReadImageFile(File("big.jpg"), 600000);
  ASSERT_TRUE(f.ok);
  EXPECT_TRUE(f.input_flags & kInputDownscaled);
  EXPECT_EQ(f.source_width, 3000);
  EXPECT_LE(static_cast<int64_t>(f.image.width) * f.image.height, 600000);
  EXPECT_NEAR(f.source_scale * f.image.width, 3000.0, 3.0);
}

TEST_F(FrameSourceTest, CorruptImagesAreUnreadableFramesAndEmptyFoldersErrors) {
  std::ofstream(File("broken.jpg")) << "\xff\xd8 not really a jpeg";
  const DecodedFrame f = ReadImageFile(File("broken.jpg"), 0);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.error.find("broken.jpg"), std::string::npos);
  fs::create_directories(File("empty"));
  EXPECT_THROW(FrameSource::OpenImages(File("empty"), 0), FileIOError);
  EXPECT_THROW(FrameSource::OpenImages(File("nothere"), 0), FileIOError);
  auto folder = FrameSource::OpenImages(dir_.string(), 0);
  EXPECT_GE(folder->NumFrames(), 1);
  EXPECT_EQ(folder->TimecodeOf(0), -1.0);
}

}  // namespace
}  // namespace facecap::face
