// The camera layout: what a writer records is what a reader gets back, attributes a writer
// does not know stay absent, and a file without a camera is refused naming the file.
#include "io/camera_file.h"

#include <string>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

TEST(CameraFile, WhatIsWrittenIsReadBack) {
  testing::TempDir dir;
  render::Camera camera;
  camera.width = 400;
  camera.height = 300;
  camera.fx = 510.25f;
  camera.fy = 511.5f;
  camera.cx = 199.75f;
  camera.cy = 150.125f;
  CameraRecord written = CameraRecord::Of(camera);
  written.distance_cm = 62.5;
  written.fps = 25.;
  {
    H5File f = H5File::CreateAtomic(dir.File("a.h5"));
    WriteCamera(&f, written);
    f.Commit();
  }
  const H5File f = H5File::OpenRead(dir.File("a.h5"));
  ASSERT_TRUE(HasCamera(f));
  const CameraRecord read = ReadCamera(f);
  EXPECT_EQ(read.fx, 510.25);
  EXPECT_EQ(read.cy, 150.125);
  EXPECT_EQ(read.width, 400.);
  EXPECT_EQ(read.height, 300.);
  EXPECT_EQ(read.distance_cm, 62.5);
  EXPECT_EQ(read.fps, 25.);
  const render::Camera back = read.ToCamera();
  EXPECT_EQ(back.width, 400);
  EXPECT_EQ(back.height, 300);
  EXPECT_EQ(back.fx, camera.fx);
  EXPECT_EQ(back.cx, camera.cx);
}

TEST(CameraFile, UnrecordedSizeFollowsThePrincipalPoint) {
  testing::TempDir dir;
  CameraRecord written;
  written.fx = written.fy = 300.;
  written.cx = 64.;
  written.cy = 48.;
  {
    H5File f = H5File::CreateAtomic(dir.File("a.h5"));
    WriteCamera(&f, written);
    f.Commit();
  }
  const H5File f = H5File::OpenRead(dir.File("a.h5"));
  EXPECT_FALSE(f.HasAttribute(kCameraPath, "width"));
  EXPECT_FALSE(f.HasAttribute(kCameraPath, "fps"));
  const CameraRecord read = ReadCamera(f);
  EXPECT_FALSE(read.width.has_value());
  EXPECT_FALSE(read.distance_cm.has_value());
  EXPECT_EQ(read.ToCamera().width, 128);
  EXPECT_EQ(read.ToCamera().height, 96);
}

TEST(CameraFile, AFileWithoutACameraIsRefusedByName) {
  testing::TempDir dir;
  const std::string path = dir.File("none.h5");
  {
    H5File f = H5File::CreateAtomic(path);
    f.WriteVector<double>("/other", {1., 2.});
    f.Commit();
  }
  const H5File f = H5File::OpenRead(path);
  EXPECT_FALSE(HasCamera(f));
  try {
    ReadCamera(f);
    ADD_FAILURE() << "a file without a camera was read";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": no /camera/intrinsics"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace facecap::io
