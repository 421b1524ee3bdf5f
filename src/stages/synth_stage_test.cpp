// facecap synth samples end to end: rank-count independence, limits on every sample, and
// restarts after a kill or a SIGTERM that reproduce the uninterrupted dataset.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "stages/rig_stage.h"
#include "stages/synth_stage.h"
#include "synth/samples.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

const char* const kDatasets[] = {"/samples/segmentation", "/samples/weights", "/samples/pose",
                                 "/samples/landmarks", "/samples/landmark_visible"};

class SynthSamples : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.out = Rig();
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Rig() { return dir_->File("rig.h5"); }
  static std::string Args(const std::string& out) {
    return "synth samples --rig " + Rig() + " --count 48 --size 32 --batch 4 --out " + out;
  }
  // The options of Args, for a run in this process.
  static SynthSamplesOptions SamplesOptions(const std::string& out) {
    SynthSamplesOptions o;
    o.rig = Rig();
    o.sample.count = 48;
    o.sample.size = 32;
    o.batch = 4;
    o.out = out;
    return o;
  }
  static std::vector<uint8_t> Bytes(const std::string& path, const std::string& name) {
    io::H5File f = io::H5File::OpenRead(path);
    io::Shape shape = f.DatasetShape(name);
    const int64_t n = io::H5File::NumElements(shape);
    if (name == "/samples/segmentation" || name == "/samples/landmark_visible") {
      return f.Read<uint8_t>(name, {});
    }
    std::vector<float> v = f.Read<float>(name, {});
    std::vector<uint8_t> b(n * sizeof(float));
    std::memcpy(b.data(), v.data(), b.size());
    return b;
  }
  static void ExpectSameDatasets(const std::string& a, const std::string& b) {
    for (const char* name : kDatasets) {
      EXPECT_EQ(Bytes(a, name), Bytes(b, name)) << name << " differs between " << a << " and " << b;
    }
  }
  static testing::TempDir* dir_;
};

testing::TempDir* SynthSamples::dir_ = nullptr;

TEST_F(SynthSamples, OneAndThreeRanksWriteIdenticalDatasets) {
  const std::string one = dir_->File("one.h5"), three = dir_->File("three.h5");
  auto r1 = RunFacecap(Args(one), 1);
  ASSERT_EQ(r1.code, 0) << r1.output;
  auto r3 = RunFacecap(Args(three), 3);
  ASSERT_EQ(r3.code, 0) << r3.output;
  ExpectSameDatasets(one, three);
  io::H5File f = io::H5File::OpenRead(three);
  EXPECT_EQ(f.GetIntAttribute("/", "mpi_ranks"), 3);
  EXPECT_EQ(f.DatasetShape("/samples/segmentation"), (io::Shape{48, 32, 32, 3}));
  // Samples are not all alike: the images differ.
  std::vector<uint8_t> seg = f.Read<uint8_t>("/samples/segmentation", {});
  EXPECT_NE(std::vector<uint8_t>(seg.begin(), seg.begin() + 3072),
            std::vector<uint8_t>(seg.begin() + 3072, seg.begin() + 6144));
}

TEST_F(SynthSamples, SparsityAndPoseLimitsHoldOnEverySample) {
  const std::string out = dir_->File("limits.h5");
  SynthSamplesOptions o = SamplesOptions(out);
  o.sample.sparsity_groups = {"mouth", "eye"};
  o.sample.sparsity_max_active = {3, 1};
  o.sample.yaw_limit_deg = 30.f;
  o.sample.pitch_limit_deg = 5.f;
  RunInProcess(RunSynthSamples, o, "synth.samples");
  io::H5File f = io::H5File::OpenRead(out);
  const auto names = f.ReadStrings("/samples/shape_names");
  const auto w = f.ReadMatrix<float>("/samples/weights", 48, names.size());
  const auto pose = f.ReadMatrix<float>("/samples/pose", 48, 3);
  int active_total = 0;
  for (int i = 0; i < 48; ++i) {
    int mouth = 0, eye = 0;
    for (size_t s = 0; s < names.size(); ++s) {
      const float v = w(i, s);
      ASSERT_GE(v, 0.f);
      ASSERT_LE(v, 1.f);
      if (v == 0.f) continue;
      ++active_total;
      if (names[s].rfind("mouth", 0) == 0) ++mouth;
      else if (names[s].rfind("eye", 0) == 0) ++eye;
      else ADD_FAILURE() << "shape " << names[s] << " is in no group but active in sample " << i;
    }
    EXPECT_LE(mouth, 3) << "sample " << i;
    EXPECT_LE(eye, 1) << "sample " << i;
    EXPECT_LE(std::abs(pose(i, 0)), 5.f * M_PI / 180.f + 1e-6f);
    EXPECT_LE(std::abs(pose(i, 1)), 30.f * M_PI / 180.f + 1e-6f);
  }
  EXPECT_GT(active_total, 48);  // the limits are reached, not just respected by empty samples
}

TEST_F(SynthSamples, IdentitySigmaVariesTheHeadAndNothingElse) {
  const std::string same = dir_->File("same_head.h5"), varied = dir_->File("varied_head.h5");
  RunInProcess(RunSynthSamples, SamplesOptions(same), "synth.samples");
  SynthSamplesOptions o = SamplesOptions(varied);
  o.sample.identity_sigma = 1.f;
  RunInProcess(RunSynthSamples, o, "synth.samples");
  // The controls and the head's pose are drawn as without identities.
  EXPECT_EQ(Bytes(same, "/samples/weights"), Bytes(varied, "/samples/weights"));
  io::H5File a = io::H5File::OpenRead(same), b = io::H5File::OpenRead(varied);
  const auto lm_a = a.Read<float>("/samples/landmarks", {});
  const auto lm_b = b.Read<float>("/samples/landmarks", {});
  const auto seg_a = a.Read<uint8_t>("/samples/segmentation", {});
  const auto seg_b = b.Read<uint8_t>("/samples/segmentation", {});
  // Every sample's head is another one: its landmarks move and its image changes.
  int moved = 0, changed = 0;
  for (int i = 0; i < 48; ++i) {
    float largest = 0.f;
    for (int k = i * 136; k < (i + 1) * 136; ++k) largest = std::max(largest, std::abs(lm_a[k] - lm_b[k]));
    moved += largest > 0.5f;
    changed += !std::equal(seg_a.begin() + i * 3072, seg_a.begin() + (i + 1) * 3072,
                           seg_b.begin() + i * 3072);
  }
  EXPECT_EQ(moved, 48);
  EXPECT_EQ(changed, 48);

  // The coefficients: N(0, sigma^2) truncated to +-2.5 sigma (standard deviation 0.955 sigma).
  synth::SampleOptions so;
  so.identity_sigma = 0.5f;
  so.sparsity_groups = {"mouth", "eye"};
  so.sparsity_max_active = {1, 1};
  rig::Rig rig;
  rig.shapes.resize(2);
  rig.shapes[0].name = "mouthClose";
  rig.shapes[1].name = "eyeBlinkLeft";
  const synth::Sparsity sparsity = synth::ResolveSparsity(rig, so);
  double sum2 = 0.;
  int n = 0;
  for (int64_t i = 0; i < 2000; ++i) {
    const synth::SampleParams p = synth::DrawSample(sparsity, so, 2, i, 24);
    ASSERT_EQ(p.identity.size(), 24);
    EXPECT_LE(p.identity.cwiseAbs().maxCoeff(), 1.25f);
    sum2 += p.identity.squaredNorm();
    n += 24;
  }
  EXPECT_NEAR(std::sqrt(sum2 / n), 0.955 * 0.5, 0.01);
  so.identity_sigma = 0.f;
  EXPECT_EQ(synth::DrawSample(sparsity, so, 2, 0, 24).identity.size(), 0);

  // A rig without identity modes cannot vary the head.
  const std::string plain = dir_->File("plain_rig.h5");
  RigDemoOptions plain_rig;
  plain_rig.out = plain;
  plain_rig.num_identity_modes = 0;
  RunInProcess(RunRigDemo, plain_rig, "rig.demo");
  o.rig = plain;
  o.out = dir_->File("no_modes.h5");
  try {
    RunInProcess(RunSynthSamples, o, "synth.samples");
    ADD_FAILURE() << "identity_sigma was accepted for a rig without identity modes";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find(plain + ": identity_sigma"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

TEST_F(SynthSamples, KilledRunContinuesToTheUninterruptedResult) {
  const std::string straight = dir_->File("straight.h5"), killed = dir_->File("killed.h5");
  RunInProcess(RunSynthSamples, SamplesOptions(straight), "synth.samples");
  auto crash = RunFacecap(Args(killed), 0, "FACECAP_FAULT_AFTER_FRAMES=12 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  EXPECT_FALSE(std::filesystem::exists(killed));
  ASSERT_TRUE(std::filesystem::exists(killed + ".partial"));
  auto rerun = RunFacecap(Args(killed));
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  ExpectSameDatasets(straight, killed);
}

TEST_F(SynthSamples, SigtermCheckpointsExitsWith75AndResumesOnThreeRanks) {
  const std::string straight = dir_->File("straight2.h5"), stopped = dir_->File("stopped.h5");
  RunInProcess(RunSynthSamples, SamplesOptions(straight), "synth.samples");
  auto stop = RunFacecap(Args(stopped), 3, "FACECAP_FAULT_AFTER_FRAMES=12");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  auto rerun = RunFacecap(Args(stopped), 2);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  ExpectSameDatasets(straight, stopped);
  // A third run finds the output up to date.
  auto again = RunFacecap(Args(stopped));
  EXPECT_EQ(again.code, 0);
  EXPECT_NE(again.output.find("up to date"), std::string::npos) << again.output;
}

TEST_F(SynthSamples, BadOptionsAreUsageErrors) {
  const std::string out = dir_->File("bad.h5");
  EXPECT_EQ(RunFacecap(Args(out) + " --count -5").code, kExitUsage);
  SynthSamplesOptions nomatch = SamplesOptions(out);
  nomatch.sample.sparsity_groups = {"lips"};
  nomatch.sample.sparsity_max_active = {5};
  try {
    RunInProcess(RunSynthSamples, nomatch, "synth.samples");
    ADD_FAILURE() << "sparsity group 'lips' was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'lips' matches no shape"), std::string::npos) << e.what();
  }
  SynthSamplesOptions none_active = SamplesOptions(out);
  none_active.sample.sparsity_groups = {"mouth"};
  none_active.sample.sparsity_max_active = {0};
  EXPECT_THROW(RunInProcess(RunSynthSamples, none_active, "synth.samples"), InvalidInputError);
  SynthSamplesOptions yaw = SamplesOptions(out);
  yaw.sample.yaw_limit_deg = 120.f;
  EXPECT_THROW(RunInProcess(RunSynthSamples, yaw, "synth.samples"), InvalidInputError);
  SynthSamplesOptions sigma = SamplesOptions(out);
  sigma.sample.identity_sigma = -1.f;
  EXPECT_THROW(RunInProcess(RunSynthSamples, sigma, "synth.samples"), InvalidInputError);
  SynthSamplesOptions mismatched = SamplesOptions(out);
  mismatched.sample.sparsity_max_active = {1, 2};
  EXPECT_THROW(RunInProcess(RunSynthSamples, mismatched, "synth.samples"), InvalidInputError);
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace facecap::stages
