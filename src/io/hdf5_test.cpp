#include "io/hdf5.h"

#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <hdf5.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

TEST(H5File, MatrixRoundTripKeepsValuesAndShape) {
  testing::TempDir dir;
  const std::string path = dir.File("m.h5");
  Eigen::MatrixXf m = Eigen::MatrixXf::Random(7, 3);
  Eigen::Matrix<int32_t, Eigen::Dynamic, Eigen::Dynamic> mi(2, 5);
  mi << 1, 2, 3, 4, 5, 6, 7, 8, 9, 10;
  {
    H5File f = H5File::CreateAtomic(path);
    f.WriteMatrix("/a/b/matrix", m);
    f.WriteMatrix("/ints", mi);
    f.WriteStrings("/names", {"jawOpen", "", "eyeBlinkLeft"});
    f.SetAttribute("/a/b/matrix", "units", std::string("cm"));
    f.SetAttribute("/", "count", int64_t{42});
    f.SetAttribute("/", "scale", 0.25);
    f.Commit();
  }
  H5File f = H5File::OpenRead(path);
  auto back = f.ReadMatrix<float>("/a/b/matrix", 7, 3);
  EXPECT_TRUE(back.isApprox(m, 0.f));
  auto backi = f.ReadMatrix<int32_t>("/ints");
  EXPECT_EQ(backi(1, 4), 10);
  EXPECT_EQ(backi(0, 1), 2);
  EXPECT_EQ(f.ReadStrings("/names"), (std::vector<std::string>{"jawOpen", "", "eyeBlinkLeft"}));
  EXPECT_EQ(f.GetStringAttribute("/a/b/matrix", "units"), "cm");
  EXPECT_EQ(f.GetIntAttribute("/", "count"), 42);
  EXPECT_DOUBLE_EQ(f.GetDoubleAttribute("/", "scale"), 0.25);
}

TEST(H5File, AtomicFileAppearsOnlyAfterCommit) {
  testing::TempDir dir;
  const std::string path = dir.File("out.h5");
  H5File f = H5File::CreateAtomic(path);
  f.WriteVector<float>("/x", {1.f, 2.f});
  f.Flush();
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::exists(H5File::PartialPath(path)));
  f.Commit();
  EXPECT_TRUE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(H5File::PartialPath(path)));
}

TEST(H5File, WrongShapeNamesFileDatasetAndExpectation) {
  testing::TempDir dir;
  const std::string path = dir.File("s.h5");
  {
    H5File f = H5File::CreateAtomic(path);
    f.WriteMatrix("/rig/neutral", Eigen::MatrixXf::Zero(10, 4));
    f.Commit();
  }
  H5File f = H5File::OpenRead(path);
  try {
    f.ReadMatrix<float>("/rig/neutral", -1, 3);
    FAIL() << "expected FileIOError";
  } catch (const FileIOError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find("/rig/neutral"), std::string::npos) << msg;
    EXPECT_NE(msg.find("[10, 4]"), std::string::npos) << msg;
    EXPECT_NE(msg.find("[*, 3]"), std::string::npos) << msg;
    EXPECT_EQ(e.code(), kExitInput);
  }
  EXPECT_THROW(f.ReadMatrix<float>("/rig/missing"), FileIOError);
  EXPECT_THROW(f.ReadMatrix<float>("/nogroup/x"), FileIOError);
}

TEST(H5File, TruncatedFileGivesClearError) {
  testing::TempDir dir;
  const std::string path = dir.File("t.h5");
  {
    H5File f = H5File::CreateAtomic(path);
    f.WriteMatrix("/big", Eigen::MatrixXf::Random(2000, 300));
    f.Commit();
  }
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size / 2);
  try {
    H5File f = H5File::OpenRead(path);
    f.ReadMatrix<float>("/big");
    FAIL() << "expected FileIOError";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  // Not HDF5 at all.
  std::ofstream(dir.File("text.h5")) << "hello";
  EXPECT_THROW(H5File::OpenRead(dir.File("text.h5")), FileIOError);
  EXPECT_THROW(H5File::OpenRead(dir.File("absent.h5")), FileIOError);
}

TEST(H5File, FrameDatasetsGrowAndReadBack) {
  testing::TempDir dir;
  H5File f = H5File::CreateAtomic(dir.File("f.h5"));
  f.CreateFrames<uint8_t>("/frames/image", {4, 5, 3}, 0, 2);
  std::vector<uint8_t> frames(3 * 60);
  for (size_t i = 0; i < frames.size(); ++i) frames[i] = static_cast<uint8_t>(i % 251);
  f.WriteFrames<uint8_t>("/frames/image", 0, 2, frames.data());
  f.WriteFrames<uint8_t>("/frames/image", 2, 1, frames.data() + 120);
  EXPECT_EQ(f.NumFrames("/frames/image"), 3);
  std::vector<uint8_t> back(60);
  f.ReadFrames<uint8_t>("/frames/image", 2, 1, back.data());
  EXPECT_TRUE(std::equal(back.begin(), back.end(), frames.begin() + 120));
  EXPECT_THROW(f.ReadFrames<uint8_t>("/frames/image", 2, 2, back.data()), FileIOError);
  // Re-creating with the same frame shape keeps the data (resumed runs).
  f.CreateFrames<uint8_t>("/frames/image", {4, 5, 3}, 0, 2);
  EXPECT_EQ(f.NumFrames("/frames/image"), 3);
  EXPECT_THROW(f.CreateFrames<uint8_t>("/frames/image", {4, 6, 3}, 0), OutputError);
}

TEST(DoneMask, PersistsAcrossReopenOfPartialFile) {
  testing::TempDir dir;
  const std::string path = dir.File("r.h5");
  {
    bool resumed = true;
    H5File f = H5File::OpenOrCreatePartial(path, &resumed);
    EXPECT_FALSE(resumed);
    DoneMask mask(&f, 10);
    mask.MarkDone({1, 3, 4});
  }  // closed without commit, as a killed run would leave it
  bool resumed = false;
  H5File f = H5File::OpenOrCreatePartial(path, &resumed);
  EXPECT_TRUE(resumed);
  DoneMask mask(&f, 10);
  EXPECT_EQ(mask.NumDone(), 3);
  EXPECT_EQ(mask.Pending(), (std::vector<int64_t>{0, 2, 5, 6, 7, 8, 9}));
}

TEST(H5File, ProvenanceAttributesPresent) {
  testing::TempDir dir;
  H5File f = H5File::CreateAtomic(dir.File("p.h5"));
  Provenance p{"rig demo", "facecap rig demo --out rig.h5", "[rig.demo]\nout = 'rig.h5'\n", 3};
  f.WriteProvenance(p);
  for (const char* key : {"facecap_version", "git_commit", "command_line", "config", "created_utc",
                          "stage"}) {
    EXPECT_TRUE(f.HasAttribute("/", key)) << key;
  }
  EXPECT_EQ(f.GetIntAttribute("/", "mpi_ranks"), 3);
  EXPECT_EQ(f.GetStringAttribute("/", "stage"), "rig demo");
}

// An attribute holding several values was read into room for one: GetIntAttribute wrote the
// whole array over its single int64, GetStringAttribute read every string into a buffer for
// one. Both are errors naming the file now.
TEST(H5File, ArrayAttributesAreNotReadAsOneValue) {
  testing::TempDir dir;
  const std::string path = dir.File("a.h5");
  {
    H5File f = H5File::CreateAtomic(path);
    f.WriteVector<float>("/x", {1.f});
    f.SetAttribute("/x", "counts", std::vector<double>{1., 2., 3., 4.});
    f.Commit();
  }
  {
    // Two fixed-length strings in one attribute (the writer makes only single strings).
    hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 8);
    const hsize_t two = 2;
    hid_t space = H5Screate_simple(1, &two, nullptr);
    hid_t attr = H5Acreate2(file, "names", type, space, H5P_DEFAULT, H5P_DEFAULT);
    const char values[16] = {'j', 'a', 'w', 'O', 'p', 'e', 'n', '\0',
                             'e', 'y', 'e', 'B', 'l', 'i', 'n', 'k'};
    ASSERT_GE(H5Awrite(attr, type, values), 0);
    H5Aclose(attr);
    H5Sclose(space);
    H5Tclose(type);
    H5Fclose(file);
  }
  H5File f = H5File::OpenRead(path);
  for (const auto& read : std::vector<std::function<void()>>{
           [&] { f.GetIntAttribute("/x", "counts"); },
           [&] { f.GetDoubleAttribute("/x", "counts"); },
           [&] { f.GetStringAttribute("/", "names"); },
           [&] { f.GetStringAttribute("/x", "counts"); }}) {
    try {
      read();
      FAIL() << "expected FileIOError";
    } catch (const FileIOError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(f.GetDoubleVectorAttribute("/x", "counts").size(), 4u);
}

TEST(ConfigHash, StableAndSensitive) {
  EXPECT_EQ(ConfigHash("a = 1"), ConfigHash("a = 1"));
  EXPECT_NE(ConfigHash("a = 1"), ConfigHash("a = 2"));
  EXPECT_EQ(ConfigHash("").size(), 16u);
}

}  // namespace
}  // namespace facecap::io
