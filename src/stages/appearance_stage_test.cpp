// facecap appearance end to end: turntables identical for any rank count and after a kill,
// and the capture of a synthetic person's albedo when the images splatted are the true renders
// (a perfect deepfake), scored by eval appearance against the true albedo.
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <utility>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/image_io.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "stages/appearance_stage.h"
#include "stages/eval_stage.h"
#include "stages/render_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_clip_stage.h"
#include "stages/track_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::ReadText;
using testing::RunFacecap;

class Appearance : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.out = dir_->File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthClipOptions clip;
    clip.rig = dir_->File("rig.h5");
    clip.clip.frames = 2;
    clip.clip.size = 64;
    clip.clip.identity_seed = 21;
    clip.out = Clip();
    RunInProcess(RunSynthClip, clip, "synth.clip");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Clip() { return dir_->File("clip.h5"); }
  // Views of the true person with the true albedo and no lighting: what a perfect deepfake
  // would hand the gathering.
  static std::string Turntable(const std::string& out) {
    return "appearance turntable --rig " + Clip() + " --texture " + Clip() +
           " --texture-dataset /identity/albedo --lighting none --views 30 --size 64 --batch 2 "
           "--sheet none --out " + out;
  }
  // Turntable(out) as options, for the stage called in-process.
  static AppearanceTurntableOptions TurntableOptions(const std::string& out) {
    AppearanceTurntableOptions o;
    o.rig = Clip();
    o.texture = Clip();
    o.texture_dataset = "/identity/albedo";
    o.lighting = "none";
    o.views = 30;
    o.size = 64;
    o.run.batch = 2;
    o.run.sheet = "none";
    o.out = out;
    return o;
  }
  // appearance gather of `views` into a texture of `texture_size` texels.
  static AppearanceGatherOptions GatherOptions(const std::string& views, int texture_size,
                                               const std::string& out) {
    AppearanceGatherOptions o;
    o.views = views;
    o.texture_size = texture_size;
    o.out = out;
    return o;
  }
  // The JSON of eval appearance of `texture` against the clip's true albedo.
  static std::string EvalAppearanceJson(const std::string& texture) {
    EvalAppearanceOptions o;
    o.truth = Clip();
    o.texture = texture;
    o.json = true;
    o.out = texture + ".json";
    RunInProcess(RunEvalAppearance, o, "eval.appearance");
    return ReadText(o.out);
  }
  template <typename T>
  static std::vector<T> Read(const std::string& path, const std::string& name) {
    return io::H5File::OpenRead(path).Read<T>(name, {});
  }
  static void ExpectSameViews(const std::string& a, const std::string& b) {
    EXPECT_EQ(Read<uint8_t>(a, "/frames/image"), Read<uint8_t>(b, "/frames/image"));
    EXPECT_EQ(Read<int32_t>(a, "/frames/triangle"), Read<int32_t>(b, "/frames/triangle"));
    for (const char* name : {"/frames/uv", "/frames/depth", "/frames/pose", "/frames/camera"}) {
      EXPECT_EQ(Read<float>(a, name), Read<float>(b, name)) << name << " differs: " << a << ", " << b;
    }
  }
  static double JsonValue(const std::string& json, const std::string& key) {
    const size_t at = json.find("\"" + key + "\": ");
    if (at == std::string::npos) return NAN;
    return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
  }
  static testing::TempDir* dir_;
};

testing::TempDir* Appearance::dir_ = nullptr;

TEST_F(Appearance, TurntableIsTheSameOnOneAndThreeRanksAndAfterAKill) {
  const std::string one = dir_->File("tt1.h5"), three = dir_->File("tt3.h5"),
                    killed = dir_->File("ttk.h5");
  auto r1 = RunFacecap(Turntable(one), 1);
  ASSERT_EQ(r1.code, 0) << r1.output;
  auto r3 = RunFacecap(Turntable(three), 3);
  ASSERT_EQ(r3.code, 0) << r3.output;
  ExpectSameViews(one, three);
  auto crash = RunFacecap(Turntable(killed), 0, "FACECAP_FAULT_AFTER_FRAMES=8 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap(Turntable(killed), 2);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  ExpectSameViews(one, killed);
  // The views cover pitch and yaw: the head is seen from both sides.
  const std::vector<float> pose = Read<float>(one, "/frames/pose");
  float lowest = 1.f, highest = -1.f;
  for (size_t v = 0; v < pose.size() / 3; ++v) {
    lowest = std::min(lowest, pose[3 * v + 1]);
    highest = std::max(highest, pose[3 * v + 1]);
  }
  EXPECT_LT(lowest, -1.1f);
  EXPECT_GT(highest, 1.1f);
}

TEST_F(Appearance, GatheringTrueRendersCapturesTheTrueAlbedo) {
  const std::string views = dir_->File("views.h5");
  RunInProcess(RunAppearanceTurntable, TurntableOptions(views), "appearance.turntable");
  const std::string one = dir_->File("texture1.h5"), two = dir_->File("texture2.h5");
  auto g1 = RunFacecap("appearance gather --views " + views + " --texture-size 128 --out " + one, 1);
  ASSERT_EQ(g1.code, 0) << g1.output;
  auto g2 = RunFacecap("appearance gather --views " + views + " --texture-size 128 --png none --out " + two, 2);
  ASSERT_EQ(g2.code, 0) << g2.output;
  EXPECT_EQ(Read<float>(one, "/texture/albedo"), Read<float>(two, "/texture/albedo"));
  EXPECT_TRUE(std::filesystem::exists(dir_->File("texture1.png")));
  EXPECT_TRUE(std::filesystem::exists(dir_->File("texture1.exr")));
  EXPECT_FALSE(std::filesystem::exists(dir_->File("texture2.png")));
  const std::string eval = EvalAppearanceJson(one);
  const double psnr = JsonValue(eval, "psnr_face_db");
  const double flat = JsonValue(eval, "psnr_flat_db");
  const double coverage = JsonValue(eval, "coverage");
  EXPECT_GT(coverage, 0.95) << eval;
  EXPECT_GT(psnr, 36.) << eval;
  EXPECT_GT(psnr, flat + 6.) << eval;
  // The lit renders of the plain albedo are no capture of this person: far below.
  const std::string lit = dir_->File("lit.h5"), lit_texture = dir_->File("lit_texture.h5");
  AppearanceTurntableOptions lit_turntable;
  lit_turntable.rig = Clip();
  lit_turntable.views = 30;
  lit_turntable.size = 64;
  lit_turntable.run.sheet = "none";
  lit_turntable.out = lit;
  RunInProcess(RunAppearanceTurntable, lit_turntable, "appearance.turntable");
  RunInProcess(RunAppearanceGather, GatherOptions(lit, 128, lit_texture), "appearance.gather");
  const std::string plain = EvalAppearanceJson(lit_texture);
  EXPECT_LT(JsonValue(plain, "psnr_face_db"), psnr - 10.) << plain;
}

// appearance gather's output is a textured rig; render draws a textured rig with its texture,
// and rig export embeds it into the glTF.
TEST_F(Appearance, ATexturedRigIsRenderedAndExportedWithItsTexture) {
  const std::string views = dir_->File("rig_views.h5"), gathered = dir_->File("rig_texture.h5");
  RunInProcess(RunAppearanceTurntable, TurntableOptions(views), "appearance.turntable");
  RunInProcess(RunAppearanceGather, GatherOptions(views, 64, gathered), "appearance.gather");
  const rig::Rig rig = io::ReadRigFile(Clip());
  EXPECT_EQ(io::ReadRigFile(gathered).neutral, rig.neutral);
  EXPECT_EQ(io::ReadRigTexture(gathered).width, 64);
  EXPECT_TRUE(io::ReadRigTexture(Clip()).empty());

  // A rig whose texture is pure green renders green where the face is.
  const std::string green = dir_->File("green.h5");
  {
    io::H5File f = io::H5File::CreateAtomic(green);
    io::WriteRig(rig, &f);
    ImageF texture(16, 16, 3);
    for (size_t i = 0; i < texture.data.size(); ++i) texture.data[i] = i % 3 == 1 ? 0.8f : 0.f;
    io::WriteColorTexture(&f, io::kTextureAlbedoPath, texture);
    f.Commit();
  }
  for (const auto& [file, is_green] : {std::pair{green, true}, std::pair{Clip(), false}}) {
    const std::string png = dir_->File(is_green ? "green.png" : "generic.png");
    RenderStageOptions render;
    render.rig = file;
    render.mode = "shaded";
    render.size = 96;
    render.out = png;
    RunInProcess(RunRender, render, "render");
    const Image8 image = io::ReadImage8(png);
    const uint8_t* centre = image.pixel(48, 48);
    EXPECT_EQ(centre[1] > 3 * std::max(centre[0], centre[2]), is_green)
        << file << ": centre pixel " << int(centre[0]) << " " << int(centre[1]) << " " << int(centre[2]);
  }
  const std::string glb = dir_->File("green.glb");
  RigExportOptions rig_export;
  rig_export.rig = green;
  rig_export.gltf = glb;
  RunInProcess(RunRigExport, rig_export, "rig.export");
  std::ifstream in(glb, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(bytes.find("\"baseColorTexture\":{\"index\":0}"), std::string::npos);
  EXPECT_NE(bytes.find("\"mimeType\":\"image/png\""), std::string::npos);
  EXPECT_NE(bytes.find("\x89PNG"), std::string::npos);
}

TEST_F(Appearance, TrackedFramesBecomeViewsWhoseUVImageCoversTheFace) {
  const std::string track = dir_->File("track.h5"), views = dir_->File("frame_views.h5");
  TrackOptions tracking;
  tracking.rig = Clip();
  tracking.targets = Clip();
  tracking.targets_dataset = "/frames/segmentation";
  tracking.out = track;
  RunInProcess(RunTrack, tracking, "track");
  auto r = RunFacecap("appearance frames --frames " + Clip() + " --track " + track + " --rig " +
                      Clip() + " --out " + views, 2);
  ASSERT_EQ(r.code, 0) << r.output;
  // The views are the clip's own frames, and the tracked rig's U(I) covers the face the
  // segmentation shows (true rig, solved on the true segmentation: nearly the same pixels).
  EXPECT_EQ(Read<uint8_t>(views, "/frames/image"), Read<uint8_t>(Clip(), "/frames/image"));
  const std::vector<float> uv = Read<float>(views, "/frames/uv");
  const std::vector<uint8_t> segmentation = Read<uint8_t>(Clip(), "/frames/segmentation");
  int64_t both = 0, either = 0;
  for (size_t p = 0; p < uv.size() / 3; ++p) {
    const bool head = segmentation[3 * p] + segmentation[3 * p + 1] + segmentation[3 * p + 2] > 0;
    const bool covered = uv[3 * p + 2] > 0.5f;
    both += head && covered;
    either += head || covered;
  }
  ASSERT_GT(either, 0);
  EXPECT_GT(static_cast<double>(both) / either, 0.9);
  const std::string texture = dir_->File("frames_texture.h5");
  RunInProcess(RunAppearanceGather, GatherOptions(views, 64, texture), "appearance.gather");
  EXPECT_GT(JsonValue(EvalAppearanceJson(texture), "coverage"), 0.5);
  // Frame 1 held out of the gathering, then re-rendered with the texture of frame 0: the
  // person's own colours explain it better than the generic texture does.
  const std::string held = dir_->File("frames_texture_held.h5");
  AppearanceGatherOptions held_out = GatherOptions(views, 64, held);
  held_out.holdout_every = 2;
  RunInProcess(RunAppearanceGather, held_out, "appearance.gather");
  const auto particles = [](const std::string& path) {
    return io::H5File::OpenRead(path).GetIntAttribute("/texture", "particles");
  };
  EXPECT_LT(particles(held), particles(texture));
  EXPECT_GT(particles(held), 0);
  EvalRerenderOptions rerender;
  rerender.views = views;
  rerender.texture = held;
  rerender.holdout_every = 2;
  rerender.json = true;
  rerender.out = dir_->File("rerender.json");
  RunInProcess(RunEvalRerender, rerender, "eval.rerender");
  const std::string e = ReadText(rerender.out);
  EXPECT_EQ(JsonValue(e, "frames"), 1.) << e;
  EXPECT_GT(JsonValue(e, "psnr_captured_db"), JsonValue(e, "psnr_generic_db") + 3.) << e;
}

TEST_F(Appearance, BadInputsNameTheFile) {
  const std::string views = dir_->File("views_bad.h5");
  AppearanceTurntableOptions no_texture;
  no_texture.rig = Clip();
  no_texture.texture = dir_->File("rig.h5");
  no_texture.texture_dataset = "/identity/albedo";
  no_texture.out = views;
  try {
    RunInProcess(RunAppearanceTurntable, no_texture, "appearance.turntable");
    ADD_FAILURE() << "no error for " << no_texture.texture;
  } catch (const FileIOError& e) {
    EXPECT_EQ(e.code(), kExitInput);
    EXPECT_NE(std::string(e.what()).find("rig.h5: no texture /identity/albedo"), std::string::npos)
        << e.what();
  }
  RunInProcess(RunAppearanceTurntable, TurntableOptions(views), "appearance.turntable");
  // Images of another count than the views: exit 3 naming both files.
  auto mismatch = RunFacecap("appearance gather --views " + views + " --images " + Clip() +
                             " --out " + dir_->File("never.h5"));
  EXPECT_EQ(mismatch.code, kExitInput) << mismatch.output;
  EXPECT_NE(mismatch.output.find("clip.h5: /frames/image has 2 images"), std::string::npos)
      << mismatch.output;
  EXPECT_FALSE(std::filesystem::exists(dir_->File("never.h5")));
  EXPECT_EQ(RunFacecap(Turntable(views) + " --yaw-max-deg 95").code, kExitUsage);
}

}  // namespace
}  // namespace facecap::stages
