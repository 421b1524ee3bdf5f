// synth contract and synth expand end to end on codes with planted outliers and gaps: the
// planted samples are the ones removed, the kept rows are the source's, the expanded set is
// bitwise the same on 1, 2 and 3 ranks and its new samples follow the gap frames' solutions.
#include <cmath>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/rig_io.h"
#include "stages/rig_stage.h"
#include "stages/sample_set_stage.h"
#include "stages/synth_stage.h"
#include "testing/testing.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

constexpr int kSamples = 40, kFrames = 20, kDim = 8;

// Codes around `center` (unit Gaussian spread).
void AddCodes(Rng* rng, double center, int rows, std::vector<float>* codes) {
  for (int i = 0; i < rows * kDim; ++i) codes->push_back(static_cast<float>(center + rng->Normal()));
}

class SampleSet : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.out = File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthSamplesOptions synth;
    synth.rig = File("rig.h5");
    synth.sample.count = kSamples;
    synth.sample.size = 32;
    synth.out = File("samples.h5");
    RunInProcess(RunSynthSamples, synth, "synth.samples");
    Rng rng(9, 0);
    // Samples: every fifth far from the real frames (the planted outliers).
    std::vector<float> sample_codes;
    for (int i = 0; i < kSamples; ++i) AddCodes(&rng, i % 5 == 3 ? 8.0 : 0.0, 1, &sample_codes);
    // Frames: the last four far from every sample (the planted gaps), frame 0 without a face.
    std::vector<float> frame_codes;
    for (int i = 0; i < kFrames; ++i) AddCodes(&rng, i >= kFrames - 4 ? -8.0 : 0.0, 1, &frame_codes);
    WriteCodes(File("sample_codes.h5"), sample_codes, kSamples, {});
    std::vector<uint8_t> found(kFrames, 1);
    found[0] = 0;
    WriteCodes(File("frame_codes.h5"), frame_codes, kFrames, found);
    // The tracker's solutions: the gap frames smile with the jaw open, the others are neutral.
    const io::H5File samples = io::H5File::OpenRead(File("samples.h5"));
    names_ = samples.ReadStrings("/samples/shape_names");
    std::vector<float> weights(kFrames * names_.size(), 0.f), pose(kFrames * 3, 0.f);
    for (int i = kFrames - 4; i < kFrames; ++i) {
      for (size_t s = 0; s < names_.size(); ++s) {
        if (names_[s] == "jawOpen") weights[i * names_.size() + s] = 0.5f + 0.1f * (i % 2);
        if (names_[s] == "mouthSmileLeft") weights[i * names_.size() + s] = 0.6f;
      }
      pose[i * 3 + 1] = 0.3f;  // yaw
    }
    io::H5File track = io::H5File::CreateAtomic(File("track.h5"));
    track.Write<float>("/track/weights", {kFrames, static_cast<int64_t>(names_.size())}, weights.data());
    track.Write<float>("/track/pose", {kFrames, 3}, pose.data());
    track.Commit();
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static void WriteCodes(const std::string& path, const std::vector<float>& codes, int rows,
                         const std::vector<uint8_t>& found) {
    io::H5File f = io::H5File::CreateAtomic(path);
    f.Write<float>("/frames/latent", {rows, kDim}, codes.data());
    f.Write<float>("/frames/latent_of_translation", {rows, kDim}, codes.data());
    std::vector<uint8_t> translated(rows * 16 * 16 * 3, 128);
    f.Write<uint8_t>("/frames/translated", {rows, 16, 16, 3}, translated.data());
    if (!found.empty()) f.WriteVector("/frames/found", found);
    f.Commit();
  }
  static SynthContractOptions ContractOptions(const std::string& out) {
    SynthContractOptions o;
    o.samples = File("samples.h5");
    o.sample_codes = File("sample_codes.h5");
    o.frame_codes = File("frame_codes.h5");
    o.out = out;
    return o;
  }
  static std::string Expand(const std::string& out) {
    return "synth expand --rig " + File("rig.h5") + " --samples " + File("contracted.h5") +
           " --frame-codes " + File("frame_codes.h5") + " --track " + File("track.h5") +
           " --out " + out + " --batch 3";
  }
  // The options of Expand, for a run in this process.
  static SynthExpandOptions ExpandOptions(const std::string& out) {
    SynthExpandOptions o;
    o.rig = File("rig.h5");
    o.samples = File("contracted.h5");
    o.frame_codes = File("frame_codes.h5");
    o.track = File("track.h5");
    o.out = out;
    o.batch = 3;
    return o;
  }
  static testing::TempDir* dir_;
  static std::vector<std::string> names_;
};

testing::TempDir* SampleSet::dir_ = nullptr;
std::vector<std::string> SampleSet::names_;

TEST_F(SampleSet, ContractionRemovesThePlantedOutliersAndKeepsTheRest) {
  RunInProcess(RunSynthContract, ContractOptions(File("contracted.h5")), "synth.contract");
  EXPECT_TRUE(std::filesystem::exists(File("contracted_contraction.png")));
  const io::H5File in = io::H5File::OpenRead(File("samples.h5"));
  const io::H5File out = io::H5File::OpenRead(File("contracted.h5"));
  const auto source = out.ReadVector<int64_t>("/contraction/source_index");
  ASSERT_EQ(source.size(), static_cast<size_t>(kSamples * 4 / 5));
  for (int64_t i : source) EXPECT_NE(i % 5, 3) << "planted outlier " << i << " kept";
  // The kept rows are the source's rows, image and parameters.
  const auto seg_in = in.Read<uint8_t>("/samples/segmentation", {});
  const auto seg_out = out.Read<uint8_t>("/samples/segmentation", {});
  const auto w_in = in.ReadMatrix<float>("/samples/weights");
  const auto w_out = out.ReadMatrix<float>("/samples/weights");
  const size_t image = 32 * 32 * 3;
  for (size_t j = 0; j < source.size(); ++j) {
    EXPECT_TRUE(std::equal(seg_out.begin() + j * image, seg_out.begin() + (j + 1) * image,
                           seg_in.begin() + source[j] * image)) << j;
    EXPECT_EQ(w_out.row(j), w_in.row(source[j])) << j;
  }
  EXPECT_EQ(out.DatasetShape("/samples/latent"), (io::Shape{static_cast<int64_t>(source.size()), kDim}));
  // The nearest real frame is never the faceless frame 0.
  for (int64_t f : out.ReadVector<int64_t>("/contraction/nearest_frame")) EXPECT_NE(f, 0);
  // The same bound, from the first contraction, removes the same samples.
  SynthContractOptions again = ContractOptions(File("again.h5"));
  again.sheet = "none";
  again.bound = File("contracted.h5");
  RunInProcess(RunSynthContract, again, "synth.contract");
  EXPECT_EQ(io::H5File::OpenRead(File("again.h5")).ReadVector<int64_t>("/contraction/source_index"), source);
}

TEST_F(SampleSet, ExpansionIsTheSameOnOneTwoAndThreeRanksAndFollowsTheGaps) {
  if (!std::filesystem::exists(File("contracted.h5"))) {
    SynthContractOptions contract = ContractOptions(File("contracted.h5"));
    contract.sheet = "none";
    RunInProcess(RunSynthContract, contract, "synth.contract");
  }
  std::vector<std::string> outs;
  for (int ranks : {1, 2, 3}) {
    outs.push_back(File("expanded" + std::to_string(ranks) + ".h5"));
    auto r = RunFacecap(Expand(outs.back()), ranks);
    ASSERT_EQ(r.code, 0) << r.output;
  }
  const io::H5File one = io::H5File::OpenRead(outs[0]);
  for (int k = 1; k < 3; ++k) {
    const io::H5File other = io::H5File::OpenRead(outs[k]);
    EXPECT_EQ(other.Read<uint8_t>("/samples/segmentation", {}), one.Read<uint8_t>("/samples/segmentation", {})) << outs[k];
    EXPECT_EQ(other.Read<float>("/samples/weights", {}), one.Read<float>("/samples/weights", {})) << outs[k];
    EXPECT_EQ(other.Read<float>("/samples/pose", {}), one.Read<float>("/samples/pose", {})) << outs[k];
  }
  // As many samples as the random set; the contracted ones first, unchanged.
  const io::H5File contracted = io::H5File::OpenRead(File("contracted.h5"));
  const int64_t kept = contracted.DatasetShape("/samples/weights")[0];
  const auto w = one.ReadMatrix<float>("/samples/weights");
  ASSERT_EQ(w.rows(), kSamples);
  EXPECT_EQ(w.topRows(kept), contracted.ReadMatrix<float>("/samples/weights"));
  // The gaps are the planted frames; every new sample is a jaw-open smile near their yaw.
  const auto gaps = one.ReadVector<int64_t>("/expansion/gap_frames");
  EXPECT_EQ(std::set<int64_t>(gaps.begin(), gaps.end()),
            (std::set<int64_t>{kFrames - 4, kFrames - 3, kFrames - 2, kFrames - 1}));
  const auto pose = one.ReadMatrix<float>("/samples/pose");
  int jaw = -1;
  for (size_t s = 0; s < names_.size(); ++s) if (names_[s] == "jawOpen") jaw = static_cast<int>(s);
  const auto origin = one.ReadVector<uint8_t>("/samples/origin");
  for (int64_t i = kept; i < kSamples; ++i) {
    EXPECT_EQ(origin[i], 1);
    EXPECT_GE(w(i, jaw), 0.4f) << i;
    EXPECT_LE(w(i, jaw), 0.72f) << i;
    EXPECT_NEAR(pose(i, 1), 0.3f, 0.2f) << i;
  }
  // A rig of other shapes than the samples' is refused, naming it.
  {
    rig::Rig fewer = io::ReadRigFile(File("rig.h5"));
    fewer.shapes.erase(fewer.shapes.begin());  // eyeBlinkLeft: every sparsity group still matches
    io::H5File f = io::H5File::CreateAtomic(File("rig_fewer.h5"));
    io::WriteRig(fewer, &f);
    f.Commit();
    SynthExpandOptions other = ExpandOptions(File("other_rig.h5"));
    other.rig = File("rig_fewer.h5");
    try {
      RunInProcess(RunSynthExpand, other, "synth.expand");
      ADD_FAILURE() << "the rig of other shapes was accepted";
    } catch (const InvalidInputError& e) {
      EXPECT_EQ(e.code(), 2);
      EXPECT_NE(std::string(e.what()).find("rig_fewer.h5"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(File("other_rig.h5")));
  }
  // Killed and rerun, it continues to the same set.
  const std::string killed = File("killed.h5");
  auto crash = RunFacecap(Expand(killed), 0, "FACECAP_FAULT_AFTER_FRAMES=6 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(crash.code, 0);
  RunInProcess(RunSynthExpand, ExpandOptions(killed), "synth.expand");
  EXPECT_EQ(io::H5File::OpenRead(killed).Read<uint8_t>("/samples/segmentation", {}),
            one.Read<uint8_t>("/samples/segmentation", {}));
}

}  // namespace
}  // namespace facecap::stages
