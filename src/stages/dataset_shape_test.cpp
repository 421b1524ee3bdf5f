// Datasets whose shapes disagree with what they are read with (truth weights of 51 columns
// for 52 shape names, poses of 2 columns) are input errors (exit 3) naming the file and the
// dataset, never reads at the wrong stride.
#include <string>
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

using testing::RunFacecap;

class DatasetShapes : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = dir_.File("rig.h5");
    truth_ = dir_.File("samples.h5");
    track_ = dir_.File("track.h5");
    RigDemoOptions demo_rig;
    demo_rig.out = rig_;
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthSamplesOptions samples;
    samples.rig = rig_;
    samples.out = truth_;
    samples.sample.count = 3;
    samples.sample.size = 48;
    RunInProcess(RunSynthSamples, samples, "synth.samples");
    TrackOptions track;
    track.rig = rig_;
    track.targets = truth_;
    track.targets_dataset = "/samples/segmentation";
    track.out = track_;
    RunInProcess(RunTrack, track, "track");
  }

  // Replaces `name` of the truth file by a [rows, cols] dataset of zeros.
  void Reshape(const std::string& name, int64_t rows, int64_t cols) {
    io::H5File f = io::H5File::OpenReadWrite(truth_);
    f.Remove(name);
    const std::vector<float> zeros(rows * cols, 0.f);
    f.Write<float>(name, {rows, cols}, zeros.data());
    f.Close();
  }

  testing::CommandResult Eval() {
    return RunFacecap("eval track --truth " + truth_ + " --track " + track_ + " --rig " + rig_);
  }
  // The options Eval() gives on the command line.
  EvalTrackOptions EvalOptions() const {
    EvalTrackOptions o;
    o.truth = truth_;
    o.track = track_;
    o.rig = rig_;
    return o;
  }

  testing::TempDir dir_;
  std::string rig_, truth_, track_;
};

TEST_F(DatasetShapes, EvalTrackRunsOnTheUntouchedFiles) {
  EXPECT_NO_THROW(RunInProcess(RunEvalTrack, EvalOptions(), "eval.track"));
}

TEST_F(DatasetShapes, TruthWeightsWithAColumnMissingAreAnInputError) {
  Reshape("/samples/weights", 3, 51);
  try {
    RunInProcess(RunEvalTrack, EvalOptions(), "eval.track");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.code(), kExitInput) << what;
    EXPECT_NE(what.find(truth_), std::string::npos) << what;
    EXPECT_NE(what.find("/samples/weights"), std::string::npos) << what;
  }
}

TEST_F(DatasetShapes, TruthPosesOfTwoColumnsAreAnInputError) {
  Reshape("/samples/pose", 3, 2);
  const auto r = Eval();
  EXPECT_EQ(r.code, kExitInput) << r.output;
  EXPECT_NE(r.output.find("/samples/pose"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace facecap::stages
