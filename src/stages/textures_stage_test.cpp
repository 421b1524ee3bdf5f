// The textured scan database, eval textures and the texture networks end to end on a tiny
// database: the skin maps are the same on 1 and 3 ranks and change only where an expression
// moves the skin, the dynamic textures of eq. 14 beat the static neutral texture on a held-out
// person, and the networks train on 2 and 3 ranks, resume, learn and make a library.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "render/shading.h"
#include "stages/render_stage.h"
#include "stages/scans_stage.h"
#include "stages/textures_net_stage.h"
#include "stages/textures_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

class TexturedScans : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RunInProcess(RunScansSynth, SynthOptions(Scans()), "scans.synth");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Scans() { return dir_->File("scans.h5"); }
  static std::string Synth(const std::string& out) {
    return "scans synth --people 4 --test-people 1 --texture-size 64 --threads 1 --out " + out;
  }
  // The options of Synth(out), for a run in this process.
  static ScansSynthOptions SynthOptions(const std::string& out) {
    ScansSynthOptions o;
    o.people = 4;
    o.test_people = 1;
    o.texture_size = 64;
    o.threads = 1;
    o.out = out;
    return o;
  }
  // eval textures of `scans` (with a texture network `model` when not empty) in this process:
  // the JSON object it writes.
  static std::string EvalTextures(const std::string& scans, const std::string& model,
                                  const std::string& json) {
    EvalTexturesOptions o;
    o.scans = scans;
    o.model = model;
    o.json = true;
    o.out = json;
    RunInProcess(RunEvalTextures, o, "eval.textures");
    return testing::ReadText(json);
  }
  static double Nested(const std::string& json, const std::string& object, const std::string& key) {
    return testing::NestedJsonNumber(json, object, key);
  }
  // The database's template as a rig file (any rig of its topology drives a library).
  static std::string TemplateRigFile() {
    const std::string path = dir_->File("template.h5");
    if (!std::filesystem::exists(path)) {
      io::H5File rig_file = io::H5File::CreateAtomic(path);
      io::WriteRig(io::ReadRig(io::H5File::OpenRead(Scans()), "/template"), &rig_file);
      rig_file.Commit();
    }
    return path;
  }
  // Every value of a frame-major dataset.
  static std::vector<float> ReadAll(const io::H5File& f, const std::string& name) {
    const io::Shape shape = f.DatasetShape(name);
    size_t count = 1;
    for (int64_t d : shape) count *= static_cast<size_t>(d);
    std::vector<float> out(count);
    f.ReadFrames<float>(name, 0, shape[0], out.data());
    return out;
  }
  static testing::TempDir* dir_;
};

testing::TempDir* TexturedScans::dir_ = nullptr;

TEST_F(TexturedScans, SkinMapsAreTheSameOnThreeRanksAndMoveOnlyWhereTheSkinMoves) {
  const std::string three = dir_->File("scans3.h5");
  auto r = RunFacecap(Synth(three), 3);
  ASSERT_EQ(r.code, 0) << r.output;
  const io::H5File a = io::H5File::OpenRead(Scans()), b = io::H5File::OpenRead(three);
  for (const char* name : {"/scans/textures/neutral", "/scans/textures/offsets", "/scans/truth/shape_offsets",
                           "/scans/truth/skin"}) {
    EXPECT_EQ(ReadAll(a, name), ReadAll(b, name)) << name;
  }
  ASSERT_EQ(a.DatasetShape("/scans/textures/offsets"), (io::Shape{4, 24, 64, 64, 5}));
  // Each true blendshape's maps at weight 1 (the expressions add unwanted motion of others).
  const io::Shape shape = a.DatasetShape("/scans/truth/shape_offsets");
  ASSERT_EQ(shape.size(), 5u);
  const size_t N = static_cast<size_t>(shape[1]), per_map = 64 * 64 * 5;
  const std::vector<float> offsets = ReadAll(a, "/scans/truth/shape_offsets");
  const std::vector<std::string> names = a.ReadStrings("/scans/shape_names");
  ASSERT_EQ(names.size(), N);
  auto moved = [&](size_t person, const std::string& shape_name) {
    const size_t i = std::find(names.begin(), names.end(), shape_name) - names.begin();
    EXPECT_LT(i, N) << shape_name;
    int texels = 0;
    const float* o = &offsets[(person * N + i) * per_map];
    for (size_t t = 0; t < 64 * 64; ++t) {
      float m = 0;
      for (int c = 0; c < 5; ++c) m = std::max(m, std::abs(o[5 * t + c]));
      texels += m > 0.f;
    }
    return texels;
  };
  for (size_t person = 0; person < 4; ++person) {
    // A blink moves a lid; opening the jaw moves the lower face.
    EXPECT_GT(moved(person, "eyeBlinkLeft"), 0);
    EXPECT_LT(moved(person, "eyeBlinkLeft"), moved(person, "jawOpen") / 2);
    EXPECT_LT(moved(person, "jawOpen"), 64 * 64 / 2);
  }
  const std::vector<float> neutral = ReadAll(a, "/scans/textures/neutral");
  EXPECT_NE(std::vector<float>(neutral.begin(), neutral.begin() + per_map),
            std::vector<float>(neutral.begin() + per_map, neutral.begin() + 2 * per_map));
}

TEST_F(TexturedScans, DynamicTexturesBeatTheStaticNeutralOnAHeldOutPerson) {
  const std::string json = EvalTextures(Scans(), "", dir_->File("eval_textures.json"));
  for (const char* layer : {"albedo_db", "displacement_db"}) {
    const double stat = Nested(json, "static_neutral", layer), dyn = Nested(json, "dynamic", layer);
    EXPECT_GT(dyn, stat + 3.0) << layer << "\n" << json;
  }
  EXPECT_GT(Nested(json, "per_blendshape_maps", "albedo_db"), Nested(json, "static_neutral", "albedo_db"));
  ScansSynthOptions none;
  none.people = 2;
  none.test_people = 1;
  none.texture_size = 0;
  none.threads = 1;
  none.out = dir_->File("plain.h5");
  RunInProcess(RunScansSynth, none, "scans.synth");
  try {
    EvalTextures(dir_->File("plain.h5"), "", dir_->File("plain.json"));
    ADD_FAILURE() << "eval textures of a database without skin maps did not fail";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find("no skin maps"), std::string::npos) << e.what();
  }
}

// Person 0's neutral and smile written as OBJ meshes with their skin maps beside them (the
// neutral's albedo as an sRGB PNG, the smile's as a linear EXR, specular as 8-bit PNGs,
// displacement as EXRs in cm) come back through scans import as the database held them.
TEST_F(TexturedScans, ImportReadsTheSkinMapsBesideTheMeshes) {
  const io::H5File db = io::H5File::OpenRead(Scans());
  const rig::Rig tmpl = io::ReadRig(db, "/template");
  const int V = tmpl.NumVertices(), S = 64, C = 5;
  const std::vector<std::string> names = db.ReadStrings("/scans/facs/names");
  const int smile = static_cast<int>(std::find(names.begin(), names.end(), "smile") - names.begin());
  ASSERT_LT(smile, static_cast<int>(names.size()));
  TemplateRigFile();
  rig::Vertices neutral(V, 3);
  db.ReadFrames<float>("/scans/people/neutral", 0, 1, neutral.data());
  std::vector<float> expressions(static_cast<size_t>(names.size()) * V * 3);
  db.ReadFrames<float>("/scans/people/expressions", 0, 1, expressions.data());
  const rig::Vertices smile_mesh = Eigen::Map<const rig::Vertices>(&expressions[static_cast<size_t>(smile) * V * 3], V, 3);
  std::vector<float> maps(static_cast<size_t>(S) * S * C);
  db.ReadFrames<float>("/scans/textures/neutral", 0, 1, maps.data());
  std::vector<float> offsets(names.size() * maps.size());
  db.ReadFrames<float>("/scans/textures/offsets", 0, 1, offsets.data());
  std::vector<float> smile_maps = maps;
  for (size_t i = 0; i < maps.size(); ++i) smile_maps[i] += offsets[smile * maps.size() + i];
  const std::string folder = dir_->File("import");
  std::filesystem::create_directories(folder);
  auto write_maps = [&](const std::string& stem, const std::vector<float>& m, bool srgb_png) {
    ImageF albedo(S, S, 3), specular(S, S, 1), displacement(S, S, 1);
    for (int t = 0; t < S * S; ++t) {
      for (int c = 0; c < 3; ++c) albedo.data[3 * t + c] = srgb_png ? render::EncodeSrgb(m[C * t + c]) : m[C * t + c];
      specular.data[t] = m[C * t + 3];
      displacement.data[t] = m[C * t + 4] / 10.f;  // cm
    }
    io::WriteImage(folder + "/" + stem + (srgb_png ? "_albedo.png" : "_albedo.exr"), albedo);
    io::WriteImage(folder + "/" + stem + "_specular.png", specular);
    io::WriteImage(folder + "/" + stem + "_displacement.exr", displacement);
  };
  io::ExportMeshObj(neutral, tmpl.triangles, nullptr, nullptr, folder + "/neutral.obj");
  io::ExportMeshObj(smile_mesh, tmpl.triangles, nullptr, nullptr, folder + "/smile.obj");
  write_maps("neutral", maps, true);
  write_maps("smile", smile_maps, false);
  std::ofstream(folder + "/labels.csv") << "person,expression,file,split\np0,neutral,neutral.obj,train\n"
                                           "p0,smile,smile.obj,train\n";
  auto import_options = [&](const std::string& out) {
    ScansImportOptions o;
    o.labels = folder + "/labels.csv";
    o.template_rig = dir_->File("template.h5");
    o.facs = {"smile=mouthSmileLeft+mouthSmileRight"};
    o.texture_size = 64;
    o.displacement_scale_mm = 10.f;
    o.out = out;
    return o;
  };
  RunInProcess(RunScansImport, import_options(dir_->File("imported.h5")), "scans.import");
  const io::H5File imported = io::H5File::OpenRead(dir_->File("imported.h5"));
  std::vector<float> got_neutral(maps.size()), got_offsets(maps.size());
  imported.ReadFrames<float>("/scans/textures/neutral", 0, 1, got_neutral.data());
  imported.ReadFrames<float>("/scans/textures/offsets", 0, 1, got_offsets.data());
  double worst_albedo_png = 0, worst_specular = 0, worst_exact = 0;
  for (size_t i = 0; i < maps.size(); ++i) {
    const int c = static_cast<int>(i % C);
    const double n_err = std::abs(got_neutral[i] - maps[i]);
    const double e_err = std::abs(got_neutral[i] + got_offsets[i] - smile_maps[i]);
    if (c < 3) {
      worst_albedo_png = std::max(worst_albedo_png, n_err);
      worst_exact = std::max(worst_exact, e_err);
    } else if (c == 3) {
      worst_specular = std::max({worst_specular, n_err, e_err});
    } else {
      worst_exact = std::max({worst_exact, n_err, e_err});
    }
  }
  EXPECT_LT(worst_albedo_png, 0.01);   // 8-bit sRGB: steps of under 1% in linear values
  EXPECT_LT(worst_specular, 0.5 / 255 + 1e-6);
  EXPECT_LT(worst_exact, 1e-5);        // float EXRs, displacement scaled back to mm
  // A mesh without the maps that the first neutral has is named.
  std::filesystem::remove(folder + "/smile_specular.png");
  try {
    RunInProcess(RunScansImport, import_options(dir_->File("imported2.h5")), "scans.import");
    ADD_FAILURE() << "scans import of a mesh without its specular map did not fail";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find("smile.obj: no specular map"), std::string::npos) << e.what();
  }
}

// A library of person 3 drives a take of three frames: at zero weights eq. 14 gives the
// neutral maps exactly, an open jaw changes them, equal weights give equal maps, and the
// sequences are the same on 2 ranks and when a run continues.
TEST_F(TexturedScans, LibraryExportsATakesTexturesFrameByFrame) {
  const std::string library = dir_->File("library.h5");
  TexturesLibraryOptions library_options;
  library_options.scans = Scans();
  library_options.person = "3";
  library_options.rig = TemplateRigFile();
  library_options.out = library;
  RunInProcess(RunTexturesLibrary, library_options, "textures.library");
  const std::vector<std::string> names = {"jawOpen", "mouthSmileLeft"};
  Eigen::MatrixXf w(3, 2);
  w << 0, 0, 1, 0.5f, 1, 0.5f;
  const std::string track = dir_->File("take.h5");
  {
    io::H5File file = io::H5File::CreateAtomic(track);
    file.WriteStrings("/track/shape_names", names);
    file.WriteMatrix("/track/weights", w);
    file.WriteMatrix("/track/pose", Eigen::MatrixXf::Zero(3, 3));
    file.WriteMatrix("/track/translation", Eigen::MatrixXf::Zero(3, 3));
    file.WriteVector<float>("/track/scale", {1.f, 1.f, 1.f});
    file.WriteVector<double>("/camera/intrinsics", {100.0, 100.0, 32.0, 32.0});
    file.Commit();
  }
  const std::string one = dir_->File("tex1"), two = dir_->File("tex2");
  ExportTexturesOptions export_options;
  export_options.library = library;
  export_options.track = track;
  export_options.out = one;
  RunInProcess(RunExportTextures, export_options, "export.textures");
  auto r = RunFacecap("export textures --library " + library + " --track " + track + " --out " + two, 2);
  ASSERT_EQ(r.code, 0) << r.output;
  auto read = [](const std::string& folder, const std::string& layer, int frame) {
    char name[64];
    std::snprintf(name, sizeof(name), "/%s.%05d.exr", layer.c_str(), frame);
    return io::ReadImageF(folder + name, 3).data;
  };
  const std::vector<float> neutral = ReadAll(io::H5File::OpenRead(library), "/dynamic_texture/neutral");
  for (const char* layer : {"albedo", "specular", "displacement"}) {
    const int first = std::string(layer) == "albedo" ? 0 : std::string(layer) == "specular" ? 3 : 4;
    const std::vector<float> f0 = read(one, layer, 0);
    double worst = 0;
    for (size_t t = 0; t < f0.size() / 3; ++t) {
      const int channels = first == 0 ? 3 : 1;
      for (int c = 0; c < channels; ++c) worst = std::max(worst, std::abs(double(f0[3 * t + c]) - neutral[5 * t + first + c]));
    }
    EXPECT_EQ(worst, 0.0) << layer;
    EXPECT_NE(read(one, layer, 1), f0) << layer;
    EXPECT_EQ(read(one, layer, 1), read(one, layer, 2)) << layer;
    for (int frame = 0; frame < 3; ++frame) EXPECT_EQ(read(one, layer, frame), read(two, layer, frame)) << layer;
  }
  r = RunFacecap("export textures --library " + library + " --track " + track + " --out " + one);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("(3 kept from an earlier run)"), std::string::npos) << r.output;
}

// The texture networks (textures train) under mpirun: every rank holds the same weights on 2
// and 3 ranks, and a stopped run continues to the weights of the straight run.
TEST_F(TexturedScans, TextureNetworksKeepOneWeightSetOnEveryRankAndResume) {
  auto train = [&](const std::string& out) {
    return "textures train --scans " + Scans() + " --epochs 1 --batch 8 --channels 4 --residual-blocks 1 "
           "--threads 1 --checkpoint-every 2 --out " + out;
  };
  auto train_options = [&](const std::string& out) {
    TexturesTrainOptions o;
    o.scans = Scans();
    o.epochs = 1;
    o.batch = 8;
    o.net.channels = 4;
    o.net.residual_blocks = 1;
    o.threads = 1;
    o.checkpoint_every = 2;
    o.out = out;
    return o;
  };
  for (int ranks : {2, 3}) {
    auto r = RunFacecap(train(dir_->File("texnet" + std::to_string(ranks) + ".h5")), ranks);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("weights identical on " + std::to_string(ranks) + " rank(s)"), std::string::npos)
        << r.output;
  }
  const std::string straight = dir_->File("texnet_straight.h5"), stopped = dir_->File("texnet_stopped.h5");
  RunInProcess(RunTexturesTrain, train_options(straight), "textures.train");
  auto stop = RunFacecap(train(stopped), 0, "FACECAP_FAULT_AFTER_STEPS=3");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  EXPECT_FALSE(std::filesystem::exists(stopped));
  auto rerun = RunFacecap(train(stopped));
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  const io::H5File a = io::H5File::OpenRead(straight), b = io::H5File::OpenRead(stopped);
  EXPECT_EQ(a.ReadVector<float>("/model/parameters"), b.ReadVector<float>("/model/parameters"));
}

// Trained a few epochs on three people, the networks' expression textures of the held-out
// person beat the static neutral texture where the skin moves (albedo and specular; the
// displacement's wrinkles take more people), and textures infer turns a rig and a neutral's
// maps into a library of predicted textures that render draws.
TEST_F(TexturedScans, TextureNetworksLearnAndMakeALibraryFromANeutral) {
  const std::string model = dir_->File("texnet_learn.h5");
  TexturesTrainOptions train;
  train.scans = Scans();
  train.epochs = 6;
  train.batch = 4;
  train.net.channels = 8;
  train.net.residual_blocks = 1;
  train.net.learning_rate = 2e-3f;
  train.threads = 2;
  train.out = model;
  RunInProcess(RunTexturesTrain, train, "textures.train");
  const std::string json = EvalTextures(Scans(), model, dir_->File("eval_textures_model.json"));
  for (const char* layer : {"albedo_db", "specular_db"}) {
    EXPECT_GT(Nested(json, "network_expressions", layer), Nested(json, "static_neutral", layer) + 0.5)
        << layer << "\n" << json;
  }
  const std::string library = dir_->File("predicted_library.h5");
  TexturesInferOptions infer;
  infer.model = model;
  infer.scans = Scans();
  infer.person = "3";
  infer.rig = TemplateRigFile();
  infer.out = library;
  RunInProcess(RunTexturesInfer, infer, "textures.infer");
  const io::H5File f = io::H5File::OpenRead(library);
  EXPECT_EQ(f.DatasetShape("/predicted"), (io::Shape{24, 64, 64, 5}));
  EXPECT_EQ(f.DatasetShape("/dynamic_texture/compress"), (io::Shape{64, 64, 5}));
  RenderStageOptions render;
  render.rig = library;
  render.weights = {"jawOpen=1"};
  render.size = 64;
  render.out = dir_->File("predicted.png");
  RunInProcess(RunRender, render, "render");
  TexturesInferOptions wrong;
  wrong.model = Scans();
  wrong.scans = Scans();
  wrong.rig = TemplateRigFile();
  wrong.out = dir_->File("no_library.h5");
  try {
    RunInProcess(RunTexturesInfer, wrong, "textures.infer");
    ADD_FAILURE() << "textures infer with a scan database as its model did not fail";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find("not a texture network model"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace facecap::stages
