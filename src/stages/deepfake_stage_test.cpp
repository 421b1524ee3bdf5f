// facecap deepfake train / infer end to end under mpirun: the same weights on every rank,
// a stopped or killed run continued to the bitwise result of the straight run, checkpoints
// that do not fit are refused with a clear message, and inference independent of the ranks.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "io/camera_file.h"
#include "io/hdf5.h"
#include "nn/deepfake.h"
#include "nn/deepfake_io.h"
#include "stages/deepfake_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

// One torch thread per rank: bitwise-reproducible runs.
const char kEnv[] = "OMP_NUM_THREADS=1";

class DeepfakeStage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.out = File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    for (int seed : {1, 2}) {
      SynthSamplesOptions samples;
      samples.rig = File("rig.h5");
      samples.sample.count = 24;
      samples.sample.size = 32;
      samples.sample.seed = seed;
      samples.out = File("samples" + std::to_string(seed) + ".h5");
      RunInProcess(RunSynthSamples, samples, "synth.samples");
    }
    // Domain B: other samples through a colour transform (a stand-in for a wild clip), with
    // the true segmentation beside them.
    io::H5File in = io::H5File::OpenRead(File("samples2.h5"));
    io::Shape shape;
    std::vector<uint8_t> seg = in.Read<uint8_t>("/samples/segmentation", {}, &shape);
    std::vector<uint8_t> image(seg.size());
    for (size_t i = 0; i < seg.size(); i += 3) {
      image[i] = static_cast<uint8_t>(40 + seg[i + 1] * 0.6);
      image[i + 1] = static_cast<uint8_t>(30 + seg[i + 2] * 0.5);
      image[i + 2] = static_cast<uint8_t>(50 + seg[i] * 0.7);
    }
    io::H5File out = io::H5File::CreateAtomic(File("b.h5"));
    out.Write<uint8_t>("/frames/image", shape, image.data());
    out.Write<uint8_t>("/frames/segmentation", shape, seg.data());
    out.Commit();
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static std::string Train(const std::string& out, int steps, int encoder_width = 8) {
    return "deepfake train --a " + File("samples1.h5") + " --b " + File("b.h5") +
           " --size 32 --latent-channels 8 --encoder-width " +
           std::to_string(encoder_width) +
           " --decoder-width 8 --discriminator-width 8 --batch 6 --checkpoint-every 4"
           " --preview-every 4 --progress-seconds 0.01 --steps " + std::to_string(steps) +
           // The plain network and losses these tests were written for, not the subcommand's
           // recipe (its skips need more levels than a 32-pixel network has).
           // A test's own flags override these (--set ranks below flags).
           " --set deepfake.train.network.skips=0 --set deepfake.train.network.decoder_b_width=0"
           " --set deepfake.train.network.input_skip_width=0 --set deepfake.train.network.palette_head=false"
           " --set deepfake.train.loss.palette_weight=0 --set deepfake.train.loss.dice_weight=0"
           " --set deepfake.train.loss.region_l1_weight=2 --set deepfake.train.loss.gradient_clip=0"
           " --set deepfake.train.average_decay=0 --set deepfake.train.augment.random_background=0"
           " --set deepfake.train.paired_fraction=0.5 --out " + out;
  }
  // The options Train(out, steps, encoder_width) gives on the command line, on one torch
  // thread as kEnv gives the command (threads 1 does not read OMP_NUM_THREADS).
  static DeepfakeTrainOptions TrainOptions(const std::string& out, int steps, int encoder_width = 8) {
    DeepfakeTrainOptions o;
    o.a = File("samples1.h5");
    o.b = File("b.h5");
    o.network.size = 32;
    o.network.latent_channels = 8;
    o.network.encoder_width = encoder_width;
    o.network.decoder_width = 8;
    o.network.discriminator_width = 8;
    o.batch = 6;
    o.checkpoint_every = 4;
    o.preview_every = 4;
    o.progress_seconds = 0.01;
    o.steps = steps;
    o.network.skips = 0;
    o.network.decoder_b_width = 0;
    o.network.input_skip_width = 0;
    o.palette_head = false;
    o.loss.palette_weight = 0;
    o.loss.dice_weight = 0;
    o.loss.region_l1_weight = 2;
    o.loss.gradient_clip = 0;
    o.average_decay = 0;
    o.augment.random_background = 0;
    o.paired_fraction = 0.5;
    o.threads = 1;
    o.out = out;
    return o;
  }
  // deepfake infer --model MODEL --frames b.h5 --out OUT's options, on one torch thread as
  // kEnv gives the command.
  static DeepfakeInferOptions InferOptions(const std::string& model, const std::string& out) {
    DeepfakeInferOptions o;
    o.model = model;
    o.frames = File("b.h5");
    o.threads = 1;
    o.out = out;
    return o;
  }
  // What the command would end with for a stage run in-process: code 0, or the exit code of
  // the error it throws, with the error's message as the output.
  template <class Options>
  static testing::CommandResult InProcessResult(
      StageSummary (*run)(const Options&, const StageContext&, const io::Config&),
      const Options& options, const std::string& table) {
    try {
      RunInProcess(run, options, table);
      return {0, ""};
    } catch (const Error& e) {
      return {e.code(), e.what()};
    }
  }
  static std::vector<std::string> RankHashes(const std::string& path) {
    io::H5File f = io::H5File::OpenRead(path);
    std::string text = f.GetStringAttribute("/training", "rank_weight_hashes");
    std::vector<std::string> hashes;
    size_t start = 0;
    for (size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1) {
      hashes.push_back(text.substr(start, comma - start));
    }
    hashes.push_back(text.substr(start));
    return hashes;
  }
  // The hash of the weights as stored, recomputed from the datasets.
  static uint64_t StoredWeightsHash(const std::string& path) {
    io::H5File f = io::H5File::OpenRead(path);
    nn::DeepfakeModel model(nn::ReadNetworkOptions(f), 0);
    nn::ReadWeights(f, &model);
    return model.ParameterHash();
  }
  static std::vector<float> Dataset(const std::string& path, const std::string& name) {
    return io::H5File::OpenRead(path).Read<float>(name, {});
  }
  static testing::TempDir* dir_;
};

testing::TempDir* DeepfakeStage::dir_ = nullptr;

// (With the palette head, the palette and Dice terms on, whose region weights come from every
// rank's shard, the input-resolution skip, and paired frames on random backgrounds from a bank
// every rank draws alike: the same weights for any number of ranks.)
TEST_F(DeepfakeStage, EveryRankHoldsTheSameWeightsOnTwoAndThreeRanks) {
  std::vector<std::string> region_weights;
  for (int ranks : {2, 3}) {
    const std::string out = File("ranks" + std::to_string(ranks) + ".h5");
    auto r = RunFacecap(Train(out, 5) + " --palette-weight 1 --palette-head --dice-weight 1 "
                        "--input-skip-width 4 --paired " + File("b.h5") + " --random-background 1",
                        ranks, kEnv);
    ASSERT_EQ(r.code, 0) << r.output;
    const size_t at = r.output.find("region weights ");
    ASSERT_NE(at, std::string::npos) << r.output;
    region_weights.push_back(r.output.substr(at, r.output.find('\n', at) - at));
    EXPECT_NE(r.output.find("dice_a "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("weights identical on " + std::to_string(ranks) + " rank(s)"),
              std::string::npos) << r.output;
    EXPECT_NE(r.output.find("steps/s"), std::string::npos) << r.output;
    const auto hashes = RankHashes(out);
    ASSERT_EQ(hashes.size(), static_cast<size_t>(ranks));
    char stored[24];
    std::snprintf(stored, sizeof(stored), "%016llx",
                  static_cast<unsigned long long>(StoredWeightsHash(out)));
    for (const auto& h : hashes) EXPECT_EQ(h, stored);
    EXPECT_TRUE(std::filesystem::exists(File("ranks" + std::to_string(ranks) + "_preview.png")));
    EXPECT_FALSE(std::filesystem::exists(out + ".checkpoint"));
  }
  EXPECT_EQ(region_weights[0], region_weights[1]);
  EXPECT_EQ(io::H5File::OpenRead(File("ranks2.h5")).GetIntAttribute("/weights", "palette_colors"), 17);
  EXPECT_NE(region_weights[0].find("background"), std::string::npos) << region_weights[0];
}

// (With the palette head, the Dice term, the input-resolution skip, random backgrounds and
// the moving average of the weights, so that these continue bitwise too.)
TEST_F(DeepfakeStage, StoppedAndKilledRunsContinueToTheStraightResult) {
  const std::string straight = File("straight.h5"), stopped = File("stopped.h5"),
                    killed = File("killed.h5");
  const std::string extra = " --palette-weight 1 --palette-head --dice-weight 1 --input-skip-width 4 "
                            "--paired " + File("b.h5") + " --random-background 0.5 "
                            "--average-decay 0.9";
  auto Train = [&](const std::string& out, int steps) { return DeepfakeStage::Train(out, steps) + extra; };
  ASSERT_EQ(RunFacecap(Train(straight, 10), 2, kEnv).code, 0);
  // SIGTERM after step 3: a checkpoint at step 3, exit 75, then a rerun continues.
  auto stop = RunFacecap(Train(stopped, 10), 2, std::string(kEnv) + " FACECAP_FAULT_AFTER_STEPS=3");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  EXPECT_TRUE(std::filesystem::exists(stopped + ".checkpoint"));
  EXPECT_FALSE(std::filesystem::exists(stopped));
  auto rerun = RunFacecap(Train(stopped, 10), 2, kEnv);
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing " + stopped + ".checkpoint at step 3"), std::string::npos)
      << rerun.output;
  // SIGKILL after step 6: only the checkpoint of step 4 survives.
  auto kill = RunFacecap(Train(killed, 10), 2,
                         std::string(kEnv) + " FACECAP_FAULT_AFTER_STEPS=6 FACECAP_FAULT_SIGNAL=KILL");
  EXPECT_NE(kill.code, 0);
  auto rerun_killed = RunFacecap(Train(killed, 10), 2, kEnv);
  ASSERT_EQ(rerun_killed.code, 0) << rerun_killed.output;
  EXPECT_NE(rerun_killed.output.find("at step 4"), std::string::npos) << rerun_killed.output;
  for (const std::string& other : {stopped, killed}) {
    EXPECT_EQ(StoredWeightsHash(other), StoredWeightsHash(straight)) << other;
    EXPECT_EQ(Dataset(other, "/optimizer/second_moment/decoder_a/rgb/weight"),
              Dataset(straight, "/optimizer/second_moment/decoder_a/rgb/weight"));
    EXPECT_EQ(Dataset(other, "/averaged_weights/encoder/code/weight"),
              Dataset(straight, "/averaged_weights/encoder/code/weight"));
    EXPECT_EQ(io::H5File::OpenRead(other).GetIntAttribute("/training", "step"), 10);
  }
  // Up to date now; more steps continue the finished model.
  auto again = RunFacecap(Train(straight, 10), 0, kEnv);
  EXPECT_EQ(again.code, 0);
  EXPECT_NE(again.output.find("up to date"), std::string::npos) << again.output;
  auto longer = RunFacecap(Train(stopped, 12), 0, kEnv);
  ASSERT_EQ(longer.code, 0) << longer.output;
  EXPECT_NE(longer.output.find("continuing " + stopped + " at step 10"), std::string::npos);
}

TEST_F(DeepfakeStage, CheckpointsThatDoNotFitAreRefusedByName) {
  const std::string out = File("fit.h5");
  RunInProcess(RunDeepfakeTrain, TrainOptions(out, 2), "deepfake.train");
  // Other options than the checkpoint was trained with.
  auto other = RunFacecap(Train(out, 4, 12), 0, kEnv);
  EXPECT_EQ(other.code, kExitUsage) << other.output;
  EXPECT_NE(other.output.find("trained with other data or options"), std::string::npos) << other.output;
  // A model whose tensor has another shape than its recorded architecture.
  {
    io::H5File f = io::H5File::OpenReadWrite(out);
    f.SetAttribute("/weights", "decoder_width", static_cast<int64_t>(16));
  }
  auto mismatch = InProcessResult(RunDeepfakeInfer, InferOptions(out, File("mismatch_translated.h5")),
                                  "deepfake.infer");
  EXPECT_EQ(mismatch.code, kExitInput) << mismatch.output;
  EXPECT_NE(mismatch.output.find("/weights/decoder_a/in/weight has shape [16, 8, 3, 3], the "
                                 "network expects [32, 8, 3, 3]"), std::string::npos) << mismatch.output;
  // A truncated model file.
  std::filesystem::resize_file(out, std::filesystem::file_size(out) / 2);
  auto truncated = RunFacecap("deepfake infer --model " + out + " --frames " + File("b.h5") +
                              " --out " + File("truncated_translated.h5"), 0, kEnv);
  EXPECT_EQ(truncated.code, kExitInput) << truncated.output;
  EXPECT_NE(truncated.output.find(out), std::string::npos) << truncated.output;
}

// (With a palette head, so that the labels are flip-averaged, and the moving average of the
// weights, which infer uses unless told not to: both the defaults; shift averaging and labels
// at twice the network's size, with the camera scaled to them.)
TEST_F(DeepfakeStage, InferenceIsTheSameOnOneAndTwoRanksWithContours) {
  const std::string model = File("infer_model.h5");
  DeepfakeTrainOptions train = TrainOptions(model, 3);
  train.palette_head = true;
  train.loss.palette_weight = 1;
  train.average_decay = 0.5;
  RunInProcess(RunDeepfakeTrain, train, "deepfake.train");
  const std::string one = File("one.h5"), two = File("two.h5");
  const std::string args = "deepfake infer --model " + model + " --frames " + File("b.h5") +
                           " --batch 5 --overlay-count 3 --shift-average 1 --label-scale 2 --camera " +
                           File("samples1.h5") + " --out ";
  {
    io::H5File m = io::H5File::OpenRead(model);
    const std::vector<float> weights = m.ReadVector<float>("/training/region_weights");
    EXPECT_EQ(static_cast<int64_t>(weights.size()), m.GetIntAttribute("/weights", "palette_colors"));
    EXPECT_GT(weights.front(), 0.f);  // the background
  }
  DeepfakeInferOptions infer_one = InferOptions(model, one);
  infer_one.batch = 5;
  infer_one.overlay_count = 3;
  infer_one.shift_average = 1;
  infer_one.label_scale = 2;
  infer_one.camera = File("samples1.h5");
  RunInProcess(RunDeepfakeInfer, infer_one, "deepfake.infer");
  auto r2 = RunFacecap(args + two, 2, kEnv);
  ASSERT_EQ(r2.code, 0) << r2.output;
  EXPECT_NE(r2.output.find("flip-averaged labels"), std::string::npos) << r2.output;
  EXPECT_NE(r2.output.find("averaged weights"), std::string::npos) << r2.output;
  EXPECT_NE(r2.output.find("shift-averaged labels"), std::string::npos) << r2.output;
  EXPECT_NE(r2.output.find("(64 x 64 labels)"), std::string::npos) << r2.output;
  auto last = RunFacecap(args + File("last.h5") + " --no-averaged", 0, kEnv);
  ASSERT_EQ(last.code, 0) << last.output;
  EXPECT_EQ(last.output.find("averaged weights"), std::string::npos) << last.output;
  EXPECT_NE(io::H5File::OpenRead(File("last.h5")).Read<float>("/frames/latent", {}),
            io::H5File::OpenRead(one).Read<float>("/frames/latent", {}));
  io::H5File f1 = io::H5File::OpenRead(one), f2 = io::H5File::OpenRead(two);
  EXPECT_EQ(f1.DatasetShape("/frames/translated"), (io::Shape{24, 64, 64, 3}));
  const io::CameraRecord from = io::ReadCamera(io::H5File::OpenRead(File("samples1.h5")));
  const io::CameraRecord to = io::ReadCamera(f1);
  ASSERT_TRUE(to.width.has_value());
  EXPECT_EQ(*to.width, 64.0);
  EXPECT_NEAR(to.cx, 32.0, 1e-9);  // the samples' principal point, at their centre
  EXPECT_NEAR(to.fx / to.cx, from.fx / from.cx, 1e-9);
  EXPECT_EQ(f1.DatasetShape("/frames/latent"), (io::Shape{24, 8 * 8 * 8}));
  EXPECT_EQ(f1.Read<uint8_t>("/frames/translated", {}), f2.Read<uint8_t>("/frames/translated", {}));
  EXPECT_EQ(f1.Read<float>("/frames/latent_of_translation", {}),
            f2.Read<float>("/frames/latent_of_translation", {}));
  EXPECT_EQ(f1.Read<int32_t>("/contours/borders", {}), f2.Read<int32_t>("/contours/borders", {}));
  EXPECT_TRUE(std::filesystem::exists(File("one_contours.png")));
  EXPECT_EQ(f1.ReadStrings("/regions/names").front(), "skin");
}

// Paired examples (--paired: camera-like frames with their true segmentation) teach E and D_A
// the translation itself: after the same steps, D_A(E(I)) of such frames is nearer their
// segmentation than after unpaired training. Of several paired clips, one without the frames
// and their segmentation is named.
TEST_F(DeepfakeStage, PairedExamplesTeachTheTranslation) {
  // `extra` sets the options of the training beyond TrainOptions; `name` names its files.
  auto error = [&](const std::string& name, auto extra) {
    const std::string model = File("paired_model_" + name + ".h5");
    const std::string out = File("paired_translated_" + name + ".h5");
    DeepfakeTrainOptions train = TrainOptions(model, 150);
    extra(&train);
    RunInProcess(RunDeepfakeTrain, train, "deepfake.train");
    // Without flip averaging: these frames are segmentations recoloured, so a left region's
    // colour differs from its right one's, which no face shows; mirrored, they read wrong.
    DeepfakeInferOptions infer = InferOptions(model, out);
    infer.flip_average = false;
    infer.label_scale = 1;  // compared with the segmentation pixel for pixel
    RunInProcess(RunDeepfakeInfer, infer, "deepfake.infer");
    const std::vector<uint8_t> translated = io::H5File::OpenRead(out).Read<uint8_t>("/frames/translated", {});
    const std::vector<uint8_t> truth = io::H5File::OpenRead(File("b.h5")).Read<uint8_t>("/frames/segmentation", {});
    EXPECT_EQ(translated.size(), truth.size());
    double sum = 0;
    for (size_t k = 0; k < std::min(translated.size(), truth.size()); ++k) sum += std::abs(translated[k] - truth[k]);
    return sum / static_cast<double>(truth.size());
  };
  auto with_paired = [&](DeepfakeTrainOptions* o) {
    o->paired = {File("b.h5")};
    o->paired_fraction = 1;
  };
  const double unpaired = error("unpaired", [](DeepfakeTrainOptions*) {}),
               paired = error("paired", with_paired);
  EXPECT_LT(paired, 0.8 * unpaired) << "paired " << paired << ", unpaired " << unpaired;
  // The palette head chooses among the region colours: nearer still after the same steps.
  const double head = error("head", [&](DeepfakeTrainOptions* o) {
    with_paired(o);
    o->palette_head = true;
    o->loss.palette_weight = 1;
  });
  EXPECT_LT(head, paired) << "palette head " << head << ", RGB head " << paired;

  DeepfakeTrainOptions bad_options = TrainOptions(File("paired_bad.h5"), 2);
  bad_options.paired = {File("b.h5"), File("samples2.h5")};
  auto bad = InProcessResult(RunDeepfakeTrain, bad_options, "deepfake.train");
  EXPECT_EQ(bad.code, kExitInput) << bad.output;
  EXPECT_NE(bad.output.find("samples2.h5"), std::string::npos) << bad.output;
}

// A warm start (--init) begins from the init model's moving average of the weights; a model of
// another network is refused by name.
TEST_F(DeepfakeStage, AWarmStartBeginsFromTheInitModelsAveragedWeights) {
  const std::string from = File("warm_from.h5"), warm = File("warm.h5");
  DeepfakeTrainOptions from_options = TrainOptions(from, 3);
  from_options.average_decay = 0.5;
  RunInProcess(RunDeepfakeTrain, from_options, "deepfake.train");
  DeepfakeTrainOptions warm_options = TrainOptions(warm, 0);
  warm_options.init = from;
  RunInProcess(RunDeepfakeTrain, warm_options, "deepfake.train");
  io::H5File f = io::H5File::OpenRead(from);
  nn::DeepfakeModel model(nn::ReadNetworkOptions(f), 0);
  const int64_t n = model.num_parameters();
  std::vector<float> averaged(n);
  ASSERT_TRUE(nn::ReadAveragedWeights(f, model, averaged.data()));
  nn::ReadWeights(f, &model);
  const std::vector<float> last(model.parameters(), model.parameters() + n);
  ASSERT_NE(last, averaged);
  nn::ReadWeights(io::H5File::OpenRead(warm), &model);
  EXPECT_EQ(std::vector<float>(model.parameters(), model.parameters() + n), averaged);

  DeepfakeTrainOptions other_options = TrainOptions(File("warm_other.h5"), 1, 12);
  other_options.init = from;
  auto other = InProcessResult(RunDeepfakeTrain, other_options, "deepfake.train");
  EXPECT_EQ(other.code, kExitInput) << other.output;
  EXPECT_NE(other.output.find(from), std::string::npos) << other.output;
}

}  // namespace
}  // namespace facecap::stages
