// Lip-sync end to end on a talking clip and its frontal lip view, whose speech starts 137 ms
// later: the clip's speech truth and sound track, the offset recovered from the two mp4s'
// sound, the blend's limits (no cross-fade: the video's solve exactly; a full one: the mouth
// source's controls at the aligned times), eval lipsync's rows, and lipsync track holding the
// head frontal and every control outside the mouth at the neutral, zeroed on the mouth at rest.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "io/audio.h"
#include "io/hdf5.h"
#include "lipsync/visemes.h"
#include "stages/lipsync_stage.h"
#include "stages/rig_stage.h"
#include "stages/synth_clip_stage.h"
#include "stages/track_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;
using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

constexpr double kOffset = 0.137;
constexpr int kFrames = 75;

class Lipsync : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    RigDemoOptions demo_rig;
    demo_rig.num_identity_modes = 8;
    demo_rig.out = File("rig.h5");
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    SynthClipOptions talk;
    talk.rig = demo_rig.out;
    talk.clip.frames = kFrames;
    talk.clip.size = 64;
    talk.clip.texture.texture_size = 128;
    talk.clip.identity_seed = 3;
    talk.video = true;
    talk.speech = "Bob made a map of Paris.";
    talk.speech_start_seconds = 0.3f;
    talk.out = File("talk.h5");
    RunInProcess(RunSynthClip, talk, "synth.clip");
    SynthClipOptions lips = talk;
    lips.speech_start_seconds = static_cast<float>(0.3 + kOffset);
    lips.lips_view = true;
    lips.out = File("lips.h5");
    RunInProcess(RunSynthClip, lips, "synth.clip");
    // Tracks made of the truth: the video's solve with its mouth at the neutral, and the lip
    // view's mouth.
    WriteTruthTrack(File("talk.h5"), File("video_track.h5"), true);
    WriteTruthTrack(File("lips.h5"), File("mouth_track.h5"), false);
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string File(const std::string& name) { return dir_->File(name); }
  // lipsync blend of the video's solve and the mouth source's track into `out`.
  static LipsyncBlendOptions Blend(const std::string& out) {
    LipsyncBlendOptions o;
    o.track = File("video_track.h5");
    o.mouth = File("mouth_track.h5");
    o.out = out;
    return o;
  }

  static void WriteTruthTrack(const std::string& clip, const std::string& out, bool neutral_mouth) {
    io::H5File c = io::H5File::OpenRead(clip);
    const auto names = c.ReadStrings("/frames/shape_names");
    RowMatrixF w = c.ReadMatrix<float>("/frames/weights");
    if (neutral_mouth) {
      for (size_t s = 0; s < names.size(); ++s) {
        const auto& mouth = lipsync::DefaultMouthControls();
        if (std::find(mouth.begin(), mouth.end(), names[s]) != mouth.end()) w.col(s).setZero();
      }
    }
    const double fps = c.GetDoubleAttribute("/camera/intrinsics", "fps");
    io::H5File f = io::H5File::CreateAtomic(out);
    f.WriteStrings("/track/shape_names", names);
    f.WriteMatrix("/track/weights", w);
    f.WriteMatrix("/track/pose", c.ReadMatrix<float>("/frames/pose"));
    f.WriteVector<int32_t>("/track/termination", std::vector<int32_t>(w.rows(), 0));
    std::vector<double> timecode;
    for (int i = 0; i < w.rows(); ++i) timecode.push_back(i / fps);
    f.WriteVector<double>("/track/timecode", timecode);
    f.Commit();
  }
  static RowMatrixF Weights(const std::string& path, const std::string& name = "/track/weights") {
    return io::H5File::OpenRead(path).ReadMatrix<float>(name);
  }
  static std::vector<int> MouthColumns(const std::string& clip) {
    const auto names = io::H5File::OpenRead(clip).ReadStrings("/frames/shape_names");
    std::vector<int> out;
    for (size_t s = 0; s < names.size(); ++s) {
      const auto& mouth = lipsync::DefaultMouthControls();
      if (std::find(mouth.begin(), mouth.end(), names[s]) != mouth.end()) out.push_back(static_cast<int>(s));
    }
    return out;
  }
  static testing::TempDir* dir_;
};

testing::TempDir* Lipsync::dir_ = nullptr;

TEST_F(Lipsync, TalkingClipKeepsItsSpeechAndSound) {
  io::H5File f = io::H5File::OpenRead(File("talk.h5"));
  const auto phones = f.ReadStrings("/speech/phones");
  ASSERT_GT(phones.size(), 10u);
  const auto times = f.ReadMatrix<double>("/speech/times");
  // The speech starts at 0.3 s (espeak-ng leads with a few ms of silence).
  EXPECT_GE(times(0, 0), 0.3);
  EXPECT_LT(times(0, 0), 0.35);
  // Bob made a map of Paris: b, b, m, m, p, p.
  const auto visemes = f.ReadVector<int>("/speech/visemes");
  EXPECT_EQ(std::count(visemes.begin(), visemes.end(), static_cast<int>(lipsync::Viseme::kPP)), 6);
  // The mouth moves with the speech; the sound is in the WAV and in the mp4.
  const auto names = f.ReadStrings("/frames/shape_names");
  const int jaw = static_cast<int>(std::find(names.begin(), names.end(), std::string("jawOpen")) - names.begin());
  ASSERT_LT(jaw, static_cast<int>(names.size()));
  EXPECT_GT(Weights(File("talk.h5"), "/frames/weights").col(jaw).maxCoeff(), 0.2f);
  const io::Audio wav = io::ReadWav(File("talk.wav"));
  EXPECT_NEAR(static_cast<double>(wav.samples.size()) / wav.rate, kFrames / 30., 0.05);
  const io::Audio sound = io::DecodeAudio(File("talk.mp4"), 16000);
  EXPECT_NEAR(static_cast<double>(sound.samples.size()) / sound.rate, kFrames / 30., 0.1);
  double energy = 0.;
  for (float x : sound.samples) energy += x * x;
  EXPECT_GT(std::sqrt(energy / sound.samples.size()), 0.01);
}

TEST_F(Lipsync, BlendAlignsByTheSoundAndHasExactLimits) {
  LipsyncBlendOptions aligned = Blend(File("blended.h5"));
  aligned.video = File("talk.mp4");
  aligned.mouth_video = File("lips.mp4");
  RunInProcess(RunLipsyncBlend, aligned, "lipsync.blend");
  io::H5File b = io::H5File::OpenRead(File("blended.h5"));
  const double offset = b.GetDoubleAttribute("/track", "lipsync_offset_seconds");
  EXPECT_NEAR(offset, kOffset, 0.02);
  // A full cross-fade: the mouth of the talking clip, read from the lip view 137 ms later.
  const RowMatrixF blended = Weights(File("blended.h5"));
  const RowMatrixF truth = Weights(File("talk.h5"), "/frames/weights");
  const RowMatrixF video = Weights(File("video_track.h5"));
  const std::vector<int> mouth = MouthColumns(File("talk.h5"));
  double error = 0., before = 0.;
  for (int f = 0; f < kFrames; ++f) {
    for (int s = 0; s < blended.cols(); ++s) {
      if (std::find(mouth.begin(), mouth.end(), s) == mouth.end()) {
        EXPECT_EQ(blended(f, s), video(f, s));
      } else {
        error += std::abs(blended(f, s) - truth(f, s));
        before += std::abs(video(f, s) - truth(f, s));
      }
    }
  }
  EXPECT_LT(error, 0.1 * before) << error << " " << before;
  // No cross-fade: the video's solve exactly.
  LipsyncBlendOptions none = Blend(File("none.h5"));
  none.offset_seconds = 0.137;
  none.crossfade = {0.f};
  RunInProcess(RunLipsyncBlend, none, "lipsync.blend");
  EXPECT_EQ(Weights(File("none.h5")), video);
  // Bad cross-fades are usage errors.
  auto r = RunFacecap("lipsync blend --track " + File("video_track.h5") + " --mouth " +
                      File("mouth_track.h5") + " --crossfade 0.5,0.5 --out " + File("bad.h5"));
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_FALSE(std::filesystem::exists(File("bad.h5")));
}

TEST_F(Lipsync, EvalScoresMouthUpperFaceAndClosures) {
  LipsyncBlendOptions aligned = Blend(File("aligned.h5"));
  aligned.offset_seconds = 0.137;
  RunInProcess(RunLipsyncBlend, aligned, "lipsync.blend");
  const std::string json = File("lipsync.json");
  EvalLipsyncOptions eval;
  eval.truth = File("talk.h5");
  eval.tracks = {File("video_track.h5"), File("aligned.h5")};
  eval.names = {"video", "blend"};
  eval.out = json;
  eval.gaps = File("gaps.csv");
  RunInProcess(RunEvalLipsync, eval, "eval.lipsync");
  std::ifstream in(json);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Rows: the neutral mouth, the video's solve (its mouth is the neutral's), the blend.
  auto value = [&](const std::string& row, const std::string& key) {
    const size_t at = text.find("\"name\": \"" + row);
    EXPECT_NE(at, std::string::npos) << row << " in " << text;
    const size_t k = text.find("\"" + key + "\": ", at);
    return std::stod(text.substr(k + key.size() + 4));
  };
  EXPECT_EQ(value("neutral mouth", "mouth_mae"), value("video", "mouth_mae"));
  EXPECT_GT(value("video", "mouth_mae"), 0.02);
  EXPECT_LT(value("blend", "mouth_mae"), 0.2 * value("video", "mouth_mae"));
  EXPECT_EQ(value("blend", "upper_mae"), 0.);
  EXPECT_LT(value("blend", "pose_err_deg"), 0.05);  // the truth's own poses (float rounding)
  EXPECT_GE(value("blend", "closure_f1"), 0.99);
  EXPECT_LT(value("video", "closure_f1"), 0.5);
  // The gaps CSV: a line per frame of each row, the truth's gap the same in every row, and the
  // blend's gaps nearer the truth's than the video solve's.
  std::ifstream csv(File("gaps.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "row,frame,source_index,seconds,truth_gap,gap");
  std::map<std::string, std::vector<std::pair<double, double>>> gaps;  // row -> (truth, gap)
  while (std::getline(csv, line)) {
    const size_t close = line.find("\",");
    ASSERT_NE(close, std::string::npos) << line;
    std::vector<double> cells;
    std::stringstream rest(line.substr(close + 2));
    for (std::string cell; std::getline(rest, cell, ',');) cells.push_back(std::stod(cell));
    ASSERT_EQ(cells.size(), 5u) << line;
    gaps[line.substr(1, close - 1)].emplace_back(cells[3], cells[4]);
  }
  ASSERT_EQ(gaps.size(), 3u);
  const auto& video = gaps["video"];
  const auto& blend = gaps["blend"];
  ASSERT_EQ(video.size(), blend.size());
  ASSERT_GT(video.size(), 20u);
  double video_error = 0., blend_error = 0.;
  for (size_t f = 0; f < video.size(); ++f) {
    EXPECT_EQ(video[f].first, blend[f].first) << f;
    video_error += std::abs(video[f].second - video[f].first);
    blend_error += std::abs(blend[f].second - blend[f].first);
  }
  EXPECT_LT(blend_error, 0.5 * video_error);
}

TEST_F(Lipsync, TrackSolvesTheMouthOfAFrontalViewOnly) {
  const std::string out = File("lips_solve.h5");
  const std::string args = "lipsync track --rig " + File("lips.h5") + " --targets " + File("lips.h5") +
                           " --sound " + File("lips.wav") + " --count 24 --out " + out;
  auto r = RunFacecap(args, 2);
  ASSERT_EQ(r.code, 0) << r.output;
  io::H5File f = io::H5File::OpenRead(out);
  const RowMatrixF w = f.ReadMatrix<float>("/track/weights");
  const RowMatrixF pose = f.ReadMatrix<float>("/track/pose");
  const auto names = f.ReadStrings("/track/shape_names");
  // Zeroed on the mouth at rest: the solve's weights less the median of the silent frames'
  // (the speech starts at 0.437 s), clamped, then the median of each three frames (the ends
  // repeated), then jawOpen raised where the lips met in a vowel (the counted frames only); a
  // rerun gives the same weights.
  const RowMatrixF solved = f.ReadMatrix<float>("/track/weights_solved");
  const int jaw = static_cast<int>(std::find(names.begin(), names.end(), std::string("jawOpen")) - names.begin());
  const int64_t parted = f.GetIntAttribute("/track/weights_solved", "lips_parted_frames");
  const std::vector<float> bias = f.ReadVector<float>("/track/rest_bias");
  ASSERT_EQ(static_cast<int64_t>(bias.size()), w.cols());
  EXPECT_GE(f.GetIntAttribute("/track/rest_bias", "rest_frames"), 3);
  const auto calibrated = [&](int i, int s) {
    return std::clamp(solved(std::clamp(i, 0, static_cast<int>(w.rows()) - 1), s) - bias[s], 0.f, 1.f);
  };
  int64_t raised = 0;
  for (int i = 0; i < w.rows(); ++i) {
    for (int s = 0; s < w.cols(); ++s) {
      float v[3] = {calibrated(i - 1, s), calibrated(i, s), calibrated(i + 1, s)};
      std::sort(v, v + 3);
      if (s == jaw && w(i, s) > v[1]) {
        ++raised;
      } else {
        EXPECT_EQ(w(i, s), v[1]) << i << " " << s;
      }
    }
  }
  EXPECT_EQ(raised, parted);
  f.Close();
  LipsyncTrackOptions rerun;
  rerun.rig = File("lips.h5");
  rerun.targets = File("lips.h5");
  rerun.filter.sound = File("lips.wav");
  rerun.count = 24;
  rerun.out = out;
  RunInProcess(RunLipsyncTrack, rerun, "lipsync.track");
  EXPECT_EQ(Weights(out), w) << "a rerun calibrated the calibrated weights again";
  const RowMatrixF truth = Weights(File("lips.h5"), "/frames/weights");
  const std::vector<int> mouth = MouthColumns(File("lips.h5"));
  Eigen::VectorXd a(24), b(24);
  for (int i = 0; i < 24; ++i) {
    EXPECT_EQ(pose.row(i).norm(), 0.f) << "the head turned at frame " << i;
    for (int s = 0; s < w.cols(); ++s) {
      if (std::find(mouth.begin(), mouth.end(), s) == mouth.end()) {
        EXPECT_EQ(w(i, s), 0.f);
      }
    }
    a[i] = solved(i, jaw);
    b[i] = truth(i, jaw);
  }
  // The solve's jaw follows the speech (a 64-pixel frame shows the mouth's other controls in a
  // few pixels).
  a.array() -= a.mean();
  b.array() -= b.mean();
  EXPECT_GT(a.dot(b) / (a.norm() * b.norm()), 0.7);
  LipsyncTrackOptions bad;
  bad.rig = File("lips.h5");
  bad.targets = File("lips.h5");
  bad.solve_controls = {"jawOpen", "grin"};
  bad.out = File("bad_track.h5");
  try {
    RunInProcess(RunLipsyncTrack, bad, "lipsync.track");
    ADD_FAILURE() << "lipsync track solved a control the rig does not have";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("grin"), std::string::npos) << e.what();
  }
  LipsyncTrackOptions unknown_word = rerun;
  unknown_word.filter.transcript = "the zorblax";
  unknown_word.out = File("word_track.h5");
  try {
    RunInProcess(RunLipsyncTrack, unknown_word, "lipsync.track");
    ADD_FAILURE() << "lipsync track took a transcript word its dictionary lacks";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("zorblax"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(unknown_word.out)) << "a bad transcript failed after the solve";
}

}  // namespace
}  // namespace facecap::stages
