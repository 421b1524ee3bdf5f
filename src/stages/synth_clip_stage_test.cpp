// facecap synth clip and synth sheet end to end: rank-count independence, a killed run that
// continues to the uninterrupted result, the stored truth, the video and the contact sheet,
// and clear errors for bad options.
#include <cmath>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/image_io.h"
#include "stages/rig_stage.h"
#include "stages/synth_clip_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

const char* const kByteDatasets[] = {"/frames/image", "/frames/segmentation",
                                     "/frames/landmark_visible"};
const char* const kFloatDatasets[] = {"/frames/pose", "/frames/translation", "/frames/weights",
                                      "/frames/landmarks", "/frames/degradation"};

class SynthClip : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.num_identity_modes = 8;
    demo_rig.out = Rig();
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Rig() { return dir_->File("rig.h5"); }
  static std::string Args(const std::string& out, int frames = 16) {
    return "synth clip --rig " + Rig() + " --frames " + std::to_string(frames) +
           " --size 40 --texture-size 128 --batch 2 --identity-seed 3 --out " + out;
  }
  // The options of Args, for a run in this process.
  static SynthClipOptions ClipOptions(const std::string& out, int frames = 16) {
    SynthClipOptions o;
    o.rig = Rig();
    o.clip.frames = frames;
    o.clip.size = 40;
    o.clip.texture.texture_size = 128;
    o.batch = 2;
    o.clip.identity_seed = 3;
    o.out = out;
    return o;
  }
  // The clip of Args made by one uninterrupted run on one rank (made once, shared).
  static std::string Reference() {
    const std::string path = dir_->File("reference.h5");
    if (!std::filesystem::exists(path)) RunInProcess(RunSynthClip, ClipOptions(path), "synth.clip");
    return path;
  }
  static void ExpectSameDatasets(const std::string& a, const std::string& b) {
    io::H5File fa = io::H5File::OpenRead(a), fb = io::H5File::OpenRead(b);
    for (const char* name : kByteDatasets) {
      EXPECT_EQ(fa.Read<uint8_t>(name, {}), fb.Read<uint8_t>(name, {})) << name << " differs";
    }
    for (const char* name : kFloatDatasets) {
      const auto va = fa.Read<float>(name, {}), vb = fb.Read<float>(name, {});
      ASSERT_EQ(va.size(), vb.size()) << name;
      EXPECT_EQ(std::memcmp(va.data(), vb.data(), va.size() * sizeof(float)), 0) << name << " differs";
    }
  }
  static testing::TempDir* dir_;
};

testing::TempDir* SynthClip::dir_ = nullptr;

TEST_F(SynthClip, OneAndThreeRanksWriteIdenticalClips) {
  const std::string three = dir_->File("three.h5");
  auto r3 = RunFacecap(Args(three), 3);
  ASSERT_EQ(r3.code, 0) << r3.output;
  ExpectSameDatasets(Reference(), three);

  io::H5File f = io::H5File::OpenRead(three);
  EXPECT_EQ(f.GetIntAttribute("/", "mpi_ranks"), 3);
  EXPECT_EQ(f.DatasetShape("/frames/image"), (io::Shape{16, 40, 40, 3}));
  EXPECT_EQ(f.DatasetShape("/frames/landmarks"), (io::Shape{16, 68, 2}));
  const auto names = f.ReadStrings("/frames/shape_names");
  EXPECT_EQ(f.DatasetShape("/frames/weights"), (io::Shape{16, static_cast<int64_t>(names.size())}));
  EXPECT_EQ(f.ReadVector<int>("/identity/seed"), std::vector<int>{3});
  EXPECT_EQ(f.ReadVector<float>("/identity/coefficients").size(), 8u);
  EXPECT_EQ(f.ReadVector<double>("/camera/intrinsics").size(), 4u);
  // The person's own rig: not the mean face.
  io::H5File mean = io::H5File::OpenRead(Rig());
  EXPECT_NE(f.Read<float>("/rig/neutral", {}), mean.Read<float>("/rig/neutral", {}));

  // The wild frames are not the segmentation renders: other colours on the face, and a
  // background where the segmentation is black.
  const auto image = f.Read<uint8_t>("/frames/image", {}), seg = f.Read<uint8_t>("/frames/segmentation", {});
  double difference = 0.0, background = 0.0;
  int64_t face = 0, outside = 0;
  for (size_t p = 0; p < image.size(); p += 3) {
    const bool covered = seg[p] || seg[p + 1] || seg[p + 2];
    for (int c = 0; c < 3; ++c) {
      if (covered) difference += std::abs(int(image[p + c]) - int(seg[p + c]));
      else background += image[p + c];
    }
    (covered ? face : outside) += 1;
  }
  ASSERT_GT(face, 0);
  ASSERT_GT(outside, 0);
  EXPECT_GT(difference / (3.0 * face), 20.0);
  EXPECT_GT(background / (3.0 * outside), 10.0);
}

TEST_F(SynthClip, KilledRunContinuesToTheUninterruptedResult) {
  const std::string killed = dir_->File("killed.h5");
  auto crash = RunFacecap(Args(killed), 0, "FACECAP_FAULT_AFTER_FRAMES=6 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  EXPECT_FALSE(std::filesystem::exists(killed));
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap(Args(killed), 2);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  ExpectSameDatasets(Reference(), killed);
}

TEST_F(SynthClip, ScriptedClipVideoAndSheet) {
  const std::string out = dir_->File("scripted.h5"), sheet = dir_->File("sheet.png");
  SynthClipOptions o = ClipOptions(out);
  o.video = true;
  o.clip.keyframes = {"0 yaw_deg=-30", "0.3 yaw_deg=40 jawOpen=1"};
  RunInProcess(RunSynthClip, o, "synth.clip");
  io::H5File f = io::H5File::OpenRead(out);
  const auto pose = f.ReadMatrix<float>("/frames/pose", 16, 3);
  EXPECT_NEAR(pose(0, 1), -30.f * M_PI / 180.f, 1e-5f);
  EXPECT_NEAR(pose(15, 1), 40.f * M_PI / 180.f, 1e-5f);
  const std::string video = dir_->File("scripted.mp4");
  ASSERT_TRUE(std::filesystem::exists(video));
  EXPECT_GT(std::filesystem::file_size(video), 1000u);

  SynthSheetOptions s;
  s.clip = out;
  s.out = sheet;
  s.frames = 5;
  s.pairs_per_row = 3;
  s.scale = 2;
  RunInProcess(RunSynthSheet, s, "synth.sheet");
  const Image8 image = io::ReadImage8(sheet);
  // 2 rows of 3 pairs of 80-pixel tiles with 2-pixel borders.
  EXPECT_EQ(image.width, 6 * 80 + 7 * 2);
  EXPECT_EQ(image.height, 2 * 80 + 3 * 2);
}

TEST_F(SynthClip, BadOptionsAreUsageErrors) {
  const std::string out = dir_->File("bad.h5");
  auto negative = RunFacecap(Args(out, -5));
  EXPECT_EQ(negative.code, kExitUsage);
  EXPECT_NE(negative.output.find("frames must be positive"), std::string::npos) << negative.output;
  // (Range checks of every option are unit-tested in synth/clip_test.cpp.)
  SynthClipOptions shape = ClipOptions(out);
  shape.clip.keyframes = {"0 grin=1"};
  try {
    RunInProcess(RunSynthClip, shape, "synth.clip");
    ADD_FAILURE() << "keyframe shape 'grin' was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'grin' is neither a shape"), std::string::npos) << e.what();
  }
  auto folder = RunFacecap(Args(out) + " --background-folder " + dir_->File("no_such_folder"));
  EXPECT_EQ(folder.code, kExitInput);
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(SynthClip, BackgroundPhotosComeFromTheFolder) {
  const std::string photos = dir_->File("photos");
  std::filesystem::create_directories(photos);
  Image8 stripes(64, 48, 3);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      stripes.at(x, y, 0) = (x / 8) % 2 ? 250 : 10;
      stripes.at(x, y, 1) = 10;
      stripes.at(x, y, 2) = (x / 8) % 2 ? 10 : 250;
    }
  }
  io::WriteImage(photos + "/wall.png", stripes);
  const std::string out = dir_->File("photo.h5");
  SynthClipOptions o = ClipOptions(out, 2);
  o.background_folder = photos;
  RunInProcess(RunSynthClip, o, "synth.clip");
  io::H5File f = io::H5File::OpenRead(out);
  const auto image = f.Read<uint8_t>("/frames/image", {});
  // The corner shows the photo's saturated red or blue, not a muted procedural colour.
  const int r0 = image[0], g0 = image[1], b0 = image[2];
  EXPECT_GT(std::max(r0, b0) - g0, 60) << r0 << " " << g0 << " " << b0;
}

}  // namespace
}  // namespace facecap::stages
