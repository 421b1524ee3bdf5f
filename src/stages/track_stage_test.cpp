// facecap track and eval track end to end on a few 64x64 synthetic samples: rank-count
// independence, a killed run continued to the uninterrupted result, and the metrics JSON.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "stages/eval_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_stage.h"
#include "stages/track_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::ReadText;
using testing::RunFacecap;

const char* const kTrackDatasets[] = {"/track/pose", "/track/translation", "/track/scale",
                                      "/track/weights", "/track/cost", "/track/iterations"};

class TrackStage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.num_identity_modes = 20;
    demo_rig.out = File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthSamplesOptions samples;
    samples.rig = demo_rig.out;
    samples.sample.count = 5;
    samples.sample.size = 64;
    samples.sample.yaw_limit_deg = 30.f;
    samples.batch = 2;
    samples.out = File("samples.h5");
    RunInProcess(RunSynthSamples, samples, "synth.samples");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static std::string Args(const std::string& out) {
    return "track --rig " + File("rig.h5") + " --targets " + File("samples.h5") +
           " --levels 1 --epochs 2 --batch 1 --out " + out;
  }
  // The options Args(out) gives on the command line.
  static TrackOptions Options(const std::string& out) {
    TrackOptions o;
    o.rig = File("rig.h5");
    o.targets = File("samples.h5");
    o.tracker.levels = 1;
    o.tracker.epochs = 2;
    o.batch = 1;
    o.out = out;
    return o;
  }
  // eval track --json of `track` against the samples, its JSON written to File(json) and
  // returned.
  static std::string EvalJson(const std::string& track, const std::string& json,
                              bool per_frame = false) {
    EvalTrackOptions o;
    o.truth = File("samples.h5");
    o.track = track;
    o.rig = File("rig.h5");
    o.json = true;
    o.per_frame = per_frame;
    o.out = File(json);
    RunInProcess(RunEvalTrack, o, "eval.track");
    return ReadText(o.out);
  }
  static std::vector<uint8_t> Bytes(const std::string& path, const std::string& name) {
    io::H5File f = io::H5File::OpenRead(path);
    if (name == "/track/cost") {
      std::vector<double> v = f.Read<double>(name, {});
      std::vector<uint8_t> b(v.size() * sizeof(double));
      std::memcpy(b.data(), v.data(), b.size());
      return b;
    }
    if (name == "/track/iterations") {
      std::vector<int32_t> v = f.Read<int32_t>(name, {});
      std::vector<uint8_t> b(v.size() * sizeof(int32_t));
      std::memcpy(b.data(), v.data(), b.size());
      return b;
    }
    std::vector<float> v = f.Read<float>(name, {});
    std::vector<uint8_t> b(v.size() * sizeof(float));
    std::memcpy(b.data(), v.data(), b.size());
    return b;
  }
  static void ExpectSameDatasets(const std::string& a, const std::string& b) {
    for (const char* name : kTrackDatasets) {
      EXPECT_EQ(Bytes(a, name), Bytes(b, name)) << name << " differs between " << a << " and " << b;
    }
  }
  static testing::TempDir* dir_;
};

testing::TempDir* TrackStage::dir_ = nullptr;

TEST_F(TrackStage, OneAndThreeRanksWriteIdenticalTracksAndEvalReportsMetrics) {
  const std::string one = File("one.h5"), three = File("three.h5");
  auto r1 = RunFacecap(Args(one), 1);
  ASSERT_EQ(r1.code, 0) << r1.output;
  auto r3 = RunFacecap(Args(three), 3);
  ASSERT_EQ(r3.code, 0) << r3.output;
  ExpectSameDatasets(one, three);
  io::H5File f = io::H5File::OpenRead(three);
  EXPECT_EQ(f.GetIntAttribute("/", "mpi_ranks"), 3);
  EXPECT_EQ(f.ReadStrings("/track/shape_names").size(), 52u);
  EXPECT_EQ(f.ReadStrings("/track/shape_names").front(), "eyeBlinkLeft");

  const std::string e = EvalJson(one, "eval.json");
  for (const char* key : {"\"frames\": 5", "pose_err_deg_mean", "weights_mae", "landmark_nme",
                          "vertex_err_rel_mean", "sec_per_frame", "weights_mae_per_shape",
                          "weights_mae_neutral"}) {
    EXPECT_NE(e.find(key), std::string::npos) << key << " missing in " << e;
  }
  // The neutral face's weight MAE is the mean |w| of the truth's weights (all 52 shapes).
  const auto truth_weights = io::H5File::OpenRead(File("samples.h5")).ReadMatrix<float>("/samples/weights");
  ASSERT_EQ(truth_weights.cols(), 52);
  const double expected = truth_weights.cwiseAbs().mean();
  const std::string key = "\"weights_mae_neutral\": ";
  const size_t at = e.find(key);
  ASSERT_NE(at, std::string::npos) << e;
  EXPECT_NEAR(std::stod(e.substr(at + key.size())), expected, 1e-5 + 1e-4 * expected);

  // Each frame's errors (per_frame), whose means are the summary's.
  const std::string p = EvalJson(one, "eval_per_frame.json", /*per_frame=*/true);
  auto number = [&](const std::string& name) {
    const size_t k = p.find("\"" + name + "\": ");
    EXPECT_NE(k, std::string::npos) << name << " missing in " << p;
    return k == std::string::npos ? -1.0 : std::stod(p.substr(k + name.size() + 4));
  };
  auto array = [&](const std::string& name) {
    std::vector<double> values;
    const size_t k = p.find("\"" + name + "\": [");
    if (k == std::string::npos) return values;
    std::istringstream in(p.substr(k + name.size() + 5, p.find(']', k) - k - name.size() - 5));
    std::string item;
    while (std::getline(in, item, ',')) values.push_back(std::stod(item));
    return values;
  };
  EXPECT_EQ(array("frame"), (std::vector<double>{0, 1, 2, 3, 4}));
  for (const auto& [name, mean] : {std::pair<std::string, std::string>{"pose_err_deg", "pose_err_deg_mean"},
                                   {"weights_mae", "weights_mae"}, {"landmark_nme", "landmark_nme"}}) {
    const std::vector<double> values = array(name);
    ASSERT_EQ(values.size(), 5u) << name << " in " << p;
    const double m = std::accumulate(values.begin(), values.end(), 0.0) / 5;
    EXPECT_NEAR(m, number(mean), 1e-5 * (1 + std::abs(m))) << name;
  }
}

// The stage called in-process (its header's Run) writes what the command writes, and says
// what it did: five frames solved, then none on a rerun of the complete output.
TEST_F(TrackStage, InProcessRunWritesWhatTheCommandWrites) {
  const std::string command = File("command.h5"), in_process = File("in_process.h5");
  auto r = RunFacecap(Args(command));
  ASSERT_EQ(r.code, 0) << r.output;
  TrackOptions o;
  o.rig = File("rig.h5");
  o.targets = File("samples.h5");
  o.out = in_process;
  o.batch = 1;
  o.tracker.levels = 1;
  o.tracker.epochs = 2;
  const StageSummary first = RunInProcess(RunTrack, o, "track");
  EXPECT_EQ(first.out, in_process);
  EXPECT_EQ(first.unit, "frames");
  EXPECT_EQ(first.items, 5);
  EXPECT_EQ(first.computed, 5);
  ExpectSameDatasets(command, in_process);
  EXPECT_EQ(RunInProcess(RunTrack, o, "track").computed, 0);
  o.tracker.levels = 0;
  EXPECT_THROW(RunInProcess(RunTrack, o, "track"), InvalidInputError);
}

TEST_F(TrackStage, KilledRunContinuesToTheUninterruptedResult) {
  const std::string straight = File("straight.h5"), killed = File("killed.h5");
  RunInProcess(RunTrack, Options(straight), "track");
  auto crash = RunFacecap(Args(killed), 0, "FACECAP_FAULT_AFTER_FRAMES=3 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  EXPECT_FALSE(std::filesystem::exists(killed));
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap(Args(killed), 2);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  ExpectSameDatasets(straight, killed);
}

// One rank of three is killed (SIGKILL: no checkpoint, as a crash or a lost node) after a few
// frames are committed; mpirun takes the others down. The rerun on two ranks continues from
// the committed frames, and no frame is lost or solved twice: the result equals the
// uninterrupted run.
TEST_F(TrackStage, RankKilledMidRunOnThreeRanksContinuesOnTwo) {
  const std::string straight = File("straight3.h5"), killed = File("killed3.h5");
  RunInProcess(RunTrack, Options(straight), "track");
  auto crash = RunFacecap(Args(killed), 3,
                          "FACECAP_FAULT_AFTER_FRAMES=3 FACECAP_FAULT_RANK=1 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0) << crash.output;
  EXPECT_FALSE(std::filesystem::exists(killed));
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap(Args(killed), 2);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  EXPECT_NE(rerun.output.find("3 of 5"), std::string::npos) << rerun.output;
  ExpectSameDatasets(straight, killed);
}

// Real footage has frames without a face (ingest's /frames/found, copied beside the
// translations): such a frame is not solved, the previous frame's solution is held, the next
// frame starts from it, and the evaluation leaves the frame out.
TEST_F(TrackStage, FramesWithoutAFaceAreHeldNotSolved) {
  const std::string targets = File("targets_found.h5");
  std::filesystem::copy_file(File("samples.h5"), targets,
                             std::filesystem::copy_options::overwrite_existing);
  {
    io::H5File f = io::H5File::OpenReadWrite(targets);
    f.WriteVector<uint8_t>("/samples/found", {1, 1, 0, 1, 1});
  }
  const std::string out = File("held.h5"), plain = File("plain.h5");
  const std::string common = " --rig " + File("rig.h5") +
                             " --levels 1 --epochs 2 --init previous --segment-frames 5 --out ";
  auto r = RunFacecap("track --targets " + targets + common + out, 2);
  ASSERT_EQ(r.code, 0) << r.output;
  TrackOptions p;
  p.targets = File("samples.h5");
  p.rig = File("rig.h5");
  p.tracker.levels = 1;
  p.tracker.epochs = 2;
  p.init = "previous";
  p.segment_frames = 5;
  p.out = plain;
  RunInProcess(RunTrack, p, "track");
  io::H5File f = io::H5File::OpenRead(out), g = io::H5File::OpenRead(plain);
  const auto termination = f.ReadVector<int32_t>("/track/termination");
  const auto cost = f.ReadVector<double>("/track/cost");
  const auto pose = f.ReadMatrix<float>("/track/pose", 5, 3);
  const auto weights = f.Read<float>("/track/weights", {});
  const auto plain_pose = g.ReadMatrix<float>("/track/pose", 5, 3);
  EXPECT_EQ(termination[2], 3);
  EXPECT_TRUE(std::isnan(cost[2]));
  EXPECT_EQ(pose.row(2), pose.row(1)) << "the frame without a face holds the previous solution";
  const size_t S = weights.size() / 5;
  for (size_t k = 0; k < S; ++k) EXPECT_EQ(weights[2 * S + k], weights[S + k]);
  // Frames before it are solved as without the flags; frame 3 is solved, not held.
  EXPECT_EQ(pose.row(0), plain_pose.row(0));
  EXPECT_EQ(pose.row(1), plain_pose.row(1));
  EXPECT_NE(termination[3], 3);
  EXPECT_TRUE(std::isfinite(cost[3]));

  const std::string e = EvalJson(out, "eval_held.json");
  EXPECT_NE(e.find("\"frames\": 4, \"frames_without_target\": 1"), std::string::npos) << e;
  EXPECT_EQ(e.find("nan"), std::string::npos) << e;
}

TEST_F(TrackStage, RejectsBadOptions) {
  EXPECT_EQ(RunFacecap(Args(File("bad.h5")) + " --init sideways").code, kExitUsage);
  TrackOptions o = Options(File("bad.h5"));
  o.tracker.objective = "pixels";
  EXPECT_THROW(RunInProcess(RunTrack, o, "track"), InvalidInputError);
}

}  // namespace
}  // namespace facecap::stages
