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
#include <string>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "render/shading.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

class TexturedScans : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    auto r = RunFacecap(Synth(Scans()));
    ASSERT_EQ(r.code, 0) << r.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Scans() { return dir_->File("scans.h5"); }
  static std::string Synth(const std::string& out) {
    return "scans synth --people 4 --test-people 1 --texture-size 64 --threads 1 --out " + out;
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
  auto r = RunFacecap("eval textures --scans " + Scans());
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* layer : {"albedo_db", "displacement_db"}) {
    const double stat = Nested(r.output, "static_neutral", layer), dyn = Nested(r.output, "dynamic", layer);
    EXPECT_GT(dyn, stat + 3.0) << layer << "\n" << r.output;
  }
  EXPECT_GT(Nested(r.output, "per_blendshape_maps", "albedo_db"), Nested(r.output, "static_neutral", "albedo_db"));
  auto none = RunFacecap("scans synth --people 2 --test-people 1 --texture-size 0 --threads 1 --out " +
                         dir_->File("plain.h5"));
  ASSERT_EQ(none.code, 0) << none.output;
  auto bad = RunFacecap("eval textures --scans " + dir_->File("plain.h5"));
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("no skin maps"), std::string::npos) << bad.output;
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
  const std::string cmd = "scans import --labels " + folder + "/labels.csv --template-rig " + dir_->File("template.h5") +
                          " --facs smile=mouthSmileLeft+mouthSmileRight --texture-size 64 --displacement-scale-mm 10";
  auto r = RunFacecap(cmd + " --out " + dir_->File("imported.h5"));
  ASSERT_EQ(r.code, 0) << r.output;
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
  auto missing = RunFacecap(cmd + " --out " + dir_->File("imported2.h5"));
  EXPECT_NE(missing.code, 0);
  EXPECT_NE(missing.output.find("smile.obj: no specular map"), std::string::npos) << missing.output;
}

// A library of person 3 drives a take of three frames: at zero weights eq. 14 gives the
// neutral maps exactly, an open jaw changes them, equal weights give equal maps, and the
// sequences are the same on 2 ranks and when a run continues.
TEST_F(TexturedScans, LibraryExportsATakesTexturesFrameByFrame) {
  const std::string library = dir_->File("library.h5");
  auto r = RunFacecap("textures library --scans " + Scans() + " --person 3 --rig " + TemplateRigFile() + " --out " +
                      library);
  ASSERT_EQ(r.code, 0) << r.output;
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
  r = RunFacecap("export textures --library " + library + " --track " + track + " --out " + one);
  ASSERT_EQ(r.code, 0) << r.output;
  r = RunFacecap("export textures --library " + library + " --track " + track + " --out " + two, 2);
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
  for (int ranks : {2, 3}) {
    auto r = RunFacecap(train(dir_->File("texnet" + std::to_string(ranks) + ".h5")), ranks);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("weights identical on " + std::to_string(ranks) + " rank(s)"), std::string::npos)
        << r.output;
  }
  const std::string straight = dir_->File("texnet_straight.h5"), stopped = dir_->File("texnet_stopped.h5");
  ASSERT_EQ(RunFacecap(train(straight)).code, 0);
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
  auto r = RunFacecap("textures train --scans " + Scans() + " --epochs 6 --batch 4 --channels 8 --residual-blocks 1 "
                      "--learning-rate 2e-3 --threads 2 --out " + model);
  ASSERT_EQ(r.code, 0) << r.output;
  r = RunFacecap("eval textures --scans " + Scans() + " --model " + model);
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* layer : {"albedo_db", "specular_db"}) {
    EXPECT_GT(Nested(r.output, "network_expressions", layer), Nested(r.output, "static_neutral", layer) + 0.5)
        << layer << "\n" << r.output;
  }
  const std::string library = dir_->File("predicted_library.h5");
  r = RunFacecap("textures infer --model " + model + " --scans " + Scans() + " --person 3 --rig " + TemplateRigFile() +
                 " --out " + library);
  ASSERT_EQ(r.code, 0) << r.output;
  const io::H5File f = io::H5File::OpenRead(library);
  EXPECT_EQ(f.DatasetShape("/predicted"), (io::Shape{24, 64, 64, 5}));
  EXPECT_EQ(f.DatasetShape("/dynamic_texture/compress"), (io::Shape{64, 64, 5}));
  r = RunFacecap("render --rig " + library + " --weights jawOpen=1 --size 64 --out " + dir_->File("predicted.png"));
  ASSERT_EQ(r.code, 0) << r.output;
  auto wrong = RunFacecap("textures infer --model " + Scans() + " --scans " + Scans() + " --rig " + TemplateRigFile() +
                          " --out " + dir_->File("no_library.h5"));
  EXPECT_NE(wrong.code, 0);
  EXPECT_NE(wrong.output.find("not a texture network model"), std::string::npos) << wrong.output;
}

}  // namespace
}  // namespace facecap::stages
