// facecap scans / blendshapes end to end on a tiny database: training (with weight decay, as the
// job trains) on 2 and 3 ranks keeps the parameters identical across ranks, a stopped training
// resumes to the uninterrupted result, and the comparison prints its JSON and infers a rig.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "stages/blendshapes_stage.h"
#include "stages/scans_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

class Blendshapes : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    ScansSynthOptions synth;
    synth.people = 5;
    synth.test_people = 1;
    synth.out = Scans();
    RunInProcess(RunScansSynth, synth, "scans.synth");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Scans() { return dir_->File("scans.h5"); }
  static std::string Train(const std::string& out) {
    return "blendshapes train --scans " + Scans() + " --image-size 32 --channels 4 --residual-blocks 1"
           " --estimation-epochs 2 --tuning-epochs 1 --batch 3 --threads 1 --checkpoint-every 100"
           " --weight-decay 0.5 --out " + out;
  }
  // The options of Train(out), for a run in this process.
  static BlendshapesTrainOptions TrainOptions(const std::string& out) {
    BlendshapesTrainOptions o;
    o.scans = Scans();
    o.image_size = 32;
    o.net.channels = 4;
    o.net.residual_blocks = 1;
    o.estimation_epochs = 2;
    o.tuning_epochs = 1;
    o.batch = 3;
    o.threads = 1;
    o.checkpoint_every = 100;
    o.net.weight_decay = 0.5f;
    o.out = out;
    return o;
  }
  // Person 4's neutral (to *neutral) as an OBJ through `blendshapes infer --model model`: the
  // rig it writes (an empty one when it fails).
  static rig::Rig InferRig(const std::string& model, const std::string& tag, rig::Vertices* neutral) {
    const io::H5File scans = io::H5File::OpenRead(Scans());
    const rig::Rig tmpl = io::ReadRig(scans, "/template");
    *neutral = rig::Vertices(tmpl.NumVertices(), 3);
    scans.ReadFrames<float>("/scans/people/neutral", 4, 1, neutral->data());
    const std::string obj = dir_->File(tag + "_neutral.obj"), out = dir_->File(tag + "_rig.h5");
    io::ExportMeshObj(*neutral, tmpl.triangles, nullptr, nullptr, obj);
    BlendshapesInferOptions o;
    o.model = model;
    o.neutral = obj;
    o.out = out;
    try {
      RunInProcess(RunBlendshapesInfer, o, "blendshapes.infer");
    } catch (const Error& e) {
      ADD_FAILURE() << e.what();
      return rig::Rig();
    }
    return io::ReadRigFile(out);
  }
  static std::vector<float> Parameters(const std::string& path) {
    return io::H5File::OpenRead(path).ReadVector<float>("/model/parameters");
  }
  static testing::TempDir* dir_;
};

testing::TempDir* Blendshapes::dir_ = nullptr;

TEST_F(Blendshapes, TwoAndThreeRanksKeepIdenticalParameters) {
  for (int ranks : {2, 3}) {
    const std::string out = dir_->File("ranks" + std::to_string(ranks) + ".h5");
    auto r = RunFacecap(Train(out), ranks);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("weights identical on " + std::to_string(ranks) + " rank(s)"), std::string::npos)
        << r.output;
  }
}

TEST_F(Blendshapes, StoppedTrainingResumesToTheUninterruptedParameters) {
  const std::string straight = dir_->File("straight.h5"), stopped = dir_->File("stopped.h5");
  RunInProcess(RunBlendshapesTrain, TrainOptions(straight), "blendshapes.train");
  auto stop = RunFacecap(Train(stopped), 0, "FACECAP_FAULT_AFTER_STEPS=3");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  EXPECT_FALSE(std::filesystem::exists(stopped));
  auto rerun = RunFacecap(Train(stopped));
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  EXPECT_EQ(Parameters(straight), Parameters(stopped));
}

// The principal-component amplitude: its basis is recomputed from the training people when a
// stopped run continues (the same basis, so the same parameters), and the model file carries it
// to inference.
TEST_F(Blendshapes, PrincipalComponentAmplitudeResumesAndTravelsInTheModelFile) {
  const std::string straight = dir_->File("pca_straight.h5"), stopped = dir_->File("pca_stopped.h5");
  const std::string flags = " --amplitude-components 3";
  auto pca = [](const std::string& out) {
    BlendshapesTrainOptions o = TrainOptions(out);
    o.net.amplitude_components = 3;
    return o;
  };
  RunInProcess(RunBlendshapesTrain, pca(straight), "blendshapes.train");
  auto stop = RunFacecap(Train(stopped) + flags, 0, "FACECAP_FAULT_AFTER_STEPS=3");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  RunInProcess(RunBlendshapesTrain, pca(stopped), "blendshapes.train");
  EXPECT_EQ(Parameters(straight), Parameters(stopped));
  const io::H5File f = io::H5File::OpenRead(straight);
  io::Shape shape;
  f.Read<float>("/model/amplitude_basis", {}, &shape);
  EXPECT_EQ(shape, (io::Shape{4, 768}));
  rig::Vertices neutral;
  EXPECT_EQ(InferRig(straight, "pca", &neutral).NumShapes(), 55);
}

// Iterate averaging (average_fraction): the Estimation Stage of 4 steps at fraction 0.5 ends on
// the mean of the parameters after steps 3 and 4, and a run stopped between them resumes to
// the uninterrupted result.
TEST_F(Blendshapes, IterateAveragingEndsOnTheMeanAndResumes) {
  auto train = [](const std::string& out, bool averaged) {
    std::string command = Train(out) + (averaged ? " --average-fraction 0.5" : "");
    const std::string tuning = "--tuning-epochs 1";
    return command.replace(command.find(tuning), tuning.size(), "--tuning-epochs 0");
  };
  auto train_options = [](const std::string& out, bool averaged) {
    BlendshapesTrainOptions o = TrainOptions(out);
    if (averaged) o.average_fraction = 0.5f;
    o.tuning_epochs = 0;
    return o;
  };
  const std::string last = dir_->File("avg_last.h5"), third = dir_->File("avg_third.h5");
  const std::string mean = dir_->File("avg_mean.h5"), resumed = dir_->File("avg_resumed.h5");
  RunInProcess(RunBlendshapesTrain, train_options(last, false), "blendshapes.train");
  ASSERT_EQ(RunFacecap(train(third, false), 0, "FACECAP_FAULT_AFTER_STEPS=3").code, kExitInterrupted);
  RunInProcess(RunBlendshapesTrain, train_options(mean, true), "blendshapes.train");
  const std::vector<float> p4 = Parameters(last), averaged = Parameters(mean);
  const std::vector<float> state = io::H5File::OpenRead(third + ".checkpoint").ReadVector<float>("/optimizer/state");
  ASSERT_EQ(averaged.size(), p4.size());
  ASSERT_GT(state.size(), p4.size());
  double worst = 0, moved = 0;
  for (size_t k = 0; k < p4.size(); ++k) {
    const double expected = 0.5 * (static_cast<double>(state[k]) + p4[k]);
    worst = std::max(worst, std::abs(averaged[k] - expected) / (1e-3 + std::abs(expected)));
    moved = std::max(moved, std::abs(static_cast<double>(state[k]) - p4[k]));
  }
  EXPECT_GT(moved, 1e-4);  // the two iterates differ, so the mean is not either of them
  EXPECT_LT(worst, 1e-5);
  auto stop = RunFacecap(train(resumed, true), 0, "FACECAP_FAULT_AFTER_STEPS=3");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  EXPECT_TRUE(io::H5File::OpenRead(resumed + ".checkpoint").Exists("/optimizer/parameter_sum"));
  RunInProcess(RunBlendshapesTrain, train_options(resumed, true), "blendshapes.train");
  EXPECT_EQ(Parameters(resumed), averaged);
}

TEST_F(Blendshapes, BaselinesEvalAndInferenceProduceTheTableAndARig) {
  const std::string model = dir_->File("model.h5"), baselines = dir_->File("baselines.h5");
  RunInProcess(RunBlendshapesTrain, TrainOptions(model), "blendshapes.train");
  BlendshapesBaselinesOptions b;
  b.scans = Scans();
  b.example.iterations = 1;
  b.out = baselines;
  RunInProcess(RunBlendshapesBaselines, b, "blendshapes.baselines");
  const std::string shapes = dir_->File("shapes.h5");
  auto e = RunFacecap("eval blendshapes --scans " + Scans() + " --baselines " + baselines + " --model " + model +
                      " --shapes " + shapes + " --json");
  ASSERT_EQ(e.code, 0) << e.output;
  for (const char* key : {"\"template_train\"", "\"template_test\"", "\"example_based_train\"", "\"example_based_test\"",
                          "\"ours_train\"", "\"ours_test\"", "\"ours_vs_truth_test\"", "\"ours_estimation_test\"", "\"truth_test\"",
                          "\"unseen_expressions\""}) {
    EXPECT_NE(e.output.find(key), std::string::npos) << key << "\n" << e.output;
  }
  // The true personal shapes reconstruct the captured expressions better than the template:
  // the database's personal motion is real and the floor is below every method.
  auto number = [&](const std::string& key) {
    const size_t at = e.output.find("\"" + key + "\": ");
    EXPECT_NE(at, std::string::npos) << key;
    return at == std::string::npos ? 0.0 : std::stod(e.output.substr(at + key.size() + 4));
  };
  EXPECT_LT(number("truth_test"), number("template_test"));
  EXPECT_LT(number("truth_test"), number("ours_test"));
  // The shapes file: every person's shapes, and per-scan errors whose held-out mean is the table's.
  {
    const io::H5File f = io::H5File::OpenRead(shapes);
    io::Shape shape;
    f.Read<float>("/shapes/ours/deltas", {}, &shape);
    ASSERT_EQ(shape.size(), 4u);
    EXPECT_EQ(shape[0], 5);
    EXPECT_EQ(shape[1], 55);
    const std::vector<float> errors = f.Read<float>("/errors/ours", {}, &shape);
    const std::vector<int32_t> split = f.ReadVector<int32_t>("/errors/split");
    ASSERT_EQ(shape[0], 5);
    double sum = 0;
    int count = 0;
    for (int j = 0; j < 5; ++j) {
      for (int64_t k = 0; k < shape[1] && split[j] == 1; ++k, ++count) sum += errors[j * shape[1] + k];
    }
    ASSERT_GT(count, 0);
    EXPECT_NEAR(sum / count, number("ours_test"), 1e-3);
  }
  // analysis/blendshapes_ceiling.py rebuilds every true shape from the stored factors (it exits
  // 3 when they differ) and scores shapes like eval: its truth and ours rows equal eval's.
  {
    const std::string script = "/usr/bin/python3 " + testing::SourceDir() + "/analysis/blendshapes_ceiling.py";
    auto c = testing::RunCommand(script + " --scans " + Scans() + " --shapes " + shapes + " --json");
    ASSERT_EQ(c.code, 0) << c.output;
    auto ceiling = [&](const std::string& key) {
      const size_t at = c.output.find("\"" + key + "\": ");
      EXPECT_NE(at, std::string::npos) << key << "\n" << c.output;
      return at == std::string::npos ? 0.0 : std::stod(c.output.substr(at + key.size() + 4));
    };
    EXPECT_NEAR(ceiling("truth"), number("truth_test"), 1e-3);
    EXPECT_NEAR(ceiling("ours"), number("ours_test"), 1e-3);
    auto bad = testing::RunCommand(script + " --scans " + baselines);
    EXPECT_EQ(bad.code, 3) << bad.output;
    EXPECT_NE(bad.output.find(baselines), std::string::npos) << bad.output;
  }
  // One neutral mesh to a rig.
  rig::Vertices neutral;
  const rig::Rig personal = InferRig(model, "plain", &neutral);
  EXPECT_EQ(personal.NumShapes(), 55);
  EXPECT_EQ(personal.neutral, neutral);
  // The same person named in the database instead of an OBJ: the same rig.
  const std::string from_scans = dir_->File("from_scans_rig.h5");
  BlendshapesInferOptions infer;
  infer.model = model;
  infer.scans = Scans();
  infer.person = "4";
  infer.out = from_scans;
  RunInProcess(RunBlendshapesInfer, infer, "blendshapes.infer");
  const rig::Rig again = io::ReadRigFile(from_scans);
  EXPECT_EQ(again.neutral, personal.neutral);
  ASSERT_EQ(again.NumShapes(), personal.NumShapes());
  for (int i = 0; i < again.NumShapes(); ++i) {
    EXPECT_EQ(again.shapes[i].delta.vertex, personal.shapes[i].delta.vertex);
    EXPECT_EQ(again.shapes[i].delta.offset, personal.shapes[i].delta.offset);
  }
  BlendshapesInferOptions both;
  both.model = model;
  both.scans = Scans();
  both.neutral = dir_->File("plain_neutral.obj");
  both.out = dir_->File("both.h5");
  try {
    RunInProcess(RunBlendshapesInfer, both, "blendshapes.infer");
    ADD_FAILURE() << "blendshapes infer with both neutral and scans did not fail";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("either neutral"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace facecap::stages
