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

#include "stages/eval_stage.h"

#include <Eigen/Geometry>

#include "appearance/photon_gather.h"
#include "appearance/texture_metrics.h"
#include "io/atomic_file.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "render/camera.h"
#include "render/framing.h"
#include "render/shading.h"
#include "render/texel_map.h"
#include "rig/compare.h"
#include "rig/evaluate.h"
#include "io/camera_file.h"
#include "io/frames_file.h"
#include "stages/holdout.h"
#include "stages/ingested_frames.h"
#include "stages/tracked_rig.h"
#include "stages/rig_texture.h"
#include "track/track_metrics.h"
#include "util/errors.h"
#include "util/json.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// A truth weight above this counts as active (the weight MAE over active weights).
using track::kActiveWeight;
using track::TrackErrors;
using track::TrackScorer;
using track::TrackScores;

// The rig of the truth: truth_rig, the truth file's /rig, or the rig that was tracked.
rig::Rig ReadTruthRig(const EvalTrackOptions& o, const io::H5File& truth) {
  if (!o.truth_rig.empty()) return io::ReadRigFile(o.truth_rig);
  if (truth.Exists("/rig/neutral")) return io::ReadRig(truth);
  if (!o.rig.empty()) return io::ReadRigFile(o.rig);  // synth samples: rendered with the rig that was tracked
  throw InvalidInputError("eval track: " + o.truth + " has no /rig; pass --truth-rig");
}


// What eval track reads of the truth file: the truth, its group and its row count.
struct TrackTruth : track::TrackTruth {
  std::string group;  // /frames (a clip) or /samples
  int64_t frames = 0;
};

// The truth's layout (a clip or synth samples), its frame count and the column of each rig
// shape in its weights (by name).
TrackTruth ReadTruthLayout(const EvalTrackOptions& o, const io::H5File& truth, const rig::Rig& rig) {
  TrackTruth t;
  const bool clip = truth.Exists(io::frames::kWeights);
  t.group = clip ? "/frames" : "/samples";
  const std::string& group = t.group;
  if (!truth.Exists(group + "/weights") || !truth.Exists(group + "/pose")) {
    throw FileIOError(o.truth + ": no " + group + "/weights and " + group + "/pose");
  }
  const int S = rig.NumShapes();
  std::vector<std::string> truth_names;
  for (const auto& s : rig.shapes) truth_names.push_back(s.name);
  if (truth.Exists(group + "/shape_names")) truth_names = truth.ReadStrings(group + "/shape_names");
  t.frames = truth.NumFrames(group + "/weights");
  truth.CheckShape(group + "/weights", {t.frames, static_cast<int64_t>(truth_names.size())});
  t.col.assign(S, -1);
  for (int s = 0; s < S; ++s) {
    for (size_t k = 0; k < truth_names.size(); ++k) {
      if (truth_names[k] == rig.shapes[s].name) t.col[s] = static_cast<int>(k);
    }
  }
  return t;
}

// The truth row of each tracked frame: its source frame for a track of footage crops.
int64_t TruthRow(const TrackedRig& tracked, int64_t f) {
  return tracked.InSourceCamera() ? tracked.SourceIndex(f) : f;
}

// The truth's poses, translations, weights and camera, once every tracked frame is known to
// have its truth row.
void ReadTruthFrames(const EvalTrackOptions& o, const io::H5File& truth, const TrackedRig& tracked,
                     TrackTruth* t) {
  const std::string& group = t->group;
  for (int64_t f = 0; f < tracked.NumFrames(); ++f) {
    if (TruthRow(tracked, f) < 0 || TruthRow(tracked, f) >= t->frames) {
      throw FileIOError(o.track + ": frame " + std::to_string(f) + " is source frame " +
                        std::to_string(TruthRow(tracked, f)) + ", but " + o.truth + " has " +
                        std::to_string(t->frames) + " frames");
    }
  }
  t->weights = truth.ReadMatrix<float>(group + "/weights");
  truth.CheckShape(group + "/pose", {t->frames, 3});
  t->pose = truth.ReadMatrix<float>(group + "/pose");
  if (truth.Exists(group + "/translation")) {
    truth.CheckShape(group + "/translation", {t->frames, 3});
    t->translation = truth.ReadMatrix<float>(group + "/translation");
  }
}

// The solve records of a track: time, final cost and termination per frame.
struct TrackSolves {
  std::vector<double> seconds, cost;
  std::vector<int32_t> termination;
};

// Means over the scored frames (n of them, na active true weights).
struct TrackSummary {
  double n = 1., na = 1., pose_median = 0., sec = 0., cost_mean = 0.;
  int converged = 0;
};

TrackSummary Summarize(const TrackScores& sc, const TrackSolves& solves, int64_t frames) {
  TrackSummary m;
  m.n = static_cast<double>(std::max<int64_t>(sc.scored, 1));
  m.na = static_cast<double>(std::max<int64_t>(sc.err.active_count, 1));
  std::vector<double> pose_errors = sc.pose_errors;
  std::sort(pose_errors.begin(), pose_errors.end());
  m.pose_median = pose_errors.empty() ? 0. : pose_errors[pose_errors.size() / 2];
  for (int64_t f = 0; f < frames; ++f) {
    if (solves.termination[f] == 3) continue;
    m.sec += solves.seconds[f];
    m.cost_mean += solves.cost[f];
    m.converged += solves.termination[f] == 0;
  }
  return m;
}

// ", \"per_frame\": {...}": each scored frame's index and errors, one array per column.
std::string PerFrameJson(const std::vector<std::array<double, 4>>& frame_errors) {
  std::ostringstream js;
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
  return js.str();
}

// The metrics as one JSON object (with each scored frame's errors when per_frame).
std::string TrackMetricsJson(const TrackScores& sc, const TrackSummary& m, int64_t frames,
                             const rig::Rig& rig, bool has_eyes, bool per_frame) {
  const TrackErrors& err = sc.err;
  const TrackErrors& neutral = sc.neutral;
  const double n = m.n, na = m.na;
  std::ostringstream js;
  js << "{\"frames\": " << sc.scored << ", \"frames_without_target\": " << frames - sc.scored
     << ", \"pose_err_deg_mean\": " << JsonNumber(err.pose / n)
     << ", \"pose_err_deg_median\": " << JsonNumber(m.pose_median)
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
     << ", \"sec_per_frame\": " << JsonNumber(m.sec / n)
     << ", \"cost_mean\": " << JsonNumber(m.cost_mean / n)
     << ", \"converged_fraction\": " << JsonNumber(m.converged / n)
     << ", \"weights_mae_per_shape\": {";
  for (int s = 0; s < rig.NumShapes(); ++s) {
    js << (s ? ", " : "") << "\"" << rig.shapes[s].name << "\": " << JsonNumber(sc.per_shape[s] / n);
  }
  js << "}";
  if (per_frame) js << PerFrameJson(sc.frame_errors);
  js << "}";
  return js.str();
}

// The metrics as a readable table.
void PrintTrackTable(const TrackScores& sc, const TrackSummary& m, int64_t frames) {
  const TrackErrors& err = sc.err;
  const TrackErrors& neutral = sc.neutral;
  const double n = m.n, na = m.na;
  std::printf("frames %lld (%lld without a face to track)\npose error %.3f deg (median %.3f)\n"
              "weight MAE %.4f (neutral face: %.4f)\n"
              "weight MAE over the %lld active true weights (> %.1f) %.4f (neutral face: %.4f)\n"
              "expression vertex error / IOD %.4f (neutral face: %.4f)\n"
              "landmark NME %.4f\nvertex error / IOD %.4f\nsec per frame %.4f\n",
              static_cast<long long>(sc.scored), static_cast<long long>(frames - sc.scored),
              err.pose / n, m.pose_median, err.weights / n, neutral.weights / n,
              static_cast<long long>(err.active_count), kActiveWeight, err.active / na,
              neutral.active / na, err.expression / n, neutral.expression / n, err.nme / n,
              err.vertex / n, m.sec / n);
}

// One capture scored against the truth: the face-region comparison and the eye and mouth
// corners' alignment.
struct AppearanceScore {
  int size = 0;
  appearance::TextureComparison comparison;
  appearance::CornerAlignment corners;
};

// A capture against the truth resampled to its resolution (bilinear, as a renderer samples).
// Corner windows of N / 16 texels each side (an eye's width), searched N / 32 texels far (16
// and 8 at 256; at least 1).
AppearanceScore ScoreCapture(const std::string& path, const rig::Rig& truth_rig, const ImageF& truth) {
  const ImageF captured = io::ReadColorTexture(path, io::kTextureAlbedoPath);
  const int N = captured.width;
  ImageF confidence(N, N, 1);
  confidence.data = io::H5File::OpenRead(path).Read<float>(io::kTextureConfidencePath, {N, N});
  const ImageF truth_resampled = render::ResampleBilinear(truth, N, N);
  const render::TexelMap texels = render::BakeTexelMap(truth_rig, N);
  AppearanceScore score;
  score.size = N;
  score.comparison = appearance::CompareTextures(captured, confidence, truth_resampled,
                                                 appearance::FaceRegionMask(truth_rig, texels));
  const int window = std::max(1, N / 16), search = std::max(1, N / 32);
  if (2 * (window + search) + 1 > N) {
    throw FileIOError(path + ": a texture of " + std::to_string(N) + " texels is too small to "
                      "measure the corners' alignment");
  }
  score.corners = appearance::MeasureCornerAlignment(
      captured, truth_resampled,
      appearance::LandmarkUVs(truth_rig, appearance::CornerLandmarks()), window, search);
  return score;
}

// Per pixel of U(I): 1 where its texture point lies in the face region and the pixel is at
// least `margin` pixels inside the silhouette.
ImageF FacePixels(const ImageF& uv, const std::vector<uint8_t>& face, int texels, int margin) {
  ImageF mask;
  appearance::SilhouetteInterior(uv, margin, &mask);
  for (int y = 0; y < uv.height; ++y) {
    for (int x = 0; x < uv.width; ++x) {
      const int tx = std::clamp(static_cast<int>(uv.at(x, y, 0) * texels), 0, texels - 1);
      const int ty = std::clamp(static_cast<int>((1.f - uv.at(x, y, 1)) * texels), 0, texels - 1);
      if (!face[static_cast<size_t>(ty) * texels + tx]) mask.at(x, y) = 0.f;
    }
  }
  return mask;
}

// The summary of an eval stage on rank 0: the JSON file `out`, counted when it was written
// (out empty: the JSON was only printed).
StageSummary EvalJsonSummary(const std::string& out) {
  const int64_t files = out.empty() ? 0 : 1;
  return StageSummary{out, "files", files, files};
}

}  // namespace

StageSummary RunEvalTrack(const EvalTrackOptions& o, const StageContext& ctx,
                          const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("eval track: " + why);

  io::H5File truth = io::H5File::OpenRead(o.truth);
  io::H5File track = io::H5File::OpenRead(o.track);
  const rig::Rig rig = ReadTruthRig(o, truth);
  const rig::Rig tracked_rig = o.rig.empty() ? rig : io::ReadRigFile(o.rig);
  if (tracked_rig.NumVertices() != rig.NumVertices() ||
      tracked_rig.landmarks.size() != rig.landmarks.size()) {
    throw FileIOError(o.rig + ": not the truth's topology (" +
                      std::to_string(tracked_rig.NumVertices()) + " vertices, " +
                      std::to_string(rig.NumVertices()) + " in the truth)");
  }
  TrackTruth t = ReadTruthLayout(o, truth, rig);
  // The track's poses and weights in the tracked rig's order.
  const TrackedRig tracked(o.track, tracked_rig);
  const int64_t frames = tracked.NumFrames();
  ReadTruthFrames(o, truth, tracked, &t);
  TrackSolves solves;
  solves.seconds = track.ReadVector<double>("/track/seconds", frames);
  solves.cost = track.ReadVector<double>("/track/cost", frames);
  solves.termination = track.ReadVector<int32_t>("/track/termination", frames);
  const io::CameraRecord truth_camera = io::ReadCamera(truth);
  t.camera = truth_camera.ToCamera();
  // The tracked rig is projected with the tracking camera, scaled to the truth's images.
  const render::Camera tracked_camera =
      tracked.HasCameraWidth() ? tracked.CameraForWidth(t.camera.width, t.camera.height) : t.camera;
  if (truth_camera.distance_cm) t.distance = static_cast<float>(*truth_camera.distance_cm);
  if (t.translation.rows() == 0 && t.distance <= 0.f) {
    throw FileIOError(o.truth + ": no " + t.group + "/translation and no distance_cm on " + io::kCameraPath);
  }

  TrackScorer scorer(rig, tracked_rig, t, tracked_camera);
  // Frames the tracker had no face to solve (/track/termination 3) are not scored.
  for (int64_t f = 0; f < frames; ++f) {
    if (solves.termination[f] == 3) continue;
    scorer.Score(f, TruthRow(tracked, f), tracked.Pose(f), tracked.Weights(f));
  }
  const TrackSummary summary = Summarize(scorer.scores(), solves, frames);
  const std::string js =
      TrackMetricsJson(scorer.scores(), summary, frames, rig, scorer.HasEyes(), o.per_frame);
  if (o.json) {
    std::cout << js << std::endl;
  } else {
    PrintTrackTable(scorer.scores(), summary, frames);
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js + "\n");
  return EvalJsonSummary(o.out);
}

StageSummary RunEvalLandmarks(const EvalLandmarksOptions& o, const StageContext& ctx,
                              const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
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
    const bool held_out = IsHeldOut(f, o.holdout_every);
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
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  return EvalJsonSummary(o.out);
}

StageSummary RunEvalPerson(const EvalPersonOptions& o, const StageContext& ctx,
                           const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
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
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  return EvalJsonSummary(o.out);
}

StageSummary RunEvalAppearance(const EvalAppearanceOptions& o, const StageContext& ctx,
                               const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
  const rig::Rig truth_rig = io::ReadRigFile(o.truth);
  const ImageF truth = io::ReadColorTexture(o.truth, io::kTrueAlbedoPath);
  const AppearanceScore score = ScoreCapture(o.texture, truth_rig, truth);
  const appearance::TextureComparison& m = score.comparison;
  std::string naive_json;
  AppearanceScore naive;
  if (!o.naive.empty()) {
    naive = ScoreCapture(o.naive, truth_rig, truth);
    naive_json = ", \"psnr_naive_db\": " + JsonNumber(naive.comparison.psnr_db) +
                 ", \"coverage_naive\": " + JsonNumber(naive.comparison.coverage) +
                 ", \"corner_misalignment_naive_texels\": " +
                 JsonNumber(naive.corners.mean_shift_texels) +
                 ", \"corners_found_naive\": " + std::to_string(naive.corners.found);
  }
  std::ostringstream js;
  js << "{\"psnr_face_db\": " << JsonNumber(m.psnr_db)
     << ", \"psnr_flat_db\": " << JsonNumber(m.psnr_flat_db)
     << ", \"corner_misalignment_texels\": " << JsonNumber(score.corners.mean_shift_texels)
     << ", \"corners_found\": " << score.corners.found
     << ", \"corner_shift_texels\": " << JsonList(score.corners.shift_texels)
     << ", \"corner_correlation\": " << JsonList(score.corners.correlation)
     << naive_json << ", \"coverage\": " << JsonNumber(m.coverage)
     << ", \"face_texels\": " << m.face_texels
     << ", \"gain\": [" << JsonNumber(m.gain[0]) << ", " << JsonNumber(m.gain[1]) << ", "
     << JsonNumber(m.gain[2]) << "], \"texture_size\": " << score.size
     << ", \"region\": \"face (brows to chin, ear to ear; no eyes, hair or mouth inside), "
        "linear RGB after one gain per channel, over covered texels\""
     << ", \"corners\": \"iBUG 36, 39, 42, 45, 48, 54 (eye and mouth corners); the shift of the "
        "capture's detail around each against the truth's, in texels; a corner without "
        "matching detail counts as " << std::max(1, score.size / 32) << "\"}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("against the true albedo: face-region PSNR (%lld texels, %.1f%% covered), and the "
                "eye and mouth corners' misalignment\n"
                "  captured texture  %.2f dB  %.2f texels (%d of 6 corners found)\n",
                static_cast<long long>(m.face_texels), 100. * m.coverage, m.psnr_db,
                score.corners.mean_shift_texels, score.corners.found);
    if (!o.naive.empty()) {
      std::printf("  naive capture     %.2f dB  %.2f texels (%d of 6 corners found)\n",
                  naive.comparison.psnr_db, naive.corners.mean_shift_texels, naive.corners.found);
    }
    std::printf("  flat colour       %.2f dB  %.2f texels (no detail)\n", m.psnr_flat_db,
                static_cast<double>(std::max(1, score.size / 32)));
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  return EvalJsonSummary(o.out);
}

StageSummary RunEvalRerender(const EvalRerenderOptions& o, const StageContext& ctx,
                             const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
  const rig::Rig rig = io::ReadRigFile(o.views);
  const ImageF captured = io::ReadColorTexture(o.texture, io::kTextureAlbedoPath);
  const ImageF naive = o.naive.empty() ? ImageF() : io::ReadColorTexture(o.naive, io::kTextureAlbedoPath);
  const ImageF generic = GenericSkinTexture(rig);
  std::vector<const ImageF*> textures = {&captured, &generic};
  if (!naive.empty()) textures.push_back(&naive);
  appearance::RerenderScore score(textures);
  constexpr int kMaskTexels = 256;
  const std::vector<uint8_t> face =
      appearance::FaceRegionMask(rig, render::BakeTexelMap(rig, kMaskTexels));
  io::H5File views = io::H5File::OpenRead(o.views);
  const io::Shape uv_shape = views.CheckShape(io::frames::kUv, {-1, -1, -1, 3});
  const int size = static_cast<int>(uv_shape[1]);
  const io::Shape image_shape = views.CheckShape(io::frames::kImage, {uv_shape[0], -1, -1, 3});
  views.CheckShape(io::frames::kTriangle, {uv_shape[0], size, size});
  Image8 image(static_cast<int>(image_shape[2]), static_cast<int>(image_shape[1]), 3);
  ImageF uv(size, size, 3), linear, normals(size, size, 3);
  Image<int32_t> triangles(size, size, 1);
  // Per triangle, its unit normal on the neutral mesh: the shading fit's normals, in the rig's
  // frame (each frame's fitted light absorbs the head's rotation).
  std::vector<Eigen::Vector3f> face_normal(rig.triangles.rows());
  for (int t = 0; t < rig.triangles.rows(); ++t) {
    const Eigen::Vector3f a = rig.neutral.row(rig.triangles(t, 0));
    const Eigen::Vector3f b = rig.neutral.row(rig.triangles(t, 1));
    const Eigen::Vector3f c = rig.neutral.row(rig.triangles(t, 2));
    face_normal[t] = (b - a).cross(c - a).normalized();
  }
  for (int64_t f = 0; f < uv_shape[0]; ++f) {
    if (o.holdout_every > 0 && !IsHeldOut(f, o.holdout_every)) continue;
    views.ReadFrames<uint8_t>(io::frames::kImage, f, 1, image.data.data());
    views.ReadFrames<float>(io::frames::kUv, f, 1, uv.data.data());
    views.ReadFrames<int32_t>(io::frames::kTriangle, f, 1, triangles.data.data());
    for (int i = 0; i < size * size; ++i) {
      const int32_t t = triangles.data[i];
      const bool valid = t >= 0 && t < rig.triangles.rows() && face_normal[t].allFinite();
      for (int k = 0; k < 3; ++k) normals.data[3 * i + k] = valid ? face_normal[t][k] : 0.f;
    }
    render::Image8ToLinear(image, true, &linear);
    score.AddFrame(render::ResampleBilinear(linear, size, size), uv, normals,
                   FacePixels(uv, face, kMaskTexels, o.edge_margin_px));
  }
  if (score.pixels() == 0) throw FileIOError(o.views + ": no face pixel in the frames scored");
  std::ostringstream js;
  js << "{\"psnr_captured_db\": " << JsonNumber(score.PsnrDb(0))
     << ", \"psnr_generic_db\": " << JsonNumber(score.PsnrDb(1));
  if (!naive.empty()) js << ", \"psnr_naive_db\": " << JsonNumber(score.PsnrDb(2));
  js << ", \"psnr_flat_db\": " << JsonNumber(score.FlatPsnrDb()) << ", \"frames\": "
     << score.frames() << ", \"pixels\": " << score.pixels()
     << ", \"scored\": \"face-region pixels of the frames, linear RGB; each frame's render "
        "shaded by first-order lighting of the surface normal fitted per frame and colour "
        "channel\"}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("tracked frames re-rendered with each texture against the frames (%d frames, "
                "%lld face pixels):\n  captured texture  %.2f dB\n",
                score.frames(), static_cast<long long>(score.pixels()), score.PsnrDb(0));
    if (!naive.empty()) std::printf("  naive capture     %.2f dB\n", score.PsnrDb(2));
    std::printf("  generic texture   %.2f dB\n  flat colour       %.2f dB\n", score.PsnrDb(1),
                score.FlatPsnrDb());
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  return EvalJsonSummary(o.out);
}

}  // namespace facecap::stages
