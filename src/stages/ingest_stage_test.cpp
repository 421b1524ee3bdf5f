// facecap ingest end to end on a real face (the portrait of Grace Hopper in Debian's
// python-matplotlib-data, datasets/README.md): a killed run continues to the uninterrupted
// result, an image folder is accounted image by image (each image on its own: no subject is
// followed across unrelated stills), small faces are found and recorded as too small, and a
// folder without any face is exit code 3 after the accounting is written.
#include <algorithm>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "face/frame_source.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "stages/ingest_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

constexpr const char* kRealPhoto = "/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg";

// `photo` resized (bilinear) to `width` pixels wide, pasted at (x, y) on a `canvas_w` x
// `canvas_h` canvas of grey `grey`.
Image8 Paste(const Image8& photo, int width, int x, int y, int canvas_w, int canvas_h, uint8_t grey = 110) {
  Image8 out(canvas_w, canvas_h, 3, grey);
  const int height = width * photo.height / photo.width;
  const double s = static_cast<double>(photo.width) / width;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      if (x + u < 0 || x + u >= canvas_w || y + v < 0 || y + v >= canvas_h) continue;
      const double sx = std::min((u + 0.5) * s - 0.5, photo.width - 1.001);
      const double sy = std::min((v + 0.5) * s - 0.5, photo.height - 1.001);
      const int x0 = std::max(0, static_cast<int>(sx)), y0 = std::max(0, static_cast<int>(sy));
      const double fx = std::max(0.0, sx - x0), fy = std::max(0.0, sy - y0);
      for (int c = 0; c < 3; ++c) {
        const double value = (1 - fx) * (1 - fy) * photo.at(x0, y0, c) + fx * (1 - fy) * photo.at(x0 + 1, y0, c) +
                             (1 - fx) * fy * photo.at(x0, y0 + 1, c) + fx * fy * photo.at(x0 + 1, y0 + 1, c);
        out.at(x + u, y + v, c) = static_cast<uint8_t>(std::lround(value));
      }
    }
  }
  return out;
}

class Ingest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    face::DecodedFrame d = face::ReadImageFile(kRealPhoto, 0);
    ASSERT_TRUE(d.ok) << kRealPhoto << " is missing: install python-matplotlib-data (./setup.sh does)";
    photo_ = new Image8(std::move(d.image));
  }
  static void TearDownTestSuite() {
    delete photo_;
    delete dir_;
  }
  static std::vector<int32_t> Status(const std::string& path) {
    return io::H5File::OpenRead(path).ReadVector<int32_t>("/frames/status");
  }
  static testing::TempDir* dir_;
  static Image8* photo_;
};

testing::TempDir* Ingest::dir_ = nullptr;
Image8* Ingest::photo_ = nullptr;

TEST_F(Ingest, KilledRunContinuesToTheUninterruptedResult) {
  std::vector<Image8> frames = face::CameraMoveClip(*photo_, 320, 240, 12);
  frames.insert(frames.begin() + 7, Image8(320, 240, 3, 90));  // no face
  const std::string video = dir_->File("clip.avi");
  face::WriteVideo(video, frames, 25.0);
  const std::string straight = dir_->File("straight.h5"), killed = dir_->File("killed.h5");
  const std::string args = " --video " + video + " --batch 3 --crop-size 64 --threads 1";
  IngestOptions o;
  o.video = video;
  o.batch = 3;
  o.crop_size = 64;
  o.threads = 1;
  o.out = straight;
  RunInProcess(RunIngest, o, "ingest");

  auto crash = RunFacecap("ingest --out " + killed + args, 0,
                          "FACECAP_FAULT_AFTER_FRAMES=6 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  EXPECT_FALSE(std::filesystem::exists(killed));
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap("ingest --out " + killed + args);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;

  const io::H5File a = io::H5File::OpenRead(straight), b = io::H5File::OpenRead(killed);
  for (const char* name : {"/frames/status", "/detections/count", "/frames/image_size"}) {
    EXPECT_EQ(a.Read<int32_t>(name, {}), b.Read<int32_t>(name, {})) << name;
  }
  for (const char* name : {"/frames/landmarks", "/frames/box", "/detections/boxes"}) {
    EXPECT_EQ(a.Read<float>(name, {}), b.Read<float>(name, {})) << name;
  }
  EXPECT_EQ(a.Read<uint8_t>("/frames/crop", {}), b.Read<uint8_t>("/frames/crop", {}));
  const std::vector<int32_t> status = a.ReadVector<int32_t>("/frames/status");
  ASSERT_EQ(status.size(), 13u);
  EXPECT_EQ(status[7], kFrameNoFace);
  EXPECT_GE(std::count(status.begin(), status.end(), kFrameFound), 11);

  // A rerun of a finished output does nothing.
  auto again = RunFacecap("ingest --out " + killed + args);
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("up to date"), std::string::npos) << again.output;
}

TEST_F(Ingest, ImageFolderIsAccountedImageByImage) {
  const std::string folder = dir_->File("stills");
  std::filesystem::create_directories(folder);
  // Sorted by name: what each file is, and the status it must get.
  io::WriteImage(folder + "/a_portrait.jpg", *photo_);                                 // found
  // A large still with the face far from where the first image had it: an unrelated image,
  // not a frame where "the subject" is absent. Over the pixel budget: scaled down.
  io::WriteImage(folder + "/b_large.png", Paste(*photo_, 900, 1400, 1600, 2600, 3000));  // found
  io::WriteImage(folder + "/c_flat.png", Image8(320, 240, 3, 128));                     // no_face
  {
    std::ofstream broken(folder + "/d_broken.jpg");
    broken << "not a jpeg";                                                              // unreadable
  }
  Image8 gray(photo_->width, photo_->height, 1);
  for (int y = 0; y < photo_->height; ++y)
    for (int x = 0; x < photo_->width; ++x) gray.at(x, y) = photo_->at(x, y, 1);
  io::WriteImage(folder + "/e_gray.png", gray);                                          // found
  // A 640 x 480 frame with a face of about 50 px: below the first detection scale (about
  // 107 px at 640 x 480), found by the small-face search, narrower than min_face_size 64.
  io::WriteImage(folder + "/f_small.png", Paste(*photo_, 120, 300, 200, 640, 480));      // too small
  {
    std::ofstream notes(folder + "/notes.txt");
    notes << "not an image: skipped";
  }
  const std::string out = dir_->File("stills.h5");
  auto r = RunFacecap("ingest --images " + folder + " --out " + out +
                      " --max-image-pixels 4000000 --crop-size 64");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::vector<int32_t> status = Status(out);
  const std::vector<int32_t> expected = {kFrameFound, kFrameFound, kFrameNoFace, kFrameUnreadable,
                                         kFrameFound, kFrameFaceTooSmall};
  EXPECT_EQ(status, expected) << r.output;
  const io::H5File f = io::H5File::OpenRead(out);
  const std::vector<int32_t> flags = f.ReadVector<int32_t>("/frames/input_flags");
  ASSERT_EQ(flags.size(), 6u);
  EXPECT_TRUE(flags[1] & face::kInputDownscaled);
  EXPECT_TRUE(flags[4] & face::kInputFromGrayscale);
  EXPECT_EQ(f.GetIntAttribute("/frames", "num_found"), 3);
  EXPECT_EQ(f.GetIntAttribute("/frames", "num_face_too_small"), 1);
  EXPECT_EQ(f.GetIntAttribute("/frames", "num_no_face"), 1);
  EXPECT_EQ(f.GetIntAttribute("/frames", "num_unreadable"), 1);
  EXPECT_EQ(f.GetIntAttribute("/frames", "num_subject_absent"), 0);
  // The large still's face in source pixels, where it was pasted.
  const auto box = f.ReadMatrix<float>("/frames/box", 6, 5);
  EXPECT_GT(box(1, 0), 1400.f);
  EXPECT_GT(box(1, 1), 1600.f);
  EXPECT_LT(box(5, 2), 64.f);
  EXPECT_GT(box(5, 2), 30.f);
  EXPECT_NE(r.output.find("1 with a face too small"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("are not found"), std::string::npos) << r.output;

  // Without the small-face search the small face is not seen at all.
  const std::string plain = dir_->File("stills_plain.h5");
  IngestOptions o;
  o.images = folder;
  o.out = plain;
  o.max_image_pixels = 4000000;
  o.crop_size = 64;
  o.detect_small_max_side = 0;
  RunInProcess(RunIngest, o, "ingest");
  EXPECT_EQ(Status(plain)[5], kFrameNoFace);
}

// A failed ingest leaves nothing under the final name (a job would take it as done): the
// per-frame accounting stays in the .partial file, and a rerun fails the same way.
TEST_F(Ingest, FolderWithoutAFaceKeepsTheAccountingInThePartialAndExits3) {
  const std::string folder = dir_->File("empty_faces");
  std::filesystem::create_directories(folder);
  io::WriteImage(folder + "/a.png", Image8(200, 150, 3, 40));
  io::WriteImage(folder + "/b.png", Image8(200, 150, 3, 220));
  const std::string out = dir_->File("none.h5");
  IngestOptions o;
  o.images = folder;
  o.out = out;
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      RunInProcess(RunIngest, o, "ingest");
      ADD_FAILURE() << "ingest of a folder without a face succeeded";
    } catch (const FileIOError& e) {  // exit code 3
      EXPECT_NE(std::string(e.what()).find("nothing was written to " + out), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(out));
    ASSERT_TRUE(std::filesystem::exists(io::H5File::PartialPath(out)));
  }
  io::H5File partial = io::H5File::OpenRead(io::H5File::PartialPath(out));
  EXPECT_EQ(partial.ReadVector<int32_t>("/frames/status"),
            (std::vector<int32_t>{kFrameNoFace, kFrameNoFace}));

  auto missing = RunFacecap("ingest --images " + dir_->File("no_such_folder") + " --out " + dir_->File("x.h5"));
  EXPECT_EQ(missing.code, 3) << missing.output;
}

}  // namespace
}  // namespace facecap::stages
