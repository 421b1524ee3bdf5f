// regress train and regress infer end to end on a synthetic clip filmed, ingested and cropped
// like footage, with codes that determine the truth (a fixed linear map of each sample's and
// frame's pose and controls, so that what the networks can learn is known), and the sample
// renders and the crops standing for their translations: the three phases (dlib's landmarks on
// the translations as L's targets) keep one weight set on 2 and 3 ranks and a run stopped in
// phase 3 continues to the straight run's weights; phase 1 fits its noiseless training set;
// infer writes a track that eval track reads, the same on 1 and 2 ranks, its angles closer to
// the clip's truth than half the frontal head's error; a tracker's solutions given with track
// are what the model learns on those frames; more footage (more_frames) joins phase 3 alone,
// and phase 1 too where more_tracks gives its tracker's solutions.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "rig/pose.h"
#include "stages/eval_stage.h"
#include "stages/ingest_stage.h"
#include "stages/ingested_frames.h"
#include "stages/regress_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_clip_stage.h"
#include "stages/synth_stage.h"
#include "testing/testing.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::stages {
namespace {

using testing::ReadText;
using testing::RunFacecap;

constexpr int kSamples = 800, kFrames = 12, kDim = 64;

class Regress : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.out = File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthSamplesOptions sample_options;
    sample_options.rig = File("rig.h5");
    sample_options.sample.count = kSamples;
    sample_options.sample.size = 32;
    sample_options.framing = "crop";
    sample_options.sample.fov_deg = 40.f;
    sample_options.sample.fill = 0.5f;
    sample_options.out = File("samples.h5");
    RunInProcess(RunSynthSamples, sample_options, "synth.samples");
    SynthClipOptions clip_options;
    clip_options.rig = File("rig.h5");
    clip_options.clip.frames = kFrames;
    clip_options.clip.size = 160;
    clip_options.clip.fov_deg = 40.f;
    clip_options.clip.fill = 0.5f;
    clip_options.video = true;
    clip_options.out = File("clip.h5");
    RunInProcess(RunSynthClip, clip_options, "synth.clip");
    IngestOptions ingest;
    ingest.video = File("clip.mp4");
    ingest.out = File("frames.h5");
    ingest.crop_size = 64;
    RunInProcess(RunIngest, ingest, "ingest");
    // The map from (pose / pi + 0.5, weights) to codes.
    const io::H5File samples = io::H5File::OpenRead(File("samples.h5"));
    const int64_t S = static_cast<int64_t>(samples.ReadStrings("/samples/shape_names").size());
    Rng rng(5, 0);
    map_.resize(kDim * (3 + S));
    for (float& m : map_) m = static_cast<float>(rng.Normal() / std::sqrt(3.0 + S) * 4.0);
    const auto pose = samples.Read<float>("/samples/pose", {kSamples, 3});
    const auto weights = samples.Read<float>("/samples/weights", {kSamples, S});
    std::vector<float> codes;
    for (int i = 0; i < kSamples; ++i) AddCode(&pose[i * 3], &weights[i * S], S, &codes);
    WriteCodes(File("sample_codes.h5"), codes, kSamples, File("samples.h5"), "/samples/segmentation");
    // The frames' codes from the clip's truth, the pose seen by each crop's camera.
    const IngestedFrames ingested = IngestedFrames::Read(File("frames.h5"));
    ASSERT_EQ(ingested.NumFrames(), kFrames);
    const io::H5File clip = io::H5File::OpenRead(File("clip.h5"));
    const auto clip_pose = clip.Read<float>("/frames/pose", {kFrames, 3});
    const auto clip_translation = clip.Read<float>("/frames/translation", {kFrames, 3});
    const auto clip_weights = clip.Read<float>("/frames/weights", {kFrames, S});
    codes.clear();
    for (int k = 0; k < kFrames; ++k) {
      rig::RigidPose source;
      source.pitch = clip_pose[k * 3];
      source.yaw = clip_pose[k * 3 + 1];
      source.roll = clip_pose[k * 3 + 2];
      source.translation = Eigen::Vector3f(clip_translation[k * 3], clip_translation[k * 3 + 1],
                                           clip_translation[k * 3 + 2]);
      const rig::RigidPose crop = PoseInCrop(source, ingested.CropCamera(k, ingested.crop_size()));
      const float angles[3] = {crop.pitch, crop.yaw, crop.roll};
      AddCode(angles, &clip_weights[k * S], S, &codes);
    }
    WriteCodes(File("frame_codes.h5"), codes, kFrames, File("frames.h5"), "/frames/crop");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static void AddCode(const float* pose, const float* weights, int64_t S, std::vector<float>* codes) {
    std::vector<float> x;
    for (int k = 0; k < 3; ++k) x.push_back(static_cast<float>(pose[k] / M_PI + 0.5));
    x.insert(x.end(), weights, weights + S);
    for (int d = 0; d < kDim; ++d) {
      double sum = 0;
      for (size_t j = 0; j < x.size(); ++j) sum += map_[d * x.size() + j] * x[j];
      codes->push_back(static_cast<float>(sum));
    }
  }
  // A codes file as deepfake infer writes it; `images` of `from` stand for the translations.
  static void WriteCodes(const std::string& path, const std::vector<float>& codes, int rows, const std::string& from,
                         const std::string& images) {
    const io::H5File source = io::H5File::OpenRead(from);
    const io::Shape shape = source.DatasetShape(images);
    io::H5File f = io::H5File::CreateAtomic(path);
    f.Write<float>("/frames/latent_of_translation", {rows, kDim}, codes.data());
    f.Write<uint8_t>("/frames/translated", shape, source.Read<uint8_t>(images, shape).data());
    f.Commit();
  }
  static std::string Train(const std::string& out, const std::string& steps) {
    return "regress train --samples " + File("samples.h5") + " --sample-codes " + File("sample_codes.h5") +
           " --frame-codes " + File("frame_codes.h5") + " --frames " + File("frames.h5") + " --rig " +
           File("rig.h5") + " --hidden 64 --batch 32 --threads 1 --checkpoint-every 20 " + steps + " --out " + out;
  }
  static std::string Infer(const std::string& model, const std::string& out) {
    return "regress infer --model " + model + " --codes " + File("frame_codes.h5") + " --frames " +
           File("frames.h5") + " --rig " + File("clip.h5") + " --out " + out;
  }
  // The options Train(out, steps) gives on the command line, the steps as --pose-steps,
  // --landmark-steps and --finetune-steps.
  static RegressTrainOptions TrainOptions(const std::string& out, int pose_steps, int landmark_steps = 0,
                                          int finetune_steps = 0) {
    RegressTrainOptions o;
    o.samples = File("samples.h5");
    o.sample_codes = File("sample_codes.h5");
    o.frame_codes = File("frame_codes.h5");
    o.frames = File("frames.h5");
    o.rig = File("rig.h5");
    o.net.hidden = 64;
    o.batch = 32;
    o.threads = 1;
    o.checkpoint_every = 20;
    o.pose_steps = pose_steps;
    o.landmark_steps = landmark_steps;
    o.finetune_steps = finetune_steps;
    o.out = out;
    return o;
  }
  // The options Infer(model, out) gives on the command line.
  static RegressInferOptions InferOptions(const std::string& model, const std::string& out) {
    RegressInferOptions o;
    o.model = model;
    o.codes = File("frame_codes.h5");
    o.frames = File("frames.h5");
    o.rig = File("clip.h5");
    o.out = out;
    return o;
  }
  static testing::TempDir* dir_;
  static std::vector<float> map_;
};
testing::TempDir* Regress::dir_ = nullptr;
std::vector<float> Regress::map_;

TEST_F(Regress, ThePhasesKeepOneWeightSetOnEveryRankAndResume) {
  const std::string steps =
      "--pose-steps 30 --landmark-steps 20 --finetune-steps 30 --landmark-weight 0.01 --anchor-weight 10 "
      "--landmark-source translations";
  for (int ranks : {2, 3}) {
    auto r = RunFacecap(Train(File("ranks" + std::to_string(ranks) + ".h5"), steps), ranks);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("weights identical on " + std::to_string(ranks) + " rank(s)"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("phase 3"), std::string::npos) << r.output;
  }
  // Stopped in phase 3 (its anchors in the checkpoint), continued: the straight run's weights.
  const std::string straight = File("straight.h5"), stopped = File("stopped.h5");
  RegressTrainOptions straight_options = TrainOptions(straight, 30, 20, 30);
  straight_options.net.landmark_weight = 0.01f;
  straight_options.net.anchor_weight = 10.f;
  straight_options.landmark_source = "translations";
  RunInProcess(RunRegressTrain, straight_options, "regress.train");
  auto stop = RunFacecap(Train(stopped, steps), 0, "FACECAP_FAULT_AFTER_STEPS=60");
  EXPECT_EQ(stop.code, kExitInterrupted) << stop.output;
  EXPECT_FALSE(std::filesystem::exists(stopped));
  auto rerun = RunFacecap(Train(stopped, steps));
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("continuing"), std::string::npos) << rerun.output;
  const io::H5File a = io::H5File::OpenRead(straight), b = io::H5File::OpenRead(stopped);
  EXPECT_EQ(a.ReadVector<float>("/regressor/state"), b.ReadVector<float>("/regressor/state"));
  // Phases 2 and 3 train on: the landmarks that phase 2 taught L fit better than chance.
  EXPECT_LT(a.GetDoubleAttribute("/regressor", "fit_samples_landmark_err"), 0.2);
}

TEST_F(Regress, PhaseOneFitsNoiselessCodesAndInferTracksTheClip) {
  const std::string model = File("phase1.h5");
  RunInProcess(RunRegressTrain, TrainOptions(model, 1500), "regress.train");
  const io::H5File m = io::H5File::OpenRead(model);
  EXPECT_LT(m.GetDoubleAttribute("/regressor", "fit_samples_angle_err_deg"), 1.5);
  EXPECT_LT(m.GetDoubleAttribute("/regressor", "fit_samples_weights_mae"), 0.03);

  // Inferred on 1 and 2 ranks: the same track, one row per frame, read by eval track.
  RunInProcess(RunRegressInfer, InferOptions(model, File("track1.h5")), "regress.infer");
  auto r = RunFacecap(Infer(model, File("track2.h5")), 2);
  ASSERT_EQ(r.code, 0) << r.output;
  const io::H5File t1 = io::H5File::OpenRead(File("track1.h5")), t2 = io::H5File::OpenRead(File("track2.h5"));
  for (const char* d : {"/track/pose", "/track/translation", "/track/weights"}) {
    EXPECT_EQ(t1.Read<float>(d, t1.DatasetShape(d)), t2.Read<float>(d, t2.DatasetShape(d))) << d;
  }
  EXPECT_EQ(t1.DatasetShape("/track/pose"), (io::Shape{kFrames, 3}));
  EvalTrackOptions eval;
  eval.truth = File("clip.h5");
  eval.track = File("track1.h5");
  eval.rig = File("clip.h5");
  eval.out = File("metrics.json");
  RunInProcess(RunEvalTrack, eval, "eval.track");
  // The codes determine the truth: the angles come out closer to it than half the frontal
  // head's error, and the head, placed on the detected landmarks, projects its landmarks near
  // the clip's.
  const auto truth = io::H5File::OpenRead(File("clip.h5")).Read<float>("/frames/pose", {kFrames, 3});
  double frontal_deg = 0;
  for (int k = 0; k < kFrames; ++k) {
    const Eigen::Matrix3f R = rig::EulerToMatrix(Eigen::Vector3f(truth[k * 3], truth[k * 3 + 1], truth[k * 3 + 2]));
    frontal_deg += std::acos(std::clamp((R.trace() - 1.f) / 2.f, -1.f, 1.f)) * 180.0 / M_PI / kFrames;
  }
  const std::string metrics = ReadText(eval.out);
  auto value = [&](const std::string& key) {
    const size_t at = metrics.find("\"" + key + "\": ");
    EXPECT_NE(at, std::string::npos) << key << " in " << metrics;
    return at == std::string::npos ? 1e9 : std::stod(metrics.substr(at + key.size() + 4));
  };
  EXPECT_LT(value("pose_err_deg_mean"), 0.5 * frontal_deg) << metrics;
  EXPECT_LT(value("landmark_nme"), 0.05) << metrics;
}

TEST_F(Regress, TheTrackersSolutionsAreLearnedOnTheirFrames) {
  // A track of the frames (infer's layout) whose controls are all 0.5, unlike the clip's truth
  // that the codes encode.
  const std::string phase1 = File("short.h5"), track = File("half.h5");
  RunInProcess(RunRegressTrain, TrainOptions(phase1, 20), "regress.train");
  RunInProcess(RunRegressInfer, InferOptions(phase1, track), "regress.infer");
  {
    io::H5File t = io::H5File::OpenReadWrite(track);
    const io::Shape shape = t.DatasetShape("/track/weights");
    const std::vector<float> half(static_cast<size_t>(shape[0] * shape[1]), 0.5f);
    t.Write<float>("/track/weights", shape, half.data());
  }
  const std::string model = File("tracked.h5"), out = File("tracked_track.h5");
  RegressTrainOptions tracked = TrainOptions(model, 1500);
  tracked.track = track;
  RunInProcess(RunRegressTrain, tracked, "regress.train");
  RunInProcess(RunRegressInfer, InferOptions(model, out), "regress.infer");
  const auto truth = io::H5File::OpenRead(File("clip.h5")).Read<float>("/frames/weights", {});
  const auto predicted = io::H5File::OpenRead(out).Read<float>("/track/weights", {});
  ASSERT_EQ(truth.size(), predicted.size());
  double to_track = 0, truth_to_track = 0;
  for (size_t k = 0; k < truth.size(); ++k) {
    to_track += std::abs(predicted[k] - 0.5) / truth.size();
    truth_to_track += std::abs(truth[k] - 0.5) / truth.size();
  }
  EXPECT_LT(to_track, 0.5 * truth_to_track) << to_track << " " << truth_to_track;
}

TEST_F(Regress, MoreFootageJoinsPhaseThreeAloneOrWithItsTrackPhaseOne) {
  // A track of the frames for phase 1's real examples.
  const std::string short_model = File("more_short.h5"), track = File("more_track.h5");
  RunInProcess(RunRegressTrain, TrainOptions(short_model, 20), "regress.train");
  RunInProcess(RunRegressInfer, InferOptions(short_model, track), "regress.infer");
  // The same crops once more as a second clip of the person.
  const auto options = [&](const std::string& out, int landmark_steps, int finetune_steps, bool more,
                           bool tracked = false) {
    RegressTrainOptions o = TrainOptions(out, 30, landmark_steps, finetune_steps);
    o.track = track;
    o.net.anchor_weight = 10.f;
    if (more) {
      o.more_frame_codes = {File("frame_codes.h5")};
      o.more_frames = {File("frames.h5")};
    }
    if (tracked) o.more_tracks = {track};
    return o;
  };
  const auto state = [](const std::string& path, const char* name) {
    const io::H5File f = io::H5File::OpenRead(path);
    return f.Exists(name) ? f.ReadVector<float>(name) : std::vector<float>{};
  };
  // Phase 1 (the samples and the tracked frames) does not see it.
  RunInProcess(RunRegressTrain, options(File("p1.h5"), 0, 0, false), "regress.train");
  RunInProcess(RunRegressTrain, options(File("p1_more.h5"), 0, 0, true), "regress.train");
  EXPECT_EQ(state(File("p1.h5"), "/regressor/state"), state(File("p1_more.h5"), "/regressor/state"));
  // Phase 3 anchors and fine-tunes on both clips' frames.
  RunInProcess(RunRegressTrain, options(File("p3.h5"), 20, 30, false), "regress.train");
  RunInProcess(RunRegressTrain, options(File("p3_more.h5"), 20, 30, true), "regress.train");
  const auto anchors = state(File("p3.h5"), "/regressor/anchors");
  ASSERT_FALSE(anchors.empty());
  EXPECT_EQ(state(File("p3_more.h5"), "/regressor/anchors").size(), 2 * anchors.size());
  EXPECT_NE(state(File("p3.h5"), "/regressor/state"), state(File("p3_more.h5"), "/regressor/state"));
  // With its tracker's solutions (more_tracks) the clip joins phase 1.
  RunInProcess(RunRegressTrain, options(File("p1_tracked.h5"), 0, 0, true, true), "regress.train");
  EXPECT_NE(state(File("p1.h5"), "/regressor/state"), state(File("p1_tracked.h5"), "/regressor/state"));
  // The two lists name the same clips.
  RegressTrainOptions mismatched = options(File("bad.h5"), 0, 0, true);
  mismatched.more_frames.push_back(File("frames.h5"));
  std::string why;
  EXPECT_FALSE(mismatched.Check(&why));
  EXPECT_NE(why.find("more_frame_codes"), std::string::npos) << why;
  // more_tracks tracks every clip of more_frames, and the first clip too.
  RegressTrainOptions untracked = options(File("bad.h5"), 0, 0, true, true);
  untracked.more_tracks.push_back(track);
  EXPECT_FALSE(untracked.Check(&why));
  EXPECT_NE(why.find("more_tracks"), std::string::npos) << why;
  untracked = options(File("bad.h5"), 0, 0, true, true);
  untracked.track.clear();
  EXPECT_FALSE(untracked.Check(&why));
  EXPECT_NE(why.find("more_tracks"), std::string::npos) << why;
}

}  // namespace
}  // namespace facecap::stages
