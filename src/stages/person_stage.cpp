// facecap person fit: the person's own rig from their footage (paper 000 Sec. 5.1). First the
// identity modes of the generic rig are fitted, jointly with every chosen frame's pose and
// expression, to the 68 landmarks ingest detected (the landmark phase: a baseline, and the
// person's own landmark vertices); then, from the generic head or from that fit
// (refine_from), refined by inverse rendering of the deepfake's segmentation translations
// (track/person_fit.h). The rig's shapes are moved onto the person by deformation transfer
// (assets/person_rig.h).
//
// Frames: every frame with a face gets a quick pose from its landmarks (spread across ranks);
// `frames` of them are chosen for pose variety (farthest-point sampling over yaw and pitch,
// starting from the most frontal). Each round solves the chosen frames across ranks and takes
// one identity step from their contributions summed in frame order, so the result is the same
// for any number of ranks. The output's .partial file holds the identity and every frame's
// state after each round: a stopped or killed fit continues from its last round when rerun.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <mutex>

#include "stages/person_stage.h"

#include "assets/person_rig.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "render/framing.h"
#include "render/landmark_calibration.h"
#include "rig/evaluate.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/ingested_frames.h"
#include "stages/person_file.h"
#include "stages/resumable.h"
#include "track/person_fit.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/signals.h"

namespace facecap::stages {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Farthest-point sampling of `count` of the points (yaw, pitch in degrees), starting from the
// one nearest to frontal; ties go to the lower index. Returns ascending indices.
std::vector<int64_t> ChooseForPoseVariety(const std::vector<Eigen::Vector2d>& points, int count) {
  const int64_t n = static_cast<int64_t>(points.size());
  std::vector<int64_t> chosen;
  if (n == 0) return chosen;
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  int64_t next = 0;
  for (int64_t i = 1; i < n; ++i) {
    if (points[i].norm() < points[next].norm()) next = i;
  }
  while (static_cast<int64_t>(chosen.size()) < std::min<int64_t>(count, n)) {
    chosen.push_back(next);
    for (int64_t i = 0; i < n; ++i) distance[i] = std::min(distance[i], (points[i] - points[next]).norm());
    next = 0;
    for (int64_t i = 1; i < n; ++i) {
      if (distance[i] > distance[next]) next = i;
    }
    if (distance[next] <= 0.) break;  // every remaining point repeats a chosen one
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

// A pose as the 8 floats of a row of /person/frames/pose, and back.
constexpr int kPoseRow = 8;
void PoseToRow(const rig::RigidPose& p, float* row) {
  const float v[kPoseRow] = {p.pitch, p.yaw, p.roll, p.translation.x(), p.translation.y(),
                             p.translation.z(), p.scale, 0.f};
  std::copy(v, v + kPoseRow, row);
}

rig::RigidPose PoseFromRow(const float* v) {
  rig::RigidPose p;
  p.pitch = v[0];
  p.yaw = v[1];
  p.roll = v[2];
  p.translation = Eigen::Vector3f(v[3], v[4], v[5]);
  p.scale = v[6];
  return p;
}

void PutPose(ByteWriter* w, const rig::RigidPose& p) {
  float v[kPoseRow];
  PoseToRow(p, v);
  w->PutArray(v, kPoseRow);
}

rig::RigidPose GetPose(ByteReader* r) { return PoseFromRow(r->GetVector<float>().data()); }

// The inputs of a fit, read and checked on every rank.
struct PersonFitInputs {
  rig::Rig generic;       // the generic rig with identity modes
  IngestedFrames frames;  // ingest output: landmarks, crops, camera
  int size = 0;           // size of the crop camera: the translations' when given (pixels)
  std::vector<float> refine_region_weights;  // per region of the rig: 0 where ignored
};

// The refinement's weight of each region of `rig` (read from `path`): 0 for the regions
// `ignored` names, 1 for the others; empty when none is ignored.
std::vector<float> RefineRegionWeights(const rig::Rig& rig, const std::string& path,
                                       const std::vector<std::string>& ignored) {
  if (ignored.empty()) return {};
  std::vector<float> weights(rig.regions.size(), 1.f);
  for (const std::string& name : ignored) {
    size_t k = 0;
    while (k < rig.regions.size() && rig.regions[k].name != name) ++k;
    if (k == rig.regions.size()) {
      std::string names;
      for (const rig::Region& r : rig.regions) names += (names.empty() ? "" : ", ") + r.name;
      throw InvalidInputError("person fit: refine_ignore_regions names '" + name + "', which " +
                              path + " does not have (its regions: " + names + ")");
    }
    weights[k] = 0.f;
  }
  return weights;
}

PersonFitInputs ReadPersonFitInputs(const dist::Comm& comm, const PersonFitStageOptions& o) {
  PersonFitInputs in;
  in.size = o.size;
  dist::CoordinateExceptions(comm, [&] {
    std::string why;
    if (!o.Check(&why)) throw InvalidInputError("person fit: " + why);
    in.generic = io::ReadRigFile(o.rig);
    if (in.generic.identity_modes.empty()) {
      throw FileIOError(o.rig + ": the rig has no identity modes to fit a person with");
    }
    if (in.generic.landmarks.size() != 68) {
      throw FileIOError(o.rig + ": the rig has no 68 landmarks");
    }
    in.refine_region_weights = RefineRegionWeights(in.generic, o.rig, o.refine_ignore_regions);
    in.frames = IngestedFrames::Read(o.frames);
    if (!o.translations.empty()) {
      io::H5File t = io::H5File::OpenRead(o.translations);
      const io::Shape shape = t.CheckShape(o.translations_dataset, {-1, -1, -1, 3});
      if (shape[0] != in.frames.NumFrames()) {
        throw FileIOError(o.translations + " has " + std::to_string(shape[0]) + " frames, " +
                          o.frames + " has " + std::to_string(in.frames.NumFrames()));
      }
      if (shape[1] != shape[2]) {
        throw FileIOError(o.translations + ": translations must be square");
      }
      in.size = static_cast<int>(shape[1]);
    }
  });
  return in;
}

// The frames of `frames` (read from `path`) in which ingest found a face: at least 2.
std::vector<int64_t> FramesWithFace(const IngestedFrames& frames, const std::string& path) {
  std::vector<int64_t> with_face;
  for (int64_t f = 0; f < frames.NumFrames(); ++f) {
    if (frames.Found(f)) with_face.push_back(f);
  }
  if (with_face.size() < 2) {
    throw FileIOError(path + ": " + std::to_string(with_face.size()) +
                      " frames with a face; person fit needs at least 2");
  }
  return with_face;
}

// What the pieces of a fit share: the options, the inputs, the fitter, and their sizes.
struct PersonFitSetup {
  const PersonFitStageOptions& o;
  const dist::Comm& comm;
  const PersonFitInputs& in;
  const track::PersonFitter& fitter;
  int num_identity;  // K: the fitter's identity parameters
  int num_shapes;    // S: the generic rig's shapes
  int threads;       // OpenMP threads per rank
  int rounds;        // the landmark rounds, then the refinement's
  bool refine;       // a refinement by inverse rendering of the translations follows
};

// The targets of a frame: its crop camera and landmarks, and its translation if any.
class FrameTargets {
 public:
  FrameTargets(const IngestedFrames& frames, int size, const std::string& dataset)
      : frames_(frames), size_(size), dataset_(dataset) {}

  // Opens the translations (every rank), for targets with an image.
  void OpenTranslations(const dist::Comm& comm, const std::string& path) {
    dist::CoordinateExceptions(comm, [&] { file_ = io::H5File::OpenRead(path); });
  }

  // The target of frame `f` (with its translation when `with_image`); safe on several threads
  // at once.
  track::TrackTarget Make(int64_t f, bool with_image, render::CropView* view) {
    track::TrackTarget t;
    *view = frames_.CropCamera(f, size_);
    t.camera = view->camera;
    t.landmarks = frames_.CropLandmarks(f, size_);
    if (with_image) {
      Image8 image(size_, size_, 3);
      std::lock_guard<std::mutex> lock(read_mutex_);
      file_.ReadFrames<uint8_t>(dataset_, f, 1, image.data.data());
      t.image = track::ToFloatImage(image);
    }
    return t;
  }

 private:
  const IngestedFrames& frames_;
  const int size_;
  const std::string dataset_;
  io::H5File file_;  // the translations: open for the refinement
  std::mutex read_mutex_;
};

// The state of a fit, checkpointed in the output after each round.
struct PersonFitState {
  int64_t rounds_done = 0;
  std::vector<int64_t> chosen;            // rows of the ingest output chosen for pose variety
  Eigen::VectorXd identity;               // identity mode coefficients alpha
  Eigen::VectorXd landmarks_only;         // alpha after the landmark phase
  std::vector<float> pose, weights;       // per chosen frame: kPoseRow and S floats
  std::vector<int32_t> person_landmarks;  // the person's 68 landmark vertices (rank 0)
};

// Rank 0: the state of a continued output `f` after its last round.
void ReadCheckpoint(const PersonFitSetup& setup, const io::H5File& f, PersonFitState* state) {
  const int K = setup.num_identity;
  const int S = setup.num_shapes;
  state->rounds_done = f.ReadVector<int64_t>("/progress/rounds", 1)[0];
  state->chosen = f.ReadVector<int64_t>("/person/frames/index");
  const int64_t n = static_cast<int64_t>(state->chosen.size());
  const std::vector<double> id = f.ReadVector<double>("/person/identity", K);
  state->identity = Eigen::Map<const Eigen::VectorXd>(id.data(), K);
  const std::vector<double> lo = f.ReadVector<double>("/person/landmarks_only_identity", K);
  state->landmarks_only = Eigen::Map<const Eigen::VectorXd>(lo.data(), K);
  state->pose = f.Read<float>("/person/frames/pose", {n, kPoseRow});
  state->weights = f.Read<float>("/person/frames/weights", {n, S});
  if (f.Exists("/person/landmarks")) {
    state->person_landmarks = f.ReadVector<int32_t>("/person/landmarks", 68);
  }
  FC_INFO("person fit: continuing {}: {} of {} rounds done",
          io::H5File::PartialPath(setup.o.out), state->rounds_done, setup.rounds);
}

// Output (rank 0): new, continued, or up to date. The state starts from the generic head (no
// frames chosen) or from a continued output's last round, and every rank gets it. Returns
// false when the output is up to date.
bool OpenOutput(const PersonFitSetup& setup, const StageContext& ctx, const io::Config& resolved,
                ResumableOutput* output, PersonFitState* state) {
  const dist::Comm& comm = setup.comm;
  const int K = setup.num_identity;
  const rig::Rig& generic = setup.in.generic;
  int up_to_date = 0;
  state->identity = Eigen::VectorXd::Zero(K);
  state->landmarks_only = Eigen::VectorXd::Zero(K);
  state->person_landmarks.assign(generic.landmarks.data(), generic.landmarks.data() + 68);
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    *output = OpenResumableOutput(setup.o.out, resolved.ToToml(),
                                  MakeProvenance(ctx, "person fit", resolved));
    if (output->up_to_date) {
      up_to_date = 1;
      return;
    }
    if (output->resumed && output->file.Exists("/progress/rounds")) {
      ReadCheckpoint(setup, output->file, state);
    }
  });
  comm.Broadcast(&up_to_date, sizeof(up_to_date));
  if (up_to_date) {
    if (comm.IsMainRank()) FC_INFO("person fit: {} is up to date", setup.o.out);
    return false;
  }
  comm.Broadcast(&state->rounds_done, sizeof(state->rounds_done));
  comm.Broadcast(&state->chosen);
  comm.Broadcast(&state->pose);
  comm.Broadcast(&state->weights);
  comm.Broadcast(state->identity.data(), K * sizeof(double));
  comm.Broadcast(state->landmarks_only.data(), K * sizeof(double));
  return true;
}

// The options of the fit's frame loops, labelled `what`.
FrameLoopOptions FitLoopOptions(const PersonFitSetup& setup, const std::string& what) {
  FrameLoopOptions loop;
  loop.threads = setup.threads;
  loop.batch = 4;
  loop.what = what;
  return loop;
}

// 0, 1, ..., n - 1.
std::vector<int64_t> Indices(int64_t n) {
  std::vector<int64_t> all(n);
  for (int64_t k = 0; k < n; ++k) all[k] = k;
  return all;
}

// Chooses the frames for pose variety from `with_face`, spread across ranks; every rank gets
// the chosen frames, their poses, and their weights (0).
void ChooseFrames(const PersonFitSetup& setup, const std::vector<int64_t>& with_face,
                  FrameTargets* targets, PersonFitState* state) {
  const dist::Comm& comm = setup.comm;
  const rig::Rig& generic = setup.in.generic;
  const int S = setup.num_shapes;
  const int size = setup.in.size;
  // Every frame with a face: its pose from the landmarks, with the generic neutral.
  const track::Tracker posing(generic, track::RigRegionColors(generic),
                              setup.o.fit.landmark_tracker);
  std::vector<Eigen::Vector2d> angles(with_face.size());
  std::vector<rig::RigidPose> poses(with_face.size());
  const FrameLoopOptions loop = FitLoopOptions(setup, "person fit: poses");
  const Eigen::VectorXf neutral = Eigen::VectorXf::Zero(S);
  auto compute = [&](int64_t k, int) {
    render::CropView view;
    const track::TrackTarget t = targets->Make(with_face[k], false, &view);
    const float d = render::FramingDistance(generic, t.camera, 0.56f);
    rig::RigidPose start = render::FramedPose(generic, d, 0.f, 0.f);
    start.translation += t.camera.RayDirection(0.5f * size, 0.5f * size) * d -
                         Eigen::Vector3f(0.f, 0.f, -d);
    const rig::RigidPose p = posing.PoseFromLandmarks(t, start, neutral);
    ByteWriter w;
    PutPose(&w, p);
    return std::move(w.bytes());
  };
  std::vector<std::vector<uint8_t>> results(with_face.size());
  auto commit = [&](const std::vector<int64_t>& done, const std::vector<std::vector<uint8_t>>& r) {
    for (size_t i = 0; i < done.size(); ++i) results[done[i]] = r[i];
  };
  const std::vector<int64_t> all = Indices(static_cast<int64_t>(with_face.size()));
  RunFrameLoop(comm, all, static_cast<int64_t>(all.size()), loop, compute, commit);
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    for (size_t k = 0; k < results.size(); ++k) {
      ByteReader r(results[k]);
      poses[k] = GetPose(&r);
      angles[k] = Eigen::Vector2d(poses[k].yaw * kRadToDeg, poses[k].pitch * kRadToDeg);
    }
    for (int64_t k : ChooseForPoseVariety(angles, setup.o.count)) {
      state->chosen.push_back(with_face[k]);
      state->pose.resize(state->pose.size() + kPoseRow);
      PoseToRow(poses[k], &state->pose[state->pose.size() - kPoseRow]);
    }
    state->weights.assign(state->chosen.size() * S, 0.f);
    FC_INFO("person fit: {} of {} frames with a face chosen for pose variety",
            state->chosen.size(), with_face.size());
  });
  comm.Broadcast(&state->chosen);
  comm.Broadcast(&state->pose);
  comm.Broadcast(&state->weights);
}

// Each landmark's noise: RMS distance of the frames' detected point to the placed vertex's
// projection, in pixels of the crop (`size`). Logs it off the jaw.
std::vector<double> LandmarkNoise(const std::vector<render::CalibrationView>& views,
                                  const render::LandmarkCalibration& c, int size) {
  const int64_t n = static_cast<int64_t>(views.size());
  std::vector<double> noise(68, 0.);
  double inner = 0.;
  for (int l = 0; l < 68; ++l) {
    for (int64_t k = 0; k < n; ++k) {
      const Eigen::Vector3f x = views[k].posed.row(c.landmarks[l]).transpose();
      noise[l] += (views[k].camera.Project(x).head<2>() - views[k].detected.row(l).transpose())
                      .squaredNorm();
    }
    if (l >= 17) inner += noise[l] / (51. * n);
    noise[l] = std::sqrt(noise[l] / n);
  }
  FC_INFO("person fit: the landmarks' noise off the jaw: {:.3f} px RMS of a {}-pixel crop",
          std::sqrt(inner), size);
  return noise;
}

// Writes the person's landmark vertices and their noise (measured in a `size`-pixel crop),
// placed at the poses of `phase`.
void WriteLandmarks(const std::vector<int32_t>& landmarks, const std::vector<double>& noise,
                    const std::string& phase, int size, io::H5File* f) {
  f->WriteVector("/person/landmarks", landmarks);
  f->SetAttribute("/person/landmarks", "meaning",
                  std::string("the person's 68 landmark vertices (the rig's "
                              "/rig/landmarks), placed at the poses of ") + phase);
  f->WriteVector<double>(std::string(kLandmarkNoisePath), noise);
  f->SetAttribute(kLandmarkNoisePath, "meaning",
                  std::string("per landmark, the RMS distance of the detected point to "
                              "the projection of the person's landmark vertex at the "
                              "poses of ") + phase);
  f->SetAttribute(kLandmarkNoisePath, "crop_size", static_cast<int64_t>(size));
}

// The person's landmark vertices from the chosen frames at their current poses (rank 0), with
// the identity `id`; written with their noise to `f`, placed at the poses of `phase`.
void PlaceLandmarks(const PersonFitSetup& setup, const Eigen::VectorXd& id,
                    const std::string& phase, PersonFitState* state, io::H5File* f) {
  const int64_t n = static_cast<int64_t>(state->chosen.size());
  const int S = setup.num_shapes;
  const int size = setup.in.size;
  const rig::Rig fitted = setup.fitter.WithNeutral(id);
  const rig::RigEvaluator evaluator(fitted);
  std::vector<render::CalibrationView> views(n);
  for (int64_t k = 0; k < n; ++k) {
    const rig::RigidPose pose = PoseFromRow(&state->pose[kPoseRow * k]);
    const Eigen::VectorXf w = Eigen::Map<const Eigen::VectorXf>(&state->weights[S * k], S);
    evaluator.EvaluatePosed(pose, w, &views[k].posed);
    views[k].camera = setup.in.frames.CropCamera(state->chosen[k], size).camera;
    views[k].detected = setup.in.frames.CropLandmarks(state->chosen[k], size);
  }
  const render::LandmarkCalibration c =
      render::CalibrateLandmarks(fitted, views, setup.o.calibrate_radius_cm);
  state->person_landmarks.assign(c.landmarks.data(), c.landmarks.data() + 68);
  double before = 0., after = 0.;
  for (int l = 0; l < 68; ++l) {
    before += c.error_before[l] / 68.;
    after += c.error_after[l] / 68.;
  }
  FC_INFO("person fit: the person's landmark vertices at the poses of {}: mean distance to the "
          "frames' landmarks {:.4f} -> {:.4f} of the eye-corner distance", phase, before, after);
  const std::vector<double> noise = LandmarkNoise(views, c, size);
  WriteLandmarks(state->person_landmarks, noise, phase, size, f);
}

// One round's per-frame solves with the identity fixed (refining: the segmentation
// objective), spread across ranks. On rank 0: the frames' new poses and weights in `state`,
// and their contributions to the identity step, in frame order.
std::vector<track::PersonFrameContribution> SolveChosenFrames(const PersonFitSetup& setup,
                                                              int64_t round, bool refining,
                                                              FrameTargets* targets,
                                                              PersonFitState* state) {
  const int64_t n = static_cast<int64_t>(state->chosen.size());
  const int K = setup.num_identity;
  const int S = setup.num_shapes;
  std::vector<track::PersonFrameContribution> contributions(n);
  const FrameLoopOptions loop = FitLoopOptions(
      setup, "person fit: round " + std::to_string(round + 1) + "/" +
                 std::to_string(setup.rounds) +
                 (refining ? " (inverse rendering)" : " (landmarks)"));
  auto compute = [&](int64_t k, int) {
    render::CropView view;
    track::PersonFrame frame;
    frame.target = targets->Make(state->chosen[k], refining, &view);
    frame.pose = PoseFromRow(&state->pose[kPoseRow * k]);
    frame.weights = Eigen::Map<const Eigen::VectorXf>(&state->weights[S * k], S);
    const track::PersonFrameContribution c =
        setup.fitter.SolveFrame(state->identity, refining, &frame);
    ByteWriter w;
    PutPose(&w, frame.pose);
    w.PutArray(frame.weights.data(), S);
    w.PutArray(c.normal.data(), K * K);
    w.PutArray(c.gradient.data(), K);
    w.Put<double>(c.cost);
    w.Put<double>(c.landmark_rms);
    return std::move(w.bytes());
  };
  auto commit = [&](const std::vector<int64_t>& done, const std::vector<std::vector<uint8_t>>& r) {
    for (size_t i = 0; i < done.size(); ++i) {
      const int64_t k = done[i];
      ByteReader reader(r[i]);
      PoseToRow(GetPose(&reader), &state->pose[kPoseRow * k]);
      const std::vector<float> w = reader.GetVector<float>();
      std::copy(w.begin(), w.end(), state->weights.begin() + S * k);
      track::PersonFrameContribution& c = contributions[k];
      const std::vector<double> normal = reader.GetVector<double>();
      const std::vector<double> gradient = reader.GetVector<double>();
      c.normal = Eigen::Map<const Eigen::MatrixXd>(normal.data(), K, K);
      c.gradient = Eigen::Map<const Eigen::VectorXd>(gradient.data(), K);
      c.cost = reader.Get<double>();
      c.landmark_rms = reader.Get<double>();
    }
  };
  RunFrameLoop(setup.comm, Indices(n), n, loop, compute, commit);
  return contributions;
}

// Rank 0: writes the state after `round` and the frames' `contributions` to `f`, and flushes.
void WriteCheckpoint(const PersonFitSetup& setup, int64_t round,
                     const std::vector<track::PersonFrameContribution>& contributions,
                     const PersonFitState& state, io::H5File* f) {
  const int64_t n = static_cast<int64_t>(state.chosen.size());
  const int K = setup.num_identity;
  if (!f->Exists("/person/frames/index")) {
    f->WriteVector("/person/frames/index", state.chosen);
    f->SetAttribute("/person/frames/index", "meaning",
                    std::string("rows of the ingest output chosen for pose variety"));
  }
  f->Write<float>("/person/frames/pose", {n, kPoseRow}, state.pose.data());
  f->SetAttribute("/person/frames/pose", "columns",
                  std::string("pitch, yaw, roll (rad), tx, ty, tz (cm), scale, 0: in each "
                              "frame's crop camera"));
  f->Write<float>("/person/frames/weights", {n, setup.num_shapes}, state.weights.data());
  std::vector<double> id(state.identity.data(), state.identity.data() + K);
  f->WriteVector("/person/identity", id);
  std::vector<double> lo(state.landmarks_only.data(), state.landmarks_only.data() + K);
  f->WriteVector("/person/landmarks_only_identity", lo);
  std::vector<double> rms_per_frame(n), weight_per_frame(n), cost_per_frame(n);
  for (int64_t k = 0; k < n; ++k) {
    rms_per_frame[k] = contributions[k].landmark_rms;
    weight_per_frame[k] = contributions[k].weight;
    cost_per_frame[k] = contributions[k].cost;
  }
  f->WriteVector("/person/frames/cost", cost_per_frame);
  f->SetAttribute("/person/frames/cost", "meaning",
                  std::string("the frame's objective in the last round, in units of a "
                              "128 x 128 target"));
  f->WriteVector("/person/frames/landmark_rms", rms_per_frame);
  f->SetAttribute("/person/frames/landmark_rms", "units",
                  std::string("pixels of a 128-pixel crop"));
  f->WriteVector("/person/frames/robust_weight", weight_per_frame);
  f->WriteVector<int64_t>("/progress/rounds", {round + 1});
  f->Flush();
}

// Rank 0, after `round`'s per-frame solves: the person's landmark vertices after the last
// round, the identity step, the round's line, and the checkpoint in `f`.
void StepAndCheckpoint(const PersonFitSetup& setup, int64_t round, bool refining,
                       std::vector<track::PersonFrameContribution>* contributions,
                       PersonFitState* state, io::H5File* f) {
  const int64_t n = static_cast<int64_t>(state->chosen.size());
  const std::string calibrate_phase = setup.o.calibrate_radius_cm <= 0.f
                                          ? ""
                                          : (setup.refine ? "the refinement"
                                                          : "the landmark phase");
  if (round + 1 == setup.rounds && !calibrate_phase.empty()) {
    PlaceLandmarks(setup, state->identity, calibrate_phase, state, f);
  }
  state->identity = setup.fitter.Step(state->identity, contributions, refining);
  double cost = 0., rms = 0.;
  for (const auto& c : *contributions) {
    cost += c.weight * c.cost;
    rms += c.landmark_rms / static_cast<double>(n);
  }
  if (round + 1 == setup.o.fit.landmark_rounds) {
    state->landmarks_only = state->identity;
    // The refinement starts from the generic head or from the landmark fit.
    if (setup.refine && setup.o.refine_from == "generic") state->identity.setZero();
  }
  FC_INFO("person fit: round {}/{}: weighted cost {:.4g}, mean landmark RMS {:.3f} px (of a "
          "128-pixel crop), |alpha| {:.3f}",
          round + 1, setup.rounds, cost, rms, state->identity.norm());
  WriteCheckpoint(setup, round, *contributions, *state, f);
}

// One round: the per-frame solves, rank 0's identity step and checkpoint, shared with every
// rank. A stop signal on any rank ends the fit after the round (InterruptedError) while
// rounds remain.
void RunRound(const PersonFitSetup& setup, int64_t round, FrameTargets* targets,
              ResumableOutput* output, PersonFitState* state) {
  const dist::Comm& comm = setup.comm;
  const int K = setup.num_identity;
  const bool refining = round >= setup.o.fit.landmark_rounds;
  std::vector<track::PersonFrameContribution> contributions =
      SolveChosenFrames(setup, round, refining, targets, state);
  // Rank 0 takes the step from the contributions in frame order, checkpoints, and shares.
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    StepAndCheckpoint(setup, round, refining, &contributions, state, &output->file);
  });
  comm.Broadcast(state->identity.data(), K * sizeof(double));
  comm.Broadcast(state->landmarks_only.data(), K * sizeof(double));
  comm.Broadcast(&state->pose);
  comm.Broadcast(&state->weights);
  MaybeInjectFault("FACECAP_FAULT_AFTER_ROUNDS", comm.rank(), round + 1);
  if (comm.AnyTrue(StopRequested()) && round + 1 < setup.rounds) {
    throw InterruptedError("person fit: stopped by signal after round " +
                           std::to_string(round + 1) + " of " + std::to_string(setup.rounds) +
                           "; the output keeps it, rerun the same command to continue");
  }
}

// The person's rig (rank 0): identity applied, shapes moved by deformation transfer; with the
// landmark phase's neutral and the generic one beside it. Commits the output.
void WritePersonRig(const PersonFitSetup& setup, const PersonFitState& state,
                    ResumableOutput* output) {
  const dist::Comm& comm = setup.comm;
  const rig::Rig& generic = setup.in.generic;
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    rig::Rig person = assets::PersonRig(generic, setup.fitter.Neutral(state.identity));
    person.landmarks = Eigen::Map<const Eigen::VectorXi>(state.person_landmarks.data(), 68);
    io::H5File& f = output->file;
    if (f.Exists("/rig")) f.Remove("/rig");
    io::WriteRig(person, &f, "/rig");
    const rig::Vertices lo = setup.fitter.Neutral(state.landmarks_only);
    f.WriteMatrix("/person/landmarks_only_neutral", lo);
    f.WriteMatrix("/person/template_neutral", generic.neutral);
    f.SetAttribute("/person/template_neutral", "meaning",
                   std::string("the generic rig's neutral the person was fitted from (cm)"));
    f.SetAttribute("/person/landmarks_only_neutral", "meaning",
                   std::string("the neutral after the landmark phase, before the refinement by "
                               "inverse rendering (cm)"));
    f.SetAttribute("/person/identity", "columns",
                   std::string("identity mode coefficients alpha (rig's /rig/identity_modes "
                               "order)"));
    f.SetAttribute("/person", "refined", static_cast<int64_t>(setup.refine ? 1 : 0));
    f.Commit();
    FC_INFO("person fit: |alpha| {:.3f}; the person's rig -> {}", state.identity.norm(),
            setup.o.out);
  });
}

}  // namespace

StageSummary RunPersonFit(const PersonFitStageOptions& o, const StageContext& ctx,
                          const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;

  const PersonFitInputs in = ReadPersonFitInputs(comm, o);
  const bool refine = !o.translations.empty() && o.fit.refine_rounds > 0;
  track::PersonFitOptions fit = o.fit;
  fit.refine_tracker.region_weights = in.refine_region_weights;
  const track::PersonFitter fitter(in.generic, fit);
  const PersonFitSetup setup{o,
                             comm,
                             in,
                             fitter,
                             fitter.NumIdentityParams(),
                             in.generic.NumShapes(),
                             ThreadsPerRank(o.threads),
                             o.fit.landmark_rounds + (refine ? o.fit.refine_rounds : 0),
                             refine};
  const std::vector<int64_t> with_face = FramesWithFace(in.frames, o.frames);

  // The targets of a frame: its crop camera and landmarks, and its translation if any.
  FrameTargets targets(in.frames, in.size, o.translations_dataset);
  if (refine) targets.OpenTranslations(comm, o.translations);

  // Output (rank 0): new, continued, or up to date.
  ResumableOutput output;
  PersonFitState fit_state;
  StageSummary summary{o.out, "rounds", setup.rounds, 0};
  if (!OpenOutput(setup, ctx, resolved, &output, &fit_state)) return summary;
  if (fit_state.chosen.empty()) ChooseFrames(setup, with_face, &targets, &fit_state);

  // Rounds.
  for (int64_t round = fit_state.rounds_done; round < setup.rounds; ++round) {
    RunRound(setup, round, &targets, &output, &fit_state);
    ++summary.computed;
  }
  if (o.fit.landmark_rounds == 0) fit_state.landmarks_only.setZero();

  // The person's rig: identity applied, shapes moved by deformation transfer.
  WritePersonRig(setup, fit_state, &output);
  return summary;
}

}  // namespace facecap::stages
