// The real-footage path on footage whose geometry is known exactly: an ingest-like frames file
// of a person filmed at known poses (landmarks where the rig's landmark vertices project,
// crop transforms aligned as ingest aligns them) and the person's segmentation seen through
// each crop's camera. Tested: tracking in the crops' cameras and the landmark export back in
// source pixels; the person fit's identity, its rank independence and its restart.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "face/align.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "render/camera.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/rasterizer.h"
#include "rig/compare.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"
#include "stages/eval_stage.h"
#include "stages/export_stage.h"
#include "stages/ingested_frames.h"
#include "stages/person_file.h"
#include "stages/person_stage.h"
#include "stages/track_stage.h"
#include "testing/testing.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

constexpr int kWidth = 320, kHeight = 240, kCrop = 128, kTarget = 64;
constexpr double kFov = 40.0, kFps = 25.0;

struct Shot {
  float pitch_deg, yaw_deg, roll_deg, tx_cm;
  bool found;
};

// Writes frames.h5 (as ingest would for these shots of `person`) and translations.h5 (the
// person's true segmentation through each crop's camera); returns each frame's landmarks in
// source pixels (pixel centres at integers).
std::vector<face::Landmarks> WriteFootage(const rig::Rig& person, const std::vector<Shot>& shots,
                                          const std::string& frames_path,
                                          const std::string& translations_path) {
  const int64_t n = static_cast<int64_t>(shots.size());
  const render::Camera source = render::Camera::FromFov(kWidth, kHeight, static_cast<float>(kFov));
  const float distance = render::FramingDistance(person, source, 0.45f);
  const rig::RigEvaluator evaluator(person);
  const Eigen::VectorXf neutral = Eigen::VectorXf::Zero(person.NumShapes());
  const auto crop_template = face::CropTemplate({kCrop, 0.4, 0.04});
  const std::vector<int>& idx = face::CropAlignmentLandmarks();
  std::vector<face::Landmarks> landmarks(n);
  std::vector<float> transforms(6 * n), lm(136 * n);
  std::vector<uint8_t> found(n), translated(n * kTarget * kTarget * 3, 0);
  std::vector<int32_t> size(2 * n);
  std::vector<int64_t> index(n);
  std::vector<double> timecode(n);
  rig::Vertices posed;
  render::GBuffer g;
  Image8 segmentation;
  const float rad = static_cast<float>(M_PI / 180.0);
  for (int64_t k = 0; k < n; ++k) {
    const Shot& s = shots[k];
    rig::RigidPose pose = render::FramedPose(person, distance, s.pitch_deg * rad, s.yaw_deg * rad,
                                             s.roll_deg * rad);
    pose.translation.x() += s.tx_cm;
    evaluator.EvaluatePosed(pose, neutral, &posed);
    for (int l = 0; l < 68; ++l) {
      landmarks[k].row(l) = (source.Project(posed.row(person.landmarks[l]).transpose()).head<2>() -
                             Eigen::Vector2f(0.5f, 0.5f)).transpose();
    }
    const face::Similarity2 m = face::FitSimilarity(face::SelectRows(landmarks[k], idx),
                                                    face::SelectRows(crop_template, idx));
    const Eigen::Matrix<float, 2, 3> mf = m.Matrix().cast<float>();
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 3; ++c) transforms[6 * k + 3 * r + c] = mf(r, c);
    std::copy(landmarks[k].data(), landmarks[k].data() + 136, lm.begin() + 136 * k);
    found[k] = s.found ? 1 : 0;
    size[2 * k] = kWidth;
    size[2 * k + 1] = kHeight;
    index[k] = 10 + 2 * k;  // as ingest with a stride of 2 from frame 10
    timecode[k] = static_cast<double>(index[k]) / kFps;
    const render::CropView view = render::CameraOfCrop(source, mf, kCrop, kTarget);
    evaluator.EvaluatePosed(PoseInCrop(pose, view), neutral, &posed);
    render::Rasterize(posed, person.triangles, view.camera, &g);
    render::RenderSegmentation(g, person.triangle_region, person.regions, Eigen::Vector3f::Zero(),
                               &segmentation);
    std::copy(segmentation.data.begin(), segmentation.data.end(),
              translated.begin() + k * kTarget * kTarget * 3);
  }
  {
    io::H5File f = io::H5File::CreateAtomic(frames_path);
    std::vector<uint8_t> crops(n * kCrop * kCrop * 3, 0);
    f.Write<uint8_t>("/frames/crop", {n, kCrop, kCrop, 3}, crops.data());
    f.WriteVector("/frames/found", found);
    f.Write<float>("/frames/crop_transform", {n, 2, 3}, transforms.data());
    f.Write<float>("/frames/landmarks", {n, 68, 2}, lm.data());
    f.Write<int32_t>("/frames/image_size", {n, 2}, size.data());
    f.WriteVector("/frames/source_index", index);
    f.WriteVector("/frames/timecode", timecode);
    f.WriteVector<double>("/camera/fov_deg", {kFov});
    f.WriteStrings("/sources/files", {"footage.mp4"});
    f.SetAttribute("/sources/files", "fps", kFps);
    f.Commit();
  }
  {
    io::H5File f = io::H5File::CreateAtomic(translations_path);
    f.Write<uint8_t>("/frames/translated", {n, kTarget, kTarget, 3}, translated.data());
    f.Commit();
  }
  return landmarks;
}

class FootageStage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    rig::DemoHeadOptions options;
    options.num_identity_modes = 20;
    generic_ = new rig::Rig(rig::MakeDemoHead(options));
    io::H5File f = io::H5File::CreateAtomic(File("rig.h5"));
    io::WriteRig(*generic_, &f);
    f.Commit();
  }
  static void TearDownTestSuite() {
    delete generic_;
    delete dir_;
  }
  static std::string File(const std::string& name) { return dir_->File(name); }
  static testing::TempDir* dir_;
  static rig::Rig* generic_;
};
testing::TempDir* FootageStage::dir_ = nullptr;
rig::Rig* FootageStage::generic_ = nullptr;

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

TEST_F(FootageStage, ExportedLandmarksMatchTheRendersThroughTheCropTransform) {
  // Turned, rolled and off-centre heads: crop transforms with rotation, scale and shift.
  const std::vector<Shot> shots = {{0, 0, 0, 0, true},   {8, 25, 12, 3, true},
                                   {-6, -30, -15, -4, true}, {0, 10, 0, 0, false},
                                   {5, -15, 20, 2, true}};
  const std::vector<face::Landmarks> truth =
      WriteFootage(*generic_, shots, File("frames_a.h5"), File("translated_a.h5"));
  TrackOptions track;
  track.rig = File("rig.h5");
  track.frames = File("frames_a.h5");
  track.targets = File("translated_a.h5");
  track.targets_dataset = "/frames/translated";
  track.tracker.objective = "landmarks";
  track.init = "landmarks";
  track.tracker.levels = 1;
  track.tracker.epochs = 4;
  track.tracker.weight_prior = 0.f;
  track.batch = 1;
  track.out = File("track_a.h5");
  RunInProcess(RunTrack, track, "track");
  ExportLandmarksOptions export_landmarks;
  export_landmarks.track = File("track_a.h5");
  export_landmarks.rig = File("rig.h5");
  export_landmarks.frames = File("frames_a.h5");
  export_landmarks.out = File("landmarks.csv");
  RunInProcess(RunExportLandmarks, export_landmarks, "export.landmarks");
  std::ifstream csv(File("landmarks.csv"));
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  const std::vector<std::string> header = Split(line);
  ASSERT_EQ(header.size(), 2u + 3u * 68u);
  EXPECT_EQ(header[0], "source_index");
  EXPECT_EQ(header[1], "timecode");
  EXPECT_EQ(header[2], "x_0");
  EXPECT_EQ(header[2 + 68], "y_0");
  EXPECT_EQ(header[2 + 136 + 67], "visible_67");
  for (size_t k = 0; k < shots.size(); ++k) {
    ASSERT_TRUE(std::getline(csv, line)) << "row " << k << " missing";
    const std::vector<std::string> row = Split(line);
    ASSERT_EQ(row.size(), header.size()) << line;
    EXPECT_EQ(std::stoll(row[0]), 10 + 2 * static_cast<int64_t>(k));
    EXPECT_NEAR(std::stod(row[1]), (10 + 2 * static_cast<double>(k)) / kFps, 1e-3);
    if (!shots[k].found) {
      for (size_t c = 2; c < row.size(); ++c) EXPECT_TRUE(row[c].empty()) << "column " << c;
      continue;
    }
    double worst = 0.;
    int visible = 0;
    for (int l = 0; l < 68; ++l) {
      const double dx = std::stod(row[2 + l]) - truth[k](l, 0);
      const double dy = std::stod(row[2 + 68 + l]) - truth[k](l, 1);
      worst = std::max(worst, std::hypot(dx, dy));
      visible += row[2 + 136 + l] == "1";
    }
    EXPECT_LT(worst, 0.5) << "frame " << k << ": landmarks off by up to " << worst << " px";
    EXPECT_GE(visible, 40) << "frame " << k;
  }
  EXPECT_FALSE(std::getline(csv, line)) << "one row per ingested frame";

  // eval landmarks: the tracked rig against the frames' landmarks, and against the same
  // landmarks moved by 4 pixels; frames without a face are left out.
  auto nme = [&](const std::string& frames) {
    EvalLandmarksOptions eval;
    eval.frames = frames;
    eval.track = File("track_a.h5");
    eval.rig = File("rig.h5");
    eval.holdout_every = 2;
    eval.json = true;
    eval.out = File("eval_landmarks.json");
    RunInProcess(RunEvalLandmarks, eval, "eval.landmarks");
    const std::string e = testing::ReadText(eval.out);
    EXPECT_NE(e.find("\"frames\": 4"), std::string::npos) << e;
    EXPECT_NE(e.find("\"held_out_frames\": 1"), std::string::npos) << e;
    const size_t at = e.find("\"landmark_nme\": ");
    return at == std::string::npos ? -1.0 : std::stod(e.substr(at + 16));
  };
  const double exact = nme(File("frames_a.h5"));
  {
    std::filesystem::copy_file(File("frames_a.h5"), File("frames_shifted.h5"));
    io::H5File f = io::H5File::OpenReadWrite(File("frames_shifted.h5"));
    std::vector<float> lm = f.Read<float>("/frames/landmarks", {});
    for (size_t i = 0; i < lm.size(); i += 2) lm[i] += 4.f;
    f.Write<float>("/frames/landmarks", {static_cast<int64_t>(shots.size()), 68, 2}, lm.data());
  }
  const double shifted = nme(File("frames_shifted.h5"));
  EXPECT_GE(exact, 0.0);
  EXPECT_LT(exact, 0.01);
  EXPECT_GT(shifted, exact + 0.03);
}

class PersonFit : public FootageStage {
 protected:
  static void SetUpTestSuite() {
    FootageStage::SetUpTestSuite();
    person_ = new rig::Rig(rig::WithIdentity(*generic_, 5));
    io::H5File f = io::H5File::CreateAtomic(File("truth.h5"));
    io::WriteRig(*person_, &f);
    f.Commit();
    std::vector<Shot> shots;
    for (int k = 0; k < 10; ++k) {
      shots.push_back({static_cast<float>(8 * std::sin(k)), -36.f + 8.f * k,
                       static_cast<float>(4 * std::cos(k)), 0.f, true});
    }
    WriteFootage(*person_, shots, File("frames.h5"), File("translated.h5"));
  }
  static void TearDownTestSuite() {
    delete person_;
    FootageStage::TearDownTestSuite();
  }
  static std::string Args(const std::string& out) {
    return "person fit --rig " + File("rig.h5") + " --frames " + File("frames.h5") +
           " --translations " + File("translated.h5") +
           " --count 10 --landmark-rounds 4 --refine-rounds 2 --identity-prior 0.1"
           " --refine-from landmarks --out " + out;
  }
  // The options Args(out) gives on the command line.
  static PersonFitStageOptions Options(const std::string& out) {
    PersonFitStageOptions o;
    o.rig = File("rig.h5");
    o.frames = File("frames.h5");
    o.translations = File("translated.h5");
    o.count = 10;
    o.fit.landmark_rounds = 4;
    o.fit.refine_rounds = 2;
    o.fit.identity_prior = 0.1;
    o.refine_from = "landmarks";
    o.out = out;
    return o;
  }
  static std::vector<double> Identity(const std::string& path) {
    return io::H5File::OpenRead(path).ReadVector<double>("/person/identity");
  }
  static rig::Rig* person_;
};
rig::Rig* PersonFit::person_ = nullptr;

// On perfect translations (the person's own renders) every region is reliable: with none
// ignored the fit recovers the identity within a tight tolerance; ignoring the eyes' and the
// mouth's regions, as by default, it still lands close.
TEST_F(PersonFit, RecoversAKnownIdentityFromItsOwnRenders) {
  auto r = RunFacecap(Args(File("person.h5")) + " --set person.fit.refine_ignore_regions=[]", 2);
  ASSERT_EQ(r.code, 0) << r.output;
  const rig::Rig fitted = io::ReadRigFile(File("person.h5"));
  const double iod = rig::InterOcularDistance(*person_, person_->neutral);
  const double error = rig::SimilarityAlignedRms(fitted.neutral, person_->neutral) / iod;
  const double generic = rig::SimilarityAlignedRms(generic_->neutral, person_->neutral) / iod;
  EXPECT_LT(error, 0.2 * generic) << "person fit " << error << ", generic head " << generic;
  EXPECT_LT(error, 0.006);
  RunInProcess(RunPersonFit, Options(File("person_default.h5")), "person.fit");
  const double default_error =
      rig::SimilarityAlignedRms(io::ReadRigFile(File("person_default.h5")).neutral,
                                person_->neutral) / iod;
  EXPECT_LT(default_error, 0.25 * generic) << "person fit ignoring the eyes and the mouth "
                                           << default_error << ", generic head " << generic;
  // The person's shapes are the generic ones moved onto the person: a smile is still a smile.
  const int smile = fitted.ShapeIndex("mouthSmileLeft");
  ASSERT_GE(smile, 0);
  EXPECT_GT(fitted.shapes[smile].delta.vertex.size(), 10u);
  // eval person reports the same against the truth, beside the generic head.
  EvalPersonOptions eval;
  eval.truth = File("truth.h5");
  eval.person = File("person.h5");
  eval.json = true;
  eval.out = File("eval_person.json");
  RunInProcess(RunEvalPerson, eval, "eval.person");
  const std::string e = testing::ReadText(eval.out);
  EXPECT_NE(e.find("\"template_vertex_rms_over_iod\""), std::string::npos) << e;
  EXPECT_NE(e.find("\"landmarks_only_vertex_rms_over_iod\""), std::string::npos);
}

// Person fit records each landmark's noise against the person's landmark vertices; track's
// landmark term is in units of it: doubling every recorded noise and quadrupling the weight
// gives the same track, and the term moves the solve.
TEST_F(PersonFit, TrackWeighsTheLandmarkTermByTheRecordedNoise) {
  auto r = RunFacecap(Args(File("person_noise.h5")), 2);
  ASSERT_EQ(r.code, 0) << r.output;
  const LandmarkNoise noise = ReadLandmarkNoise(File("person_noise.h5"));
  ASSERT_EQ(noise.px.size(), 68u);
  EXPECT_EQ(noise.crop_size, kTarget);
  // The footage's landmarks are the person's own projected landmarks: the noise is sub-pixel.
  double inner = 0.;
  for (int l = 17; l < 68; ++l) inner += noise.px[l] * noise.px[l] / 51.;
  EXPECT_LT(std::sqrt(inner), 1.0);
  std::filesystem::copy_file(File("person_noise.h5"), File("person_noise2.h5"));
  {
    io::H5File f = io::H5File::OpenReadWrite(File("person_noise2.h5"));
    std::vector<double> doubled = noise.px;
    for (double& v : doubled) v *= 2.;
    f.WriteVector(kLandmarkNoisePath, doubled);
    f.SetAttribute(kLandmarkNoisePath, "crop_size", static_cast<int64_t>(kTarget));
  }
  ASSERT_EQ(ReadLandmarkNoise(File("person_noise2.h5")).px[20], 2. * noise.px[20]);
  auto track = [&](const std::string& rig, const std::string& weight, const std::string& out) {
    auto t = RunFacecap("track --rig " + File(rig) + " --frames " + File("frames.h5") +
                        " --targets " + File("translated.h5") + " --targets-dataset "
                        "/frames/translated --init previous --levels 1 --epochs 2 "
                        "--landmark-weight " + weight + " --out " + File(out), 2);
    EXPECT_EQ(t.code, 0) << t.output;
    return io::H5File::OpenRead(File(out)).Read<float>("/track/pose", {});
  };
  const std::vector<float> once = track("person_noise.h5", "0.5", "track_noise1.h5");
  const std::vector<float> doubled = track("person_noise2.h5", "2", "track_noise2.h5");
  const std::vector<float> without = track("person_noise.h5", "0", "track_noise0.h5");
  ASSERT_EQ(once.size(), doubled.size());
  for (size_t i = 0; i < once.size(); ++i) EXPECT_NEAR(once[i], doubled[i], 1e-5f) << i;
  double moved = 0.;
  for (size_t i = 0; i < once.size(); ++i) moved = std::max(moved, std::abs(double(once[i]) - without[i]));
  EXPECT_GT(moved, 1e-4);
  // A recorded noise that is not one positive value per landmark is an error naming the file.
  {
    io::H5File f = io::H5File::OpenReadWrite(File("person_noise2.h5"));
    f.WriteVector(kLandmarkNoisePath, std::vector<double>(67, 1.));
    f.SetAttribute(kLandmarkNoisePath, "crop_size", static_cast<int64_t>(kTarget));
  }
  r = RunFacecap("track --rig " + File("person_noise2.h5") + " --frames " + File("frames.h5") +
                 " --targets " + File("translated.h5") + " --targets-dataset /frames/translated "
                 "--out " + File("track_bad.h5"));
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("person_noise2.h5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("landmark_noise_px"), std::string::npos) << r.output;
}

// The refinement's ignored regions are the rig's: a name the rig lacks is refused, naming the
// rig file and its regions, before any work.
TEST_F(PersonFit, AnIgnoredRegionTheRigLacksIsRefused) {
  PersonFitStageOptions o = Options(File("person_unknown_region.h5"));
  o.refine_ignore_regions = {"sclera", "freckles"};
  try {
    RunInProcess(RunPersonFit, o, "person.fit");
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'freckles'"), std::string::npos) << what;
    EXPECT_NE(what.find(File("rig.h5")), std::string::npos) << what;
    EXPECT_NE(what.find("upper_lip"), std::string::npos) << what;
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

TEST_F(PersonFit, OneAndThreeRanksGiveTheSameIdentity) {
  RunInProcess(RunPersonFit, Options(File("person_1.h5")), "person.fit");
  auto r = RunFacecap(Args(File("person_3.h5")), 3);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(Identity(File("person_1.h5")), Identity(File("person_3.h5")));
}

TEST_F(PersonFit, AKilledFitContinuesToTheUninterruptedResult) {
  auto r = RunFacecap(Args(File("person_straight.h5")), 2);
  ASSERT_EQ(r.code, 0) << r.output;
  r = RunFacecap(Args(File("person_killed.h5")), 2,
                 "FACECAP_FAULT_AFTER_ROUNDS=2 FACECAP_FAULT_SIGNAL=KILL");
  ASSERT_NE(r.code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(File("person_killed.h5.partial")));
  EXPECT_FALSE(std::filesystem::exists(File("person_killed.h5")));
  r = RunFacecap(Args(File("person_killed.h5")), 2);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("2 of 6 rounds done"), std::string::npos) << r.output;
  EXPECT_EQ(Identity(File("person_straight.h5")), Identity(File("person_killed.h5")));
}

}  // namespace
}  // namespace facecap::stages

namespace facecap::stages {
namespace {

// jobs/demo.toml made small enough for a test.
std::string TinyDemo() {
  std::string sets;
  for (const char* s :
       {"rig.calibrate.people=1", "rig.calibrate.frames=4", "synth.clip.frames=16",
        "synth.samples.count=64", "synth.clip-paired11.frames=12",
        "synth.clip-paired12.frames=12", "synth.clip-paired13.frames=12",
        "synth.clip-paired14.frames=12", "deepfake.train.steps=3",
        "deepfake.train.batch=4", "deepfake.train.checkpoint_every=0",
        "deepfake.train.preview_every=0", "deepfake.infer.shift_average=0",
        "person.fit.count=4", "person.fit.landmark_rounds=1", "person.fit.refine_rounds=1",
        "track.solver.levels=1", "track.solver.epochs=1", "export.overlay.count=4"}) {
    sets += std::string(" --set ") + s;
  }
  return "run " + testing::SourceDir() + "/jobs/demo.toml" + sets;
}

template <typename T>
std::vector<T> Dataset(const std::string& path, const std::string& name) {
  return io::H5File::OpenRead(path).Read<T>(name, {});
}

// The demo's pipeline stages read nothing of the clip's truth: run from the mp4 alone, with
// the clip's HDF5 file absent, they give the same outputs.
TEST(DemoPipeline, StagesAfterTheVideoReadNoTruth) {
  testing::TempDir with_truth, video_only;
  auto r = testing::RunCommand("cd " + with_truth.path() + " && " + testing::BuildDir() +
                               "/facecap " + TinyDemo() + " --until export.overlay 2>&1");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string demo = with_truth.File("out/demo/");
  ASSERT_TRUE(std::filesystem::exists(demo + "clip.h5"));
  std::filesystem::create_directories(video_only.File("out/demo"));
  for (const char* name : {"rig_generic.h5", "rig.h5", "clip.mp4"}) {
    std::filesystem::copy_file(demo + name, video_only.File("out/demo/") + name);
  }
  r = testing::RunCommand("cd " + video_only.path() + " && " + testing::BuildDir() +
                          "/facecap " + TinyDemo() + " --from ingest --until export.overlay 2>&1");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string other = video_only.File("out/demo/");
  EXPECT_FALSE(std::filesystem::exists(other + "clip.h5"));
  EXPECT_EQ(Dataset<float>(demo + "frames.h5", "/frames/landmarks"),
            Dataset<float>(other + "frames.h5", "/frames/landmarks"));
  EXPECT_EQ(Dataset<uint8_t>(demo + "translated.h5", "/frames/translated"),
            Dataset<uint8_t>(other + "translated.h5", "/frames/translated"));
  EXPECT_EQ(Dataset<double>(demo + "person.h5", "/person/identity"),
            Dataset<double>(other + "person.h5", "/person/identity"));
  EXPECT_EQ(Dataset<float>(demo + "track.h5", "/track/pose"),
            Dataset<float>(other + "track.h5", "/track/pose"));
  EXPECT_EQ(Dataset<float>(demo + "track.h5", "/track/weights"),
            Dataset<float>(other + "track.h5", "/track/weights"));
  EXPECT_EQ(testing::ReadText(demo + "landmarks.csv"), testing::ReadText(other + "landmarks.csv"));
}

}  // namespace
}  // namespace facecap::stages
