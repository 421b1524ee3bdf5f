// facecap export: Live Link Face CSV columns and values, glTF animation that re-imports, the
// overlay video drawn where the rig is.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/texture_file.h"
#include "rig/arkit.h"
#include "stages/export_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_clip_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

// A small tracking output: 5 frames, the ARKit shapes in a shuffled order plus one extra.
std::string WriteTrack(const testing::TempDir& dir) {
  std::vector<std::string> names = rig::ArkitShapeNames();
  std::reverse(names.begin(), names.end());
  names.push_back("notAnArkitShape");
  const int F = 5, S = static_cast<int>(names.size());
  Eigen::MatrixXf w(F, S);
  for (int f = 0; f < F; ++f)
    for (int s = 0; s < S; ++s) w(f, s) = static_cast<float>((f * 7 + s) % 10) / 10.f;
  Eigen::MatrixXf pose(F, 3);
  for (int f = 0; f < F; ++f) pose.row(f) << 0.01f * f, -0.1f * f, 0.002f;
  const std::string path = dir.File("track.h5");
  io::H5File file = io::H5File::CreateAtomic(path);
  file.WriteStrings("/track/shape_names", names);
  file.WriteMatrix("/track/weights", w);
  file.WriteMatrix("/track/pose", pose);
  file.Commit();
  return path;
}

TEST(ExportLiveLink, HeaderHasTimecodeCountAnd61ValuesMatchedByName) {
  testing::TempDir dir;
  const std::string track = WriteTrack(dir), csv = dir.File("take.csv");
  ExportLiveLinkOptions o;
  o.track = track;
  o.out = csv;
  o.fps = 30.f;
  RunInProcess(RunExportLiveLink, o, "export.livelink");
  std::ifstream in(csv);
  std::string header, line;
  std::getline(in, header);
  const auto columns = SplitCsv(header);
  ASSERT_EQ(columns.size(), 63u);  // Timecode, BlendShapeCount, 61 values
  EXPECT_EQ(columns[0], "Timecode");
  EXPECT_EQ(columns[1], "BlendShapeCount");
  EXPECT_EQ(columns[2], "EyeBlinkLeft");
  EXPECT_EQ(columns[53], "TongueOut");
  EXPECT_EQ(columns[54], "HeadYaw");
  EXPECT_EQ(columns[62], "RightEyeRoll");
  // Values follow names: jawOpen's column holds the track's jawOpen weights.
  std::vector<std::string> names = rig::ArkitShapeNames();
  std::reverse(names.begin(), names.end());
  const int jaw_track = static_cast<int>(std::find(names.begin(), names.end(), "jawOpen") - names.begin());
  const int jaw_column = static_cast<int>(std::find(columns.begin(), columns.end(), "JawOpen") - columns.begin());
  int frame = 0;
  while (std::getline(in, line)) {
    const auto cells = SplitCsv(line);
    ASSERT_EQ(cells.size(), 63u);
    EXPECT_EQ(cells[1], "61");
    EXPECT_NEAR(std::stof(cells[jaw_column]), ((frame * 7 + jaw_track) % 10) / 10.f, 1e-6);
    EXPECT_NEAR(std::stof(cells[54]), -0.1f * frame, 1e-6);  // yaw
    ++frame;
  }
  EXPECT_EQ(frame, 5);
}

TEST(ExportLiveLink, MissingTrackIsAnInputError) {
  testing::TempDir dir;
  auto r = RunFacecap("export livelink --track " + dir.File("none.h5") + " --out " + dir.File("x.csv"));
  EXPECT_EQ(r.code, kExitInput) << r.output;
}

TEST(ExportGltf, AnimationReimportsWithTheRigsMorphTargets) {
  testing::TempDir dir;
  const std::string track = WriteTrack(dir), rig = dir.File("rig.h5"), glb = dir.File("take.glb");
  RigDemoOptions demo_rig;
  demo_rig.out = rig;
  RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  ExportGltfOptions o;
  o.track = track;
  o.rig = rig;
  o.out = glb;
  RunInProcess(RunExportGltf, o, "export.gltf");
  const rig::Rig back = io::ImportRigFromGltf(glb);
  EXPECT_EQ(back.NumShapes(), 52);
  EXPECT_GE(back.ShapeIndex("jawOpen"), 0);
}

// The overlay of a track that equals a clip's truth, at full opacity, shows the clip's own
// segmentation render: decoded from the mp4 (ffmpeg), most covered pixels have its colours.
TEST(ExportOverlay, DrawsTheTrackedRigWhereTheFaceIs) {
  testing::TempDir dir;
  const std::string rig = dir.File("rig.h5"), clip = dir.File("clip.h5");
  RigDemoOptions demo_rig;
  demo_rig.out = rig;
  RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  SynthClipOptions synth_clip;
  synth_clip.rig = rig;
  synth_clip.clip.frames = 6;
  synth_clip.clip.size = 64;
  synth_clip.out = clip;
  RunInProcess(RunSynthClip, synth_clip, "synth.clip");
  io::H5File c = io::H5File::OpenRead(clip);
  const int F = 6, S = 52;
  const std::string track = dir.File("track.h5");
  {
    io::H5File t = io::H5File::CreateAtomic(track);
    t.WriteStrings("/track/shape_names", c.ReadStrings("/frames/shape_names"));
    t.WriteMatrix("/track/weights", c.ReadMatrix<float>("/frames/weights", F, S));
    t.WriteMatrix("/track/pose", c.ReadMatrix<float>("/frames/pose", F, 3));
    t.WriteMatrix("/track/translation", c.ReadMatrix<float>("/frames/translation", F, 3));
    t.WriteVector<float>("/track/scale", std::vector<float>(F, 1.f));
    t.WriteVector<double>("/camera/intrinsics", c.ReadVector<double>("/camera/intrinsics", 4));
    t.SetAttribute("/camera/intrinsics", "width", 64.0);
    t.Commit();
  }
  const std::string mp4 = dir.File("overlay.mp4");
  ExportOverlayOptions overlay;
  overlay.track = track;
  overlay.rig = clip;
  overlay.frames = clip;
  overlay.opacity = 1.f;
  overlay.scale = 1;
  overlay.out = mp4;
  RunInProcess(RunExportOverlay, overlay, "export.overlay");
  const std::string raw = dir.File("overlay.rgb");
  ASSERT_EQ(std::system(("ffmpeg -loglevel error -y -i " + mp4 +
                         " -f rawvideo -pix_fmt rgb24 " + raw).c_str()), 0);
  std::ifstream in(raw, std::ios::binary);
  std::vector<uint8_t> decoded((std::istreambuf_iterator<char>(in)), {});
  ASSERT_EQ(decoded.size(), static_cast<size_t>(F) * 64 * 64 * 3);
  std::vector<uint8_t> truth(decoded.size());
  c.ReadFrames<uint8_t>("/frames/segmentation", 0, F, truth.data());
  int face = 0, close = 0;
  for (size_t p = 0; p < decoded.size(); p += 3) {
    if (truth[p] == 0 && truth[p + 1] == 0 && truth[p + 2] == 0) continue;  // background
    ++face;
    int d = 0;
    for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int{decoded[p + k]} - int{truth[p + k]}));
    if (d < 48) ++close;  // video compression and the white borders aside
  }
  ASSERT_GT(face, F * 500);
  EXPECT_GT(close, 0.6 * face) << close << " of " << face;

  // --texture shades the rig with the rig file's texture: a green one shows green where the
  // face is; the clip (its albedo is truth, not a rig texture) has none to draw with.
  const std::string textured = dir.File("textured.h5");
  demo_rig.out = textured;
  RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  {
    io::H5File t = io::H5File::OpenReadWrite(textured);
    ImageF green(16, 16, 3);
    for (size_t k = 0; k < green.data.size(); k += 3) green.data[k + 1] = 0.6f;
    io::WriteColorTexture(&t, io::kTextureAlbedoPath, green);
  }
  const std::string shaded = dir.File("shaded.mp4");
  ExportOverlayOptions shaded_overlay = overlay;
  shaded_overlay.rig = textured;
  shaded_overlay.texture = true;
  shaded_overlay.out = shaded;
  RunInProcess(RunExportOverlay, shaded_overlay, "export.overlay");
  ASSERT_EQ(std::system(("ffmpeg -loglevel error -y -i " + shaded +
                         " -f rawvideo -pix_fmt rgb24 " + raw).c_str()), 0);
  std::ifstream shaded_in(raw, std::ios::binary);
  const std::vector<uint8_t> drawn((std::istreambuf_iterator<char>(shaded_in)), {});
  ASSERT_EQ(drawn.size(), decoded.size());
  int green_pixels = 0;
  for (size_t p = 0; p < drawn.size(); p += 3) {
    if (truth[p] == 0 && truth[p + 1] == 0 && truth[p + 2] == 0) continue;
    green_pixels += drawn[p + 1] > drawn[p] + 30 && drawn[p + 1] > drawn[p + 2] + 30;
  }
  EXPECT_GT(green_pixels, 0.6 * face) << green_pixels << " of " << face;
  ExportOverlayOptions untextured;
  untextured.track = track;
  untextured.rig = clip;
  untextured.frames = clip;
  untextured.texture = true;
  untextured.out = dir.File("none.mp4");
  try {
    RunInProcess(RunExportOverlay, untextured, "export.overlay");
    ADD_FAILURE() << "--texture was accepted with a rig without a texture";
  } catch (const FileIOError& e) {
    EXPECT_EQ(e.code(), kExitInput);
    EXPECT_NE(std::string(e.what()).find(clip + ": no texture"), std::string::npos) << e.what();
  }
}

TEST(ExportOverlay, BadOptionsAreUsageErrors) {
  testing::TempDir dir;
  auto r = RunFacecap("export overlay --opacity 2 --out " + dir.File("x.mp4"));
  EXPECT_EQ(r.code, kExitUsage) << r.output;
}

}  // namespace
}  // namespace facecap::stages
