// The readers of ingest outputs (IngestedFrames), tracking outputs (TrackedRig) and rig files
// (io::ReadRigFile) on files that are well-formed but for one thing: each reads or throws a
// FileIOError naming the file, never reads out of bounds or hands on values a stage cannot
// use. The cases are the inputs tests/fuzz found, and the mismatches they stand for.
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/rig_io.h"
#include "rig/rig.h"
#include "stages/ingested_frames.h"
#include "stages/tracked_rig.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The message of the FileIOError that `fn` throws, which must name `path`.
std::string FileErrorOf(const std::string& path, const std::function<void()>& fn) {
  try {
    fn();
  } catch (const FileIOError& e) {
    EXPECT_EQ(e.code(), kExitInput);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no FileIOError for " << path;
  return "";
}

// ---- ingest outputs ---------------------------------------------------------------------------

struct Frames {
  int64_t n = 3;
  int64_t crop = 4;
  std::vector<uint8_t> found = {1, 0, 1};
  std::vector<float> transform;  // 6 per frame
  std::vector<float> landmarks;  // 136 per frame
  std::vector<int32_t> size;
  std::vector<int64_t> index = {0, 2, 4};
  std::vector<double> timecode = {0., 0.08, 0.16};

  Frames() {
    for (int64_t k = 0; k < n; ++k) {
      const float t[6] = {0.25f, 0.01f, -40.f, -0.01f, 0.25f, -30.f};
      for (float x : t) transform.push_back(found[k] ? x : 0.f);
      for (int l = 0; l < 68; ++l) {
        landmarks.push_back(found[k] ? 200.f + l : 0.f);
        landmarks.push_back(found[k] ? 150.f + 0.5f * l : 0.f);
      }
      size.push_back(640);
      size.push_back(480);
    }
  }

  std::string Write(const testing::TempDir& dir, const std::string& name,
                    int64_t crop_width = -1) const {
    const std::string path = dir.File(name);
    io::H5File f = io::H5File::CreateAtomic(path);
    const int64_t w = crop_width < 0 ? crop : crop_width;
    std::vector<uint8_t> crops(n * crop * w * 3, 7);
    f.Write<uint8_t>("/frames/crop", {n, crop, w, 3}, crops.data());
    f.WriteVector("/frames/found", found);
    f.Write<float>("/frames/crop_transform", {n, 2, 3}, transform.data());
    f.Write<float>("/frames/landmarks", {n, 68, 2}, landmarks.data());
    f.Write<int32_t>("/frames/image_size", {n, 2}, size.data());
    f.WriteVector("/frames/source_index", index);
    f.WriteVector("/frames/timecode", timecode);
    f.WriteVector<double>("/camera/fov_deg", {40.});
    f.WriteStrings("/sources/files", {"clip.mp4"});
    f.SetAttribute("/sources/files", "fps", 25.);
    f.Commit();
    return path;
  }
};

TEST(BadReaders, WellFormedFramesRead) {
  testing::TempDir dir;
  const IngestedFrames frames = IngestedFrames::Read(Frames().Write(dir, "frames.h5"));
  ASSERT_EQ(frames.NumFrames(), 3);
  EXPECT_EQ(frames.crop_size(), 4);
  EXPECT_TRUE(frames.Found(0));
  EXPECT_FALSE(frames.Found(1));
  EXPECT_GT(frames.CropCamera(2, 64).camera.fx, 0.f);
  EXPECT_TRUE(frames.CropLandmarks(2, 64).allFinite());
}

// Found by fuzz_frames_h5: a frame with a face whose crop transform is all zeros (here: a
// uint8 dataset that truncated the transform) gave a crop camera of focal length 0.
TEST(BadReaders, FrameWithFaceAndSingularCropTransformIsAnError) {
  testing::TempDir dir;
  Frames frames;
  std::fill(frames.transform.begin(), frames.transform.begin() + 6, 0.f);
  const std::string path = frames.Write(dir, "zero_transform.h5");
  const std::string error = FileErrorOf(path, [&] { IngestedFrames::Read(path); });
  EXPECT_NE(error.find("frame 0 has a face but its /frames/crop_transform"), std::string::npos)
      << error;
}

TEST(BadReaders, FrameWithFaceAndNonFiniteValuesIsAnError) {
  testing::TempDir dir;
  {
    Frames frames;
    frames.transform[6 * 2 + 2] = kNaN;
    const std::string path = frames.Write(dir, "nan_transform.h5");
    FileErrorOf(path, [&] { IngestedFrames::Read(path); });
  }
  {
    Frames frames;
    frames.landmarks[136 * 2 + 17] = std::numeric_limits<float>::infinity();
    const std::string path = frames.Write(dir, "inf_landmark.h5");
    const std::string error = FileErrorOf(path, [&] { IngestedFrames::Read(path); });
    EXPECT_NE(error.find("frame 2 has a face but landmarks"), std::string::npos) << error;
  }
  {
    Frames frames;
    frames.timecode[1] = std::nan("");
    const std::string path = frames.Write(dir, "nan_timecode.h5");
    FileErrorOf(path, [&] { IngestedFrames::Read(path); });
  }
  {
    Frames frames;
    frames.index[1] = -1;
    const std::string path = frames.Write(dir, "negative_index.h5");
    FileErrorOf(path, [&] { IngestedFrames::Read(path); });
  }
}

// Crops of 0 pixels (crop size 0 divided the crop landmarks) and crops that are not square
// (taken as crop_size = width) are errors.
TEST(BadReaders, EmptyOrNonSquareCropsAreAnError) {
  testing::TempDir dir;
  Frames no_pixels;
  no_pixels.crop = 0;
  const std::string empty = no_pixels.Write(dir, "empty_crops.h5");
  FileErrorOf(empty, [&] { IngestedFrames::Read(empty); });
  const std::string wide = Frames().Write(dir, "wide_crops.h5", 6);
  const std::string error = FileErrorOf(wide, [&] { IngestedFrames::Read(wide); });
  EXPECT_NE(error.find("[3, 4, 6, 3]"), std::string::npos) << error;
}

// ---- tracking outputs -------------------------------------------------------------------------

// A tetrahedron rig with the shapes jawOpen, eyeBlinkLeft and mouthSmileLeft.
rig::Rig SmallRig() {
  rig::Rig r;
  r.neutral.resize(4, 3);
  r.neutral << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  r.triangles.resize(4, 3);
  r.triangles << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  r.regions = {{"skin", Eigen::Vector3f(0.8f, 0.6f, 0.5f)}};
  r.triangle_region = Eigen::VectorXi::Zero(4);
  r.jaw_weights = Eigen::VectorXf::Zero(4);
  for (const char* name : {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft"}) {
    rig::Shape shape;
    shape.name = name;
    shape.delta.vertex = {3};
    shape.delta.offset = {Eigen::Vector3f(0.f, 0.1f, 0.f)};
    r.shapes.push_back(shape);
  }
  std::string why;
  EXPECT_TRUE(r.Check(&why)) << why;
  return r;
}

struct Track {
  int64_t n = 3;
  std::vector<std::string> names = {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft", "browInnerUp"};
  Eigen::MatrixXf pose = Eigen::MatrixXf::Constant(3, 3, 0.1f);
  Eigen::MatrixXf translation = Eigen::MatrixXf::Constant(3, 3, -60.f);
  std::vector<float> scale = {1.f, 1.f, 1.f};
  Eigen::MatrixXf weights = Eigen::MatrixXf::Constant(3, 4, 0.5f);
  std::vector<double> intrinsics = {800., 800., 320., 240.};
  double width = 640.;

  std::string Write(const testing::TempDir& dir, const std::string& name,
                    const std::function<void(io::H5File*)>& change = nullptr) const {
    const std::string path = dir.File(name);
    io::H5File f = io::H5File::CreateAtomic(path);
    f.WriteStrings("/track/shape_names", names);
    f.WriteMatrix("/track/pose", pose);
    f.WriteMatrix("/track/translation", translation);
    f.WriteVector("/track/scale", scale);
    f.WriteMatrix("/track/weights", weights);
    f.WriteVector<int32_t>("/track/termination", std::vector<int32_t>(n, 0));
    f.WriteVector<double>("/camera/intrinsics", intrinsics);
    f.SetAttribute("/camera/intrinsics", "width", width);
    if (change) change(&f);
    f.Commit();
    return path;
  }
};

TEST(BadReaders, WellFormedTrackReads) {
  testing::TempDir dir;
  const rig::Rig rig = SmallRig();
  const TrackedRig track(Track().Write(dir, "track.h5"), rig);
  ASSERT_EQ(track.NumFrames(), 3);
  EXPECT_EQ(track.Weights(2).size(), 3);
  EXPECT_FLOAT_EQ(track.Weights(2)[1], 0.5f);
  EXPECT_FLOAT_EQ(track.CameraForWidth(320, 240).fx, 400.f);
}

// Found by fuzz_track_h5: a scalar /track/pose (rank 0) made the frame count the first
// element of an empty shape: a read through a null pointer.
TEST(BadReaders, ScalarPoseIsAnError) {
  testing::TempDir dir;
  const std::string path = Track().Write(dir, "scalar_pose.h5", [](io::H5File* f) {
    const float one = 1.f;
    f->Write<float>("/track/pose", {}, &one);
  });
  const std::string error = FileErrorOf(path, [&] { (void)TrackedRig(path, SmallRig()); });
  EXPECT_NE(error.find("/track/pose"), std::string::npos) << error;
}

// Weights with 51 columns for 52 shape names (here 3 for 4) are a mismatch, not a stride.
TEST(BadReaders, WeightsColumnsDifferingFromShapeNamesAreAnError) {
  testing::TempDir dir;
  Track track;
  track.weights = Eigen::MatrixXf::Constant(3, 3, 0.5f);
  const std::string path = track.Write(dir, "weights_51_of_52.h5");
  const std::string error = FileErrorOf(path, [&] { (void)TrackedRig(path, SmallRig()); });
  EXPECT_NE(error.find("/track/weights has shape [3, 3], expected [3, 4]"), std::string::npos)
      << error;
  Track rows;
  rows.scale = {1.f, 1.f};
  const std::string short_scale = rows.Write(dir, "scale_2_of_3.h5");
  FileErrorOf(short_scale, [&] { (void)TrackedRig(short_scale, SmallRig()); });
}

TEST(BadReaders, TrackNamingAShapeTwiceIsAnError) {
  testing::TempDir dir;
  Track track;
  track.names[3] = "jawOpen";
  const std::string path = track.Write(dir, "twice.h5");
  const std::string error = FileErrorOf(path, [&] { (void)TrackedRig(path, SmallRig()); });
  EXPECT_NE(error.find("'jawOpen' twice"), std::string::npos) << error;
}

TEST(BadReaders, TrackWithUnusableValuesIsAnError) {
  testing::TempDir dir;
  std::vector<std::pair<std::string, Track>> cases;
  Track t;
  t.pose(1, 2) = kNaN;
  cases.emplace_back("nan_pose.h5", t);
  t = Track();
  t.weights(2, 0) = std::numeric_limits<float>::infinity();
  cases.emplace_back("inf_weight.h5", t);
  t = Track();
  t.scale[0] = 0.f;
  cases.emplace_back("zero_scale.h5", t);
  t = Track();
  t.intrinsics[0] = std::nan("");
  cases.emplace_back("nan_focal.h5", t);
  t = Track();
  t.intrinsics[1] = -800.;
  cases.emplace_back("negative_focal.h5", t);
  t = Track();
  t.width = 0.;
  cases.emplace_back("zero_width.h5", t);
  for (const auto& [name, track] : cases) {
    const std::string path = track.Write(dir, name);
    FileErrorOf(path, [&] { (void)TrackedRig(path, SmallRig()); });
  }
  const std::string index = Track().Write(dir, "negative_index.h5", [](io::H5File* f) {
    f->WriteVector<int64_t>("/track/source_index", {0, -3, 6});
    f->WriteVector<double>("/track/timecode", {0., 0.1, 0.2});
  });
  FileErrorOf(index, [&] { (void)TrackedRig(index, SmallRig()); });
}

// ---- rig files --------------------------------------------------------------------------------

TEST(BadReaders, RigWithInconsistentDeltasIsAnError) {
  testing::TempDir dir;
  const rig::Rig rig = SmallRig();
  const auto write = [&](const std::string& name, const std::function<void(io::H5File*)>& change) {
    const std::string path = dir.File(name);
    io::H5File f = io::H5File::CreateAtomic(path);
    io::WriteRig(rig, &f);
    change(&f);
    f.Commit();
    return path;
  };
  EXPECT_EQ(io::ReadRigFile(write("rig.h5", [](io::H5File*) {})).NumShapes(), 3);
  const std::string offsets = write("offsets.h5", [](io::H5File* f) {
    f->WriteVector<int64_t>("/rig/shapes/deltas/row_offsets", {0, 1, 5, 3});
  });
  FileErrorOf(offsets, [&] { io::ReadRigFile(offsets); });
  const std::string vertex = write("vertex.h5", [](io::H5File* f) {
    f->WriteVector<int32_t>("/rig/shapes/deltas/vertex", {3, 3, 7});
  });
  FileErrorOf(vertex, [&] { io::ReadRigFile(vertex); });
  const std::string names = write("names.h5", [](io::H5File* f) {
    f->WriteStrings("/rig/shapes/names", {"jawOpen", "eyeBlinkLeft"});
  });
  FileErrorOf(names, [&] { io::ReadRigFile(names); });
}

}  // namespace
}  // namespace facecap::stages
