// facecap eval track: accuracy of a track.h5 against the truth of a synthetic file (samples
// or clip): pose error, weight error per shape, landmark NME and vertex error over the
// inter-ocular distance, and the solve time per frame. Prints one JSON object.
// facecap eval landmarks: for real footage, which has no true parameters, the reprojection
// error of the tracked rig's 68 landmarks against the landmarks dlib detected in the crops,
// on all frames with a face and on the frames held out of deepfake training.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "io/hdf5.h"
#include "io/rig_io.h"
#include "render/camera.h"
#include "render/framing.h"
#include "rig/compare.h"
#include "rig/evaluate.h"
#include "stages/cli.h"
#include "stages/ingested_frames.h"
#include "stages/tracked_rig.h"
#include "stages/registry.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// [eval.track]
struct EvalTrackOptions {
  std::string truth = "clip.h5";   // file with the true pose and weights of every frame
  std::string track = "track.h5";  // output of facecap track
  // The rig that was tracked; empty: the truth's rig (a track made with the true rig).
  std::string rig = "";
  // Rig of the truth (HDF5 /rig); empty: the truth file's /rig.
  std::string truth_rig = "";
  bool json = true;                // print the metrics as one JSON object (else a table)
  std::string out = "";            // also write the JSON to this file (empty: none)
  bool per_frame = false;          // add each scored frame's errors to the JSON object

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "file with the true pose and weights per frame (synth samples or clip)");
    v("track", track, "track.h5 written by facecap track");
    v("rig", rig, "the rig that was tracked (empty: the truth's own rig)");
    v("truth_rig", truth_rig,
      "rig file of the truth (empty: the truth file's /rig, else the rig that was tracked)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
    v("per_frame", per_frame,
      "add \"per_frame\" to the JSON object: each scored frame's index, pose error (deg), "
      "weight MAE and landmark NME, to find the frames that fail");
  }
  bool Check(std::string* why) const {
    if (truth.empty() || track.empty()) {
      *why = "truth and track are required";
      return false;
    }
    return true;
  }
};

double RotationAngleDeg(const rig::RigidPose& a, const rig::RigidPose& b) {
  const Eigen::Matrix3d r = (a.Rotation().transpose() * b.Rotation()).cast<double>();
  return std::acos(std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
}

std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char text[64];
  std::snprintf(text, sizeof(text), "%.6g", v);
  return text;
}

// A truth weight above this counts as active (the weight MAE over active weights).
constexpr float kActiveWeight = 0.1f;

// Sums of one row of metrics over the scored frames.
struct TrackErrors {
  double pose = 0., translation = 0., weights = 0., nme = 0., vertex = 0.;
  double active = 0., expression = 0.;
  int64_t active_count = 0;
};

void RunEvalTrack(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<EvalTrackOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("eval track: " + why);

  io::H5File truth = io::H5File::OpenRead(o.truth);
  io::H5File track = io::H5File::OpenRead(o.track);
  rig::Rig rig;
  if (!o.truth_rig.empty()) {
    rig = io::ReadRigFile(o.truth_rig);
  } else if (truth.Exists("/rig/neutral")) {
    rig = io::ReadRig(truth);
  } else if (!o.rig.empty()) {
    rig = io::ReadRigFile(o.rig);  // synth samples: rendered with the rig that was tracked
  } else {
    throw InvalidInputError("eval track: " + o.truth + " has no /rig; pass --truth-rig");
  }
  const rig::Rig tracked_rig = o.rig.empty() ? rig : io::ReadRigFile(o.rig);
  if (tracked_rig.NumVertices() != rig.NumVertices() ||
      tracked_rig.landmarks.size() != rig.landmarks.size()) {
    throw FileIOError(o.rig + ": not the truth's topology (" +
                      std::to_string(tracked_rig.NumVertices()) + " vertices, " +
                      std::to_string(rig.NumVertices()) + " in the truth)");
  }
  // Truth layout: a clip (/frames) or synth samples (/samples).
  const bool clip = truth.Exists("/frames/weights");
  const std::string group = clip ? "/frames" : "/samples";
  if (!truth.Exists(group + "/weights") || !truth.Exists(group + "/pose")) {
    throw FileIOError(o.truth + ": no " + group + "/weights and " + group + "/pose");
  }
  const int S = rig.NumShapes();
  std::vector<std::string> truth_names;
  for (const auto& s : rig.shapes) truth_names.push_back(s.name);
  if (truth.Exists(group + "/shape_names")) truth_names = truth.ReadStrings(group + "/shape_names");
  const int64_t truth_frames = truth.NumFrames(group + "/weights");
  truth.CheckShape(group + "/weights", {truth_frames, static_cast<int64_t>(truth_names.size())});
  // Column of each rig shape in the truth (by name); the track's poses and weights in the
  // tracked rig's order come from TrackedRig.
  std::vector<int> truth_col(S, -1);
  for (int s = 0; s < S; ++s) {
    for (size_t k = 0; k < truth_names.size(); ++k) {
      if (truth_names[k] == rig.shapes[s].name) truth_col[s] = static_cast<int>(k);
    }
  }
  const TrackedRig tracked(o.track, tracked_rig);
  const int64_t frames = tracked.NumFrames();
  // The truth row of each tracked frame: its source frame for a track of footage crops.
  auto truth_row = [&](int64_t f) { return tracked.InSourceCamera() ? tracked.SourceIndex(f) : f; };
  for (int64_t f = 0; f < frames; ++f) {
    if (truth_row(f) < 0 || truth_row(f) >= truth_frames) {
      throw FileIOError(o.track + ": frame " + std::to_string(f) + " is source frame " +
                        std::to_string(truth_row(f)) + ", but " + o.truth + " has " +
                        std::to_string(truth_frames) + " frames");
    }
  }
  const auto tw = truth.ReadMatrix<float>(group + "/weights");
  truth.CheckShape(group + "/pose", {truth_frames, 3});
  const auto tp = truth.ReadMatrix<float>(group + "/pose");
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> tt;
  if (truth.Exists(group + "/translation")) {
    truth.CheckShape(group + "/translation", {truth_frames, 3});
    tt = truth.ReadMatrix<float>(group + "/translation");
  }
  const std::vector<double> seconds = track.ReadVector<double>("/track/seconds", frames);
  const std::vector<double> cost = track.ReadVector<double>("/track/cost", frames);
  const std::vector<int32_t> termination = track.ReadVector<int32_t>("/track/termination", frames);
  const std::vector<double> k = truth.ReadVector<double>("/camera/intrinsics", 4);
  render::Camera camera;
  camera.fx = static_cast<float>(k[0]);
  camera.fy = static_cast<float>(k[1]);
  camera.cx = static_cast<float>(k[2]);
  camera.cy = static_cast<float>(k[3]);
  camera.width = static_cast<int>(std::lround(2. * k[2]));
  camera.height = static_cast<int>(std::lround(2. * k[3]));
  if (truth.HasAttribute("/camera/intrinsics", "width")) {
    camera.width = static_cast<int>(truth.GetDoubleAttribute("/camera/intrinsics", "width"));
    camera.height = static_cast<int>(truth.GetDoubleAttribute("/camera/intrinsics", "height"));
  }
  // The tracked rig is projected with the tracking camera, scaled to the truth's images.
  const render::Camera tracked_camera =
      tracked.HasCameraWidth() ? tracked.CameraForWidth(camera.width, camera.height) : camera;
  float distance = 0.f;
  if (truth.HasAttribute("/camera/intrinsics", "distance_cm")) {
    distance = static_cast<float>(truth.GetDoubleAttribute("/camera/intrinsics", "distance_cm"));
  }
  if (tt.rows() == 0 && distance <= 0.f) {
    throw FileIOError(o.truth + ": no " + group + "/translation and no distance_cm on /camera/intrinsics");
  }

  const rig::RigEvaluator evaluator(rig), tracked_evaluator(tracked_rig);
  const int L = static_cast<int>(rig.landmarks.size());
  const bool has_eyes = L == 68;
  // The solved rows, and the neutral face's (every weight 0): what solving no expression at
  // all scores on this clip, the reference every figure has to beat.
  TrackErrors err, neutral;
  std::vector<double> per_shape(S, 0.);
  std::vector<double> pose_errors;
  // Each scored frame's index, pose error, weight MAE and landmark NME (per_frame).
  std::vector<std::array<double, 4>> frame_errors;
  rig::Vertices truth_posed, solved_posed, truth_shape, solved_shape;
  const Eigen::VectorXf zero = Eigen::VectorXf::Zero(S);
  const double iod3_neutral = rig::InterOcularDistance(rig, rig.neutral);
  // Frames the tracker had no face to solve (/track/termination 3) are not scored.
  int64_t scored = 0;
  for (int64_t f = 0; f < frames; ++f) {
    if (termination[f] == 3) continue;
    ++scored;
    const int64_t t = truth_row(f);
    rig::RigidPose truth_pose;
    if (tt.rows() > 0) {
      truth_pose.pitch = tp(t, 0);
      truth_pose.yaw = tp(t, 1);
      truth_pose.roll = tp.cols() > 2 ? tp(t, 2) : 0.f;
      truth_pose.translation = tt.row(t).transpose();
    } else {
      truth_pose = render::FramedPose(rig, distance, tp(t, 0), tp(t, 1),
                                      tp.cols() > 2 ? tp(t, 2) : 0.f);
    }
    const rig::RigidPose solved = tracked.Pose(f);
    const Eigen::VectorXf ws = tracked.Weights(f);
    Eigen::VectorXf wt = Eigen::VectorXf::Zero(S);
    double frame_weight_err = 0.;
    for (int s = 0; s < S; ++s) {
      if (truth_col[s] >= 0) wt[s] = tw(t, truth_col[s]);
      const double e = std::abs(wt[s] - ws[s]);
      per_shape[s] += e;
      frame_weight_err += e / S;
      neutral.weights += std::abs(wt[s]) / S;
      if (wt[s] > kActiveWeight) {
        err.active += e;
        neutral.active += wt[s];
        ++err.active_count;
      }
    }
    err.weights += frame_weight_err;
    const double pe = RotationAngleDeg(truth_pose, solved);
    frame_errors.push_back({static_cast<double>(f), pe, frame_weight_err, std::nan("")});
    pose_errors.push_back(pe);
    err.pose += pe;
    err.translation += (truth_pose.translation - solved.translation).norm();
    // Expression: the shape without the rigid pose, less each rig's own neutral.
    evaluator.EvaluateShape(wt, &truth_shape);
    tracked_evaluator.EvaluateShape(ws, &solved_shape);
    if (iod3_neutral > 0.) {
      err.expression += ((solved_shape - tracked_rig.neutral) - (truth_shape - rig.neutral))
                            .rowwise().norm().mean() / iod3_neutral;
      neutral.expression += (truth_shape - rig.neutral).rowwise().norm().mean() / iod3_neutral;
    }
    evaluator.EvaluatePosed(truth_pose, wt, &truth_posed);
    tracked_evaluator.EvaluatePosed(solved, ws, &solved_posed);
    if (has_eyes) {
      const int a = rig.landmarks[36], b = rig.landmarks[45];
      const float iod3 = (truth_posed.row(a) - truth_posed.row(b)).norm();
      const Eigen::Vector2f pa = camera.Project(truth_posed.row(a).transpose()).head<2>();
      const Eigen::Vector2f pb = camera.Project(truth_posed.row(b).transpose()).head<2>();
      const float iod2 = (pa - pb).norm();
      double lm = 0.;
      for (int l = 0; l < L; ++l) {
        // The same surface points on both meshes (one topology): the truth's landmarks.
        lm += (camera.Project(truth_posed.row(rig.landmarks[l]).transpose()).head<2>() -
               tracked_camera.Project(solved_posed.row(rig.landmarks[l]).transpose()).head<2>())
                  .norm();
      }
      err.nme += lm / L / iod2;
      frame_errors.back()[3] = lm / L / iod2;
      err.vertex += (truth_posed - solved_posed).rowwise().norm().mean() / iod3;
    }
  }
  const double n = static_cast<double>(std::max<int64_t>(scored, 1));
  const double na = static_cast<double>(std::max<int64_t>(err.active_count, 1));
  std::sort(pose_errors.begin(), pose_errors.end());
  const double pose_median = pose_errors.empty() ? 0. : pose_errors[pose_errors.size() / 2];
  double sec = 0., cost_mean = 0.;
  int converged = 0;
  for (int64_t f = 0; f < frames; ++f) {
    if (termination[f] == 3) continue;
    sec += seconds[f];
    cost_mean += cost[f];
    converged += termination[f] == 0;
  }
  std::ostringstream js;
  js << "{\"frames\": " << scored << ", \"frames_without_target\": " << frames - scored
     << ", \"pose_err_deg_mean\": " << JsonNumber(err.pose / n)
     << ", \"pose_err_deg_median\": " << JsonNumber(pose_median)
     << ", \"translation_err_cm_mean\": " << JsonNumber(err.translation / n)
     << ", \"weights_mae\": " << JsonNumber(err.weights / n)
     << ", \"weights_mae_neutral\": " << JsonNumber(neutral.weights / n)
     << ", \"active_weights_mae\": " << JsonNumber(err.active / na)
     << ", \"active_weights_mae_neutral\": " << JsonNumber(neutral.active / na)
     << ", \"active_weights\": " << err.active_count
     << ", \"expression_err_rel\": " << JsonNumber(err.expression / n)
     << ", \"expression_err_rel_neutral\": " << JsonNumber(neutral.expression / n)
     << ", \"landmark_nme\": " << (has_eyes ? JsonNumber(err.nme / n) : "null")
     << ", \"vertex_err_rel_mean\": " << (has_eyes ? JsonNumber(err.vertex / n) : "null")
     << ", \"sec_per_frame\": " << JsonNumber(sec / n)
     << ", \"cost_mean\": " << JsonNumber(cost_mean / n)
     << ", \"converged_fraction\": " << JsonNumber(converged / n)
     << ", \"weights_mae_per_shape\": {";
  for (int s = 0; s < S; ++s) {
    js << (s ? ", " : "") << "\"" << rig.shapes[s].name << "\": " << JsonNumber(per_shape[s] / n);
  }
  js << "}";
  if (o.per_frame) {
    const char* keys[4] = {"frame", "pose_err_deg", "weights_mae", "landmark_nme"};
    js << ", \"per_frame\": {";
    for (int c = 0; c < 4; ++c) {
      js << (c ? "], " : "") << "\"" << keys[c] << "\": [";
      for (size_t i = 0; i < frame_errors.size(); ++i) {
        js << (i ? ", " : "") << (c == 0 ? std::to_string(static_cast<int64_t>(frame_errors[i][0]))
                                         : JsonNumber(frame_errors[i][c]));
      }
    }
    js << "]}";
  }
  js << "}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("frames %lld (%lld without a face to track)\npose error %.3f deg (median %.3f)\n"
                "weight MAE %.4f (neutral face: %.4f)\n"
                "weight MAE over the %lld active true weights (> %.1f) %.4f (neutral face: %.4f)\n"
                "expression vertex error / IOD %.4f (neutral face: %.4f)\n"
                "landmark NME %.4f\nvertex error / IOD %.4f\nsec per frame %.4f\n",
                static_cast<long long>(scored), static_cast<long long>(frames - scored),
                err.pose / n, pose_median, err.weights / n, neutral.weights / n,
                static_cast<long long>(err.active_count), kActiveWeight, err.active / na,
                neutral.active / na, err.expression / n, neutral.expression / n, err.nme / n,
                err.vertex / n, sec / n);
  }
  if (!o.out.empty()) {
    std::ofstream file(o.out);
    if (!file) throw OutputError("eval track: cannot write " + o.out);
    file << js.str() << "\n";
  }
}

// [eval.landmarks]
struct EvalLandmarksOptions {
  std::string frames = "frames.h5";  // ingest output: detected landmarks, crops, camera
  std::string track = "track.h5";    // tracking of the frames' translations
  std::string rig = "rig.h5";        // the rig that was tracked
  int holdout_every = 0;             // frames i % n == n - 1 were held out of training
  bool json = true;                  // print one JSON object (else a table)
  std::string out = "";              // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("frames", frames, "ingest output (frames.h5): dlib's landmarks in source pixels");
    v("track", track, "track.h5 of the frames' crops (track --frames: in the source camera)");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("holdout_every", holdout_every,
      "frames i % n == n - 1 were held out of deepfake training: reported apart (0: none)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (holdout_every < 0 || holdout_every == 1) { *why = "holdout_every must be 0 or >= 2"; return false; }
    return true;
  }
};

void RunEvalLandmarks(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<EvalLandmarksOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (rig.landmarks.size() != 68) throw FileIOError(o.rig + ": the rig has no 68 landmarks");
  const IngestedFrames frames = IngestedFrames::Read(o.frames);
  const TrackedRig track(o.track, rig);
  const int64_t n = track.NumFrames();
  if (!track.InSourceCamera()) {
    throw FileIOError(o.track + ": not a track of an ingest output's crops (track --frames)");
  }
  if (frames.NumFrames() != n) {
    throw FileIOError(o.frames + " has " + std::to_string(frames.NumFrames()) + " frames, " +
                      o.track + " has " + std::to_string(n));
  }
  const rig::RigEvaluator evaluator(rig);
  rig::Vertices posed;
  // [all, held out, trained on]
  double sum[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  std::vector<double> errors;
  for (int64_t f = 0; f < n; ++f) {
    if (!frames.Found(f) || !track.Solved(f)) continue;
    evaluator.EvaluatePosed(track.Pose(f), track.Weights(f), &posed);
    const render::Camera camera = frames.SourceCamera(f);
    const auto detected = frames.SourceLandmarks(f);
    auto point = [&](int l) { return Eigen::Vector2f(detected.row(l).transpose()); };
    const double iod = (point(36) - point(45)).norm();
    if (!(iod > 1e-3)) continue;
    double e = 0.;
    for (int l = 0; l < 68; ++l) {
      // Camera coordinates put pixel centres at i + 0.5, dlib's landmarks at i.
      const Eigen::Vector2f q = camera.Project(posed.row(rig.landmarks[l]).transpose()).head<2>() -
                                Eigen::Vector2f(0.5f, 0.5f);
      e += (q - point(l)).norm();
    }
    e /= 68. * iod;
    errors.push_back(e);
    const bool held_out = o.holdout_every > 0 && f % o.holdout_every == o.holdout_every - 1;
    for (int g : {0, held_out ? 1 : 2}) {
      sum[g] += e;
      ++count[g];
    }
  }
  if (errors.empty()) throw FileIOError(o.frames + ": no tracked frame has a detected face");
  std::sort(errors.begin(), errors.end());
  auto mean = [&](int g) { return count[g] ? JsonNumber(sum[g] / count[g]) : std::string("null"); };
  std::ostringstream js;
  js << "{\"frames\": " << count[0] << ", \"landmark_nme\": " << mean(0)
     << ", \"landmark_nme_median\": " << JsonNumber(errors[errors.size() / 2])
     << ", \"held_out_frames\": " << count[1] << ", \"landmark_nme_held_out\": " << mean(1)
     << ", \"trained_frames\": " << count[2] << ", \"landmark_nme_trained\": " << mean(2)
     << ", \"normalized_by\": \"detected inter-ocular distance (landmarks 36, 45)\"}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("frames with a face %d\nlandmark NME %s (median %.4f)\nheld out of training: %d "
                "frames, NME %s\ntrained on: %d frames, NME %s\n",
                count[0], mean(0).c_str(), errors[errors.size() / 2], count[1], mean(1).c_str(),
                count[2], mean(2).c_str());
  }
  if (!o.out.empty()) {
    std::ofstream file(o.out);
    if (!file) throw OutputError("eval landmarks: cannot write " + o.out);
    file << js.str() << "\n";
  }
}

// [eval.person]
struct EvalPersonOptions {
  std::string truth = "clip.h5";     // a synthetic clip: its /rig is the true person
  std::string person = "person.h5";  // person fit output
  bool json = true;                  // print one JSON object (else a table)
  std::string out = "";              // also write the JSON to this file

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "file whose /rig is the true person (synth clip)");
    v("person", person, "person fit output (HDF5): the estimated rig, the landmarks-only "
                        "neutral and the generic neutral it started from");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (truth.empty() || person.empty()) { *why = "truth and person are required"; return false; }
    return true;
  }
};

void RunEvalPerson(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<EvalPersonOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("eval person: " + why);
  const rig::Rig truth = io::ReadRigFile(o.truth);
  const rig::Rig person = io::ReadRigFile(o.person);
  io::H5File f = io::H5File::OpenRead(o.person);
  for (const char* name : {"/person/landmarks_only_neutral", "/person/template_neutral"}) {
    if (!f.Exists(name)) throw FileIOError(o.person + ": no " + name + " (not a person fit output)");
  }
  const int64_t V = truth.NumVertices();
  if (person.NumVertices() != V) {
    throw FileIOError(o.person + " has " + std::to_string(person.NumVertices()) + " vertices, " +
                      o.truth + " has " + std::to_string(V) + ": not one topology");
  }
  const rig::Vertices landmarks_only = f.ReadMatrix<float>("/person/landmarks_only_neutral", V, 3);
  const rig::Vertices template_neutral = f.ReadMatrix<float>("/person/template_neutral", V, 3);
  const double iod = rig::InterOcularDistance(truth, truth.neutral);
  if (!(iod > 0.)) throw FileIOError(o.truth + ": the true rig has no 68 landmarks to measure with");
  const double rms = rig::SimilarityAlignedRms(person.neutral, truth.neutral);
  const double rms_template = rig::SimilarityAlignedRms(template_neutral, truth.neutral);
  const double rms_landmarks = rig::SimilarityAlignedRms(landmarks_only, truth.neutral);
  std::ostringstream js;
  js << "{\"vertex_rms_mm\": " << JsonNumber(10. * rms)
     << ", \"vertex_rms_over_iod\": " << JsonNumber(rms / iod)
     << ", \"template_vertex_rms_mm\": " << JsonNumber(10. * rms_template)
     << ", \"template_vertex_rms_over_iod\": " << JsonNumber(rms_template / iod)
     << ", \"landmarks_only_vertex_rms_mm\": " << JsonNumber(10. * rms_landmarks)
     << ", \"landmarks_only_vertex_rms_over_iod\": " << JsonNumber(rms_landmarks / iod)
     << ", \"iod_mm\": " << JsonNumber(10. * iod) << ", \"vertices\": " << V
     << ", \"alignment\": \"similarity (rotation, translation, scale) onto the truth\"}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("vertex RMS after similarity alignment, over the true inter-ocular distance "
                "(%.1f mm):\n  person fit      %.4f (%.2f mm)\n  landmarks only  %.4f (%.2f mm)\n"
                "  generic head    %.4f (%.2f mm)\n",
                10. * iod, rms / iod, 10. * rms, rms_landmarks / iod, 10. * rms_landmarks,
                rms_template / iod, 10. * rms_template);
  }
  if (!o.out.empty()) {
    std::ofstream file(o.out);
    if (!file) throw OutputError("eval person: cannot write " + o.out);
    file << js.str() << "\n";
  }
}

}  // namespace

void RegisterEval(CLI::App* app, AppState* state) {
  CLI::App* eval = nullptr;
  try {
    eval = app->get_subcommand("eval");
  } catch (const CLI::OptionNotFound&) {
    eval = app->add_subcommand("eval", "Metrics of an output against synthetic truth");
    eval->require_subcommand(1);
  }
  AddStage<EvalTrackOptions>(
      eval, state, "track", "eval.track", "eval track",
      "Tracking accuracy against the truth, each beside the neutral face's: pose error (deg), "
      "weight MAE (overall, over the truth's active weights, per shape), expression vertex "
      "error (rigid pose and identity removed), landmark NME and vertex error over the "
      "inter-ocular distance (outer eye corners 36, 45), seconds per frame; one JSON object",
      PathKeys{{"truth", "track", "rig", "truth_rig"}, {{"out", OutputKind::kText}}},
      RunEvalTrack);
  AddStage<EvalLandmarksOptions>(
      eval, state, "landmarks", "eval.landmarks", "eval landmarks",
      "Real footage: the tracked rig's 68 landmarks against dlib's in source pixels, over the "
      "detected outer-eye-corner distance, on all frames with a face and on the frames held "
      "out of deepfake training apart; one JSON object (score against an independent "
      "landmarker with export landmarks and analysis/compare_landmarks.py)",
      PathKeys{{"frames", "track", "rig"}, {{"out", OutputKind::kText}}},
      RunEvalLandmarks);
  AddStage<EvalPersonOptions>(
      eval, state, "person", "eval.person", "eval person",
      "The person fit's neutral against the true person of a synthetic clip: vertex RMS after a "
      "similarity alignment, in mm and over the inter-ocular distance, beside the generic head's "
      "and the landmarks-only fit's; one JSON object",
      PathKeys{{"truth", "person"}, {{"out", OutputKind::kText}}},
      RunEvalPerson);
}

}  // namespace facecap::stages
