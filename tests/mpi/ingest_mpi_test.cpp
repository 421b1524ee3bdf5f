// facecap ingest gives the same frames.h5 on any number of ranks: the world communicator's
// run is compared, dataset by dataset, with a single-rank run of the same clip. The clip is a
// camera move over a real photo that ships in a Debian package (python-matplotlib-data),
// with frames without a face between, and the same for a folder of stills.
#include <filesystem>

#include <gtest/gtest.h>

#include "dist/comm.h"
#include "face/frame_source.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "stages/ingest_stage.h"
#include "testing/testing.h"

namespace facecap {
namespace {

constexpr const char* kRealPhoto = "/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg";

template <typename T>
void ExpectSameDataset(const io::H5File& a, const io::H5File& b, const std::string& name) {
  io::Shape sa, sb;
  const std::vector<T> va = a.Read<T>(name, {}, &sa);
  const std::vector<T> vb = b.Read<T>(name, {}, &sb);
  EXPECT_EQ(sa, sb) << name;
  EXPECT_TRUE(va == vb) << name << " differs between rank counts";
}

TEST(IngestMpiTest, SameOutputForAnyNumberOfRanks) {
  const dist::Comm world = dist::Comm::World();
  std::string dir;
  std::unique_ptr<testing::TempDir> temp;
  int ok = 1;
  if (world.IsMainRank()) {
    temp = std::make_unique<testing::TempDir>();
    dir = temp->path();
    face::DecodedFrame photo = face::ReadImageFile(kRealPhoto, 0);
    if (!photo.ok) {
      ADD_FAILURE() << kRealPhoto << " is missing: install python-matplotlib-data (./setup.sh does)";
      ok = 0;
    } else {
      std::vector<Image8> frames = face::CameraMoveClip(photo.image, 320, 240, 10);
      frames.insert(frames.begin() + 4, Image8(320, 240, 3, 90));  // no face
      frames.emplace_back(320, 240, 3, 200);                      // no face
      face::WriteVideo(dir + "/clip.avi", frames, 25.0);
    }
  }
  world.Broadcast(&ok, sizeof(ok));
  if (!ok) return;
  world.Broadcast(&dir);

  stages::IngestOptions o;
  o.video = dir + "/clip.avi";
  o.batch = 2;  // several rounds, so ranks seek into the clip
  o.threads = 1;
  o.crop_size = 64;
  o.detect_max_side = 0;
  o.out = dir + "/ranks.h5";
  io::Config resolved;
  io::StoreOptions(o, "ingest", &resolved);
  stages::StageContext ctx;
  ctx.comm = world;
  ctx.command_line = "ingest mpi test";
  const stages::IngestSummary summary = stages::RunIngest(o, ctx, resolved);
  if (!world.IsMainRank()) return;
  EXPECT_EQ(summary.frames, 12);
  EXPECT_GE(summary.found, 9);
  EXPECT_EQ(summary.no_face, 12 - summary.found);

  o.out = dir + "/single.h5";
  stages::StageContext single;
  single.comm = dist::Comm::Single();
  stages::RunIngest(o, single, resolved);

  const io::H5File a = io::H5File::OpenRead(dir + "/ranks.h5");
  const io::H5File b = io::H5File::OpenRead(dir + "/single.h5");
  for (const char* name : {"/frames/status", "/frames/image_size", "/frames/input_flags",
                           "/detections/count", "/frames/source_file_id"}) {
    ExpectSameDataset<int32_t>(a, b, name);
  }
  for (const char* name : {"/frames/box", "/frames/landmarks", "/frames/landmarks_crop",
                           "/frames/crop_transform", "/detections/boxes"}) {
    ExpectSameDataset<float>(a, b, name);
  }
  ExpectSameDataset<uint8_t>(a, b, "/frames/crop");
  ExpectSameDataset<uint8_t>(a, b, "/frames/found");
  ExpectSameDataset<int64_t>(a, b, "/frames/source_index");
  ExpectSameDataset<double>(a, b, "/frames/timecode");
  EXPECT_EQ(a.GetIntAttribute("/", "mpi_ranks"), world.size());
}

TEST(IngestMpiTest, ImageFolderGivesTheSameOutputForAnyNumberOfRanks) {
  const dist::Comm world = dist::Comm::World();
  std::string dir;
  std::unique_ptr<testing::TempDir> temp;
  int ok = 1;
  if (world.IsMainRank()) {
    temp = std::make_unique<testing::TempDir>();
    dir = temp->path();
    face::DecodedFrame photo = face::ReadImageFile(kRealPhoto, 0);
    ok = photo.ok ? 1 : 0;
    if (ok) {
      std::filesystem::create_directories(dir + "/stills");
      std::vector<Image8> frames = face::CameraMoveClip(photo.image, 320, 240, 6);
      frames.emplace_back(320, 240, 3, 90);  // no face
      for (size_t k = 0; k < frames.size(); ++k) {
        io::WriteImage(dir + "/stills/" + std::to_string(100 + k) + ".png", frames[k]);
      }
    }
  }
  world.Broadcast(&ok, sizeof(ok));
  if (!ok) return;
  world.Broadcast(&dir);
  stages::IngestOptions o;
  o.images = dir + "/stills";
  o.batch = 2;
  o.threads = 1;
  o.crop_size = 64;
  o.out = dir + "/ranks.h5";
  io::Config resolved;
  io::StoreOptions(o, "ingest", &resolved);
  stages::StageContext ctx;
  ctx.comm = world;
  const stages::IngestSummary summary = stages::RunIngest(o, ctx, resolved);
  if (!world.IsMainRank()) return;
  EXPECT_EQ(summary.frames, 7);
  EXPECT_EQ(summary.subject_absent, 0);
  o.out = dir + "/single.h5";
  stages::StageContext single;
  single.comm = dist::Comm::Single();
  stages::RunIngest(o, single, resolved);
  const io::H5File a = io::H5File::OpenRead(dir + "/ranks.h5");
  const io::H5File b = io::H5File::OpenRead(dir + "/single.h5");
  ExpectSameDataset<int32_t>(a, b, "/frames/status");
  for (const char* name : {"/frames/box", "/frames/landmarks"}) ExpectSameDataset<float>(a, b, name);
  ExpectSameDataset<uint8_t>(a, b, "/frames/crop");
}

}  // namespace
}  // namespace facecap
