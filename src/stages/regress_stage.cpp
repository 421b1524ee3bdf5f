// facecap regress train / infer: the personalized regressor of paper 000 Sec. 9 (Fig. 23).
// train fits P, J, W and L (nn/regressor.h) on the codes e = E(D_S(E(I))) of the synthetic
// samples and of the real frames, in the paper's three phases, with the training controller;
// infer predicts each frame's pose and controls from its code and writes a track file.
#include "stages/regress_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include "face/face_analyzer.h"
#include "io/config.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "io/translations_file.h"
#include "nn/deepfake.h"
#include "nn/regressor.h"
#include "render/framing.h"
#include "rig/evaluate.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/ingested_frames.h"
#include "stages/resumable.h"
#include "stages/sample_file.h"
#include "stages/stage.h"
#include "stages/track_file.h"
#include "stages/tracked_rig.h"
#include "track/soft_segmentation.h"
#include "track/tracker.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parallel_for.h"

namespace facecap::stages {
namespace {

constexpr int kPose = 3;  // pitch, yaw, roll
// L's landmarks: the 51 of the 68 off the jaw contour (the tracker's landmark term's points),
// whose detections hold at large yaws where the contour's do not.
constexpr int kFirstLandmark = 17;
constexpr int kLandmarks = kSampleLandmarks - kFirstLandmark;
// A pose angle a (rad) is the network's a / kPoseRange + 0.5, inside the sigmoid's (0, 1).
constexpr double kPoseRange = M_PI;
// The codes of deepfake infer's outputs the regressor reads: e = E(D_S(E(I))).
constexpr const char* kCodes = io::frames::kLatentOfTranslation;

// The rows of a deepfake infer output's codes, checked against the expected count.
std::vector<float> ReadCodeRows(const std::string& path, int64_t rows, int64_t* dim) {
  const io::H5File f = io::H5File::OpenRead(path);
  if (!f.Exists(kCodes)) {
    throw FileIOError(path + ": no " + std::string(kCodes) + " (an output of deepfake infer is expected)");
  }
  const io::Shape shape = f.CheckShape(kCodes, {-1, -1});
  if (shape[0] != rows) {
    throw FileIOError(path + ": " + std::to_string(shape[0]) + " codes in " + kCodes + ", " +
                      std::to_string(rows) + " expected (one per sample or frame)");
  }
  if (*dim > 0 && shape[1] != *dim) {
    throw FileIOError(path + ": codes of " + std::to_string(shape[1]) + " values, the other codes have " +
                      std::to_string(*dim) + " (a different deepfake?)");
  }
  *dim = shape[1];
  std::vector<float> codes = f.Read<float>(kCodes, shape);
  for (float x : codes) {
    if (!std::isfinite(x)) throw FileIOError(path + ": a non-finite value in " + std::string(kCodes));
  }
  return codes;
}

// The face box ingest's detector gives in a crop, as fractions of the crop: the median of each
// edge of /frames/box, carried into the crop, over the frames with a face.
face::FaceBox TypicalCropBox(const std::string& path, const IngestedFrames& ingested) {
  const io::H5File f = io::H5File::OpenRead(path);
  if (!f.Exists(io::frames::kBox)) throw FileIOError(path + ": no /frames/box (an ingest output is expected)");
  const std::vector<float> boxes = f.Read<float>(io::frames::kBox, f.CheckShape(io::frames::kBox, {ingested.NumFrames(), 5}));
  std::vector<float> edges[4];
  for (int64_t k = 0; k < ingested.NumFrames(); ++k) {
    if (!ingested.Found(k)) continue;
    const float* b = &boxes[5 * k];
    if (!std::all_of(b, b + 4, [](float x) { return std::isfinite(x); }) || !(b[2] > 0.f && b[3] > 0.f)) continue;
    const Eigen::Vector2f lo = ingested.CropPoint(k, Eigen::Vector2f(b[0], b[1]), 1);
    const Eigen::Vector2f hi = ingested.CropPoint(k, Eigen::Vector2f(b[0] + b[2], b[1] + b[3]), 1);
    edges[0].push_back(lo.x());
    edges[1].push_back(lo.y());
    edges[2].push_back(hi.x());
    edges[3].push_back(hi.y());
  }
  if (edges[0].empty()) throw FileIOError(path + ": no frame with a face box");
  float median[4];
  for (int e = 0; e < 4; ++e) {
    std::nth_element(edges[e].begin(), edges[e].begin() + edges[e].size() / 2, edges[e].end());
    median[e] = edges[e][edges[e].size() / 2];
  }
  face::FaceBox box;
  box.x = median[0];
  box.y = median[1];
  box.width = median[2] - median[0];
  box.height = median[3] - median[1];
  return box;
}

// dlib's landmarks 17-67 on the translations D_S(E(I)) (/frames/translated) of `rows` of a
// deepfake infer output, fitted in `box` (fractions of the image) on a copy enlarged to about
// 256 pixels, as fractions of the image: [rows, 51, 2].
std::vector<float> LandmarksOfTranslations(const std::string& path, const std::vector<int64_t>& rows,
                                           const face::FaceBox& box, int threads) {
  const io::TranslationsFile f(path);
  const int height = f.size(), width = f.size();  // square
  const int upsample = std::clamp(256 / std::max(1, width), 1, 16);
  face::FaceBox pixels;
  pixels.x = box.x * width - 0.5f;
  pixels.y = box.y * height - 0.5f;
  pixels.width = box.width * width;
  pixels.height = box.height * height;
  std::vector<std::unique_ptr<face::FaceAnalyzer>> analyzers(static_cast<size_t>(std::max(1, threads)));
  analyzers[0] = std::make_unique<face::FaceAnalyzer>();
  for (size_t t = 1; t < analyzers.size(); ++t) analyzers[t] = analyzers[0]->Clone();
  // Read first (the HDF5 library is not thread-safe), fitted on the threads.
  const std::vector<uint8_t> images = f.ReadAll();
  const size_t image_size = static_cast<size_t>(width) * height * 3;
  std::vector<float> out(rows.size() * 2 * kLandmarks);
  const int chunks = static_cast<int>(analyzers.size());
  ParallelFor(0, chunks, chunks, [&](int t) {
    Image8 translated(width, height, 3);
    for (size_t r = static_cast<size_t>(t); r < rows.size(); r += static_cast<size_t>(chunks)) {
      if (rows[r] < 0 || rows[r] >= f.count()) throw FileIOError(path + ": no translation of row " + std::to_string(rows[r]));
      std::copy_n(images.begin() + static_cast<int64_t>(rows[r] * image_size), image_size, translated.data.begin());
      const face::Landmarks l = analyzers[t]->FitLandmarks(translated, pixels, upsample);
      for (int k = 0; k < kLandmarks; ++k) {
        out[(r * kLandmarks + k) * 2] = (l(kFirstLandmark + k, 0) + 0.5f) / width;
        out[(r * kLandmarks + k) * 2 + 1] = (l(kFirstLandmark + k, 1) + 0.5f) / height;
      }
    }
  });
  return out;
}

// Everything training reads, normalized: the codes (per dimension to zero mean, unit
// deviation over the samples), the pose as angle / kPoseRange + 0.5, controls as they are,
// landmarks as fractions of the image size.
struct RegressData {
  nn::RegressorSizes sizes;
  int64_t num_samples = 0, num_frames = 0;
  int64_t num_tracked_clip_frames = 0;  // the frames of the clips with a track (they come first)
  std::vector<float> codes;        // [samples + frames, code]
  std::vector<float> pose, jaw, expression;  // per example (zeros where unknown)
  std::vector<uint8_t> has_truth;  // per example: pose and controls known
  int64_t num_truth_frames = 0;    // real frames with the tracker's solution
  std::vector<float> landmarks;    // [samples + frames, 136]
  std::vector<float> code_mean, code_scale;
  std::vector<std::string> shape_names;
  std::vector<int32_t> jaw_shapes, expression_shapes;
};

RegressData ReadRegressData(const RegressTrainOptions& o) {
  RegressData d;
  const io::H5File s = io::H5File::OpenRead(o.samples);
  for (const char* name : {"/samples/pose", "/samples/weights", "/samples/landmarks", "/samples/shape_names",
                           "/samples/segmentation"}) {
    if (!s.Exists(name)) throw FileIOError(o.samples + ": no " + std::string(name) + " (a samples file is expected)");
  }
  const io::Shape image = s.CheckShape("/samples/segmentation", {-1, -1, -1, 3});
  d.num_samples = image[0];
  if (d.num_samples < 1) throw FileIOError(o.samples + ": no samples");
  d.shape_names = s.ReadStrings("/samples/shape_names");
  const int64_t S = static_cast<int64_t>(d.shape_names.size());
  const std::vector<float> pose = s.Read<float>("/samples/pose", s.CheckShape("/samples/pose", {d.num_samples, kPose}));
  const std::vector<float> weights = s.Read<float>("/samples/weights", s.CheckShape("/samples/weights", {d.num_samples, S}));
  const std::vector<float> lm =
      s.Read<float>("/samples/landmarks", s.CheckShape("/samples/landmarks", {d.num_samples, kSampleLandmarks, 2}));

  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (rig.NumShapes() != S) {
    throw InvalidInputError(o.rig + ": " + std::to_string(rig.NumShapes()) + " shapes, the samples " + o.samples +
                            " have " + std::to_string(S));
  }
  for (int64_t k = 0; k < S; ++k) {
    if (rig.shapes[k].name != d.shape_names[k]) {
      throw InvalidInputError(o.rig + ": shape " + std::to_string(k) + " is " + rig.shapes[k].name + ", the samples' " +
                              d.shape_names[k] + " (the samples must be of this rig)");
    }
  }
  std::vector<bool> is_jaw(S, false);
  for (int j : rig::JawShapeIndices(rig)) is_jaw[j] = true;
  for (int k = 0; k < S; ++k) (is_jaw[k] ? d.jaw_shapes : d.expression_shapes).push_back(k);
  if (d.jaw_shapes.empty() || d.expression_shapes.empty()) {
    throw InvalidInputError(o.rig + ": the regressor needs jaw-skinned controls and others; the rig has " +
                            std::to_string(d.jaw_shapes.size()) + " and " + std::to_string(d.expression_shapes.size()));
  }

  int64_t dim = 0;
  d.codes = ReadCodeRows(o.sample_codes, d.num_samples, &dim);
  // The samples' projected landmarks, then the real frames' detected ones.
  for (int64_t i = 0; i < d.num_samples; ++i) {
    for (int p = kFirstLandmark; p < kSampleLandmarks; ++p) {
      d.landmarks.push_back(lm[(i * kSampleLandmarks + p) * 2] / static_cast<float>(image[2]));
      d.landmarks.push_back(lm[(i * kSampleLandmarks + p) * 2 + 1] / static_cast<float>(image[1]));
    }
  }
  // The real frames: phase 3's examples, and the fit report's (given without phase 3); those of
  // `frames` (the clip the tracker's track solved) first, then more_frames' clips.
  std::vector<std::pair<std::string, std::string>> clips;  // codes, frames
  if (!o.frame_codes.empty() && !o.frames.empty()) {
    clips.emplace_back(o.frame_codes, o.frames);
    for (size_t i = 0; i < o.more_frames.size(); ++i) clips.emplace_back(o.more_frame_codes[i], o.more_frames[i]);
  }
  std::vector<IngestedFrames> ingested;
  std::vector<std::vector<int64_t>> clip_rows;  // each clip's frames with a face
  for (const auto& [codes_path, frames_path] : clips) {
    ingested.push_back(IngestedFrames::Read(frames_path));
    const IngestedFrames& in = ingested.back();
    int64_t frame_dim = dim;
    const std::vector<float> frame_codes = ReadCodeRows(codes_path, in.NumFrames(), &frame_dim);
    const int size = in.crop_size();
    std::vector<int64_t>& rows = clip_rows.emplace_back();
    for (int64_t k = 0; k < in.NumFrames(); ++k) {
      if (!in.Found(k)) continue;
      d.codes.insert(d.codes.end(), frame_codes.begin() + k * dim, frame_codes.begin() + (k + 1) * dim);
      const auto l = in.CropLandmarks(k, size);
      for (int p = kFirstLandmark; p < kSampleLandmarks; ++p) {
        d.landmarks.push_back(l(p, 0) / size);
        d.landmarks.push_back(l(p, 1) / size);
      }
      rows.push_back(k);
    }
    if (rows.empty() && o.finetune_steps > 0) throw FileIOError(frames_path + ": no frame with a face for phase 3");
    d.num_frames += static_cast<int64_t>(rows.size());
  }
  // Phase 1's real frames: those of `frames`, and of every clip when more_tracks tracks them all.
  for (size_t c = 0; c < clip_rows.size() && (c == 0 || !o.more_tracks.empty()); ++c) {
    d.num_tracked_clip_frames += static_cast<int64_t>(clip_rows[c].size());
  }
  if (o.landmark_source == "translations" && !clips.empty() && (o.landmark_steps > 0 || o.finetune_steps > 0)) {
    // dlib on every example's translation D_S(E(I)), in the box ingest's detector typically
    // gives in a crop: L learns, and phase 3 matches, landmarks of one detector on one kind of
    // image.
    const face::FaceBox box = TypicalCropBox(o.frames, ingested[0]);
    const int threads = ThreadsPerRank(o.threads);
    std::vector<int64_t> sample_rows(static_cast<size_t>(d.num_samples));
    for (int64_t i = 0; i < d.num_samples; ++i) sample_rows[i] = i;
    std::vector<float> detected = LandmarksOfTranslations(o.sample_codes, sample_rows, box, threads);
    for (size_t c = 0; c < clips.size(); ++c) {
      const face::FaceBox clip_box = c == 0 ? box : TypicalCropBox(clips[c].second, ingested[c]);
      const std::vector<float> detected_frames =
          LandmarksOfTranslations(clips[c].first, clip_rows[c], clip_box, threads);
      detected.insert(detected.end(), detected_frames.begin(), detected_frames.end());
    }
    // How far dlib on the translations lands from the projected (samples) and the ingest
    // (real crops) landmarks: the detector's and the translation's bias that L absorbs.
    const auto mean_distance = [&](int64_t first, int64_t count) {
      double sum = 0;
      for (int64_t i = first; i < first + count; ++i) {
        for (int k = 0; k < kLandmarks; ++k) {
          const size_t at = static_cast<size_t>(i) * 2 * kLandmarks + 2 * k;
          sum += std::hypot(detected[at] - d.landmarks[at], detected[at + 1] - d.landmarks[at + 1]);
        }
      }
      return count > 0 ? sum / (static_cast<double>(count) * kLandmarks) : 0.0;
    };
    FC_INFO("regress train: dlib's landmarks on the translations are {:.4f} from the samples' projected ones and "
            "{:.4f} from those ingest detected on the real crops (fractions of the crop; box x {:.3f} y {:.3f} "
            "size {:.3f} x {:.3f})",
            mean_distance(0, d.num_samples), mean_distance(d.num_samples, d.num_frames), box.x, box.y, box.width,
            box.height);
    d.landmarks = std::move(detected);
  }

  d.code_mean.assign(dim, 0.f);
  d.code_scale.assign(dim, 0.f);
  for (int64_t j = 0; j < dim; ++j) {
    double sum = 0, sum2 = 0;
    for (int64_t i = 0; i < d.num_samples; ++i) sum += d.codes[i * dim + j];
    const double mean = sum / d.num_samples;
    for (int64_t i = 0; i < d.num_samples; ++i) sum2 += std::pow(d.codes[i * dim + j] - mean, 2);
    d.code_mean[j] = static_cast<float>(mean);
    d.code_scale[j] = static_cast<float>(1.0 / std::max(1e-3, std::sqrt(sum2 / d.num_samples)));
  }
  for (int64_t i = 0; i < d.num_samples + d.num_frames; ++i) {
    for (int64_t j = 0; j < dim; ++j) d.codes[i * dim + j] = (d.codes[i * dim + j] - d.code_mean[j]) * d.code_scale[j];
  }
  const auto add_truth = [&](const float* angles, const float* w) {
    for (int k = 0; k < kPose; ++k) d.pose.push_back(static_cast<float>(angles[k] / kPoseRange + 0.5));
    for (int j : d.jaw_shapes) d.jaw.push_back(std::clamp(w[j], 0.f, 1.f));
    for (int j : d.expression_shapes) d.expression.push_back(std::clamp(w[j], 0.f, 1.f));
  };
  for (int64_t i = 0; i < d.num_samples; ++i) add_truth(&pose[i * kPose], &weights[i * S]);
  d.has_truth.assign(static_cast<size_t>(d.num_samples), 1);
  // The real frames: the tracker's solution, its pose seen in the crop's camera, where it solved.
  std::vector<std::optional<TrackedRig>> tracked(clips.size());
  for (size_t c = 0; c < clips.size(); ++c) {
    const std::string& path = c == 0 ? o.track : o.more_tracks.empty() ? std::string() : o.more_tracks[c - 1];
    if (path.empty()) continue;
    tracked[c].emplace(path, rig);
    if (!tracked[c]->InSourceCamera() || tracked[c]->NumFrames() != ingested[c].NumFrames()) {
      throw FileIOError(path + ": a track of the crops of " + clips[c].second + " (" +
                        std::to_string(ingested[c].NumFrames()) +
                        " frames, as track --frames writes) is expected; it has " +
                        std::to_string(tracked[c]->NumFrames()) + " frames" +
                        (tracked[c]->InSourceCamera() ? "" : " in another camera"));
    }
  }
  for (size_t c = 0; c < clip_rows.size(); ++c) {
    for (int64_t k : clip_rows[c]) {
      const bool known = tracked[c] && tracked[c]->Solved(k);
      float angles[kPose] = {0.f, 0.f, 0.f};
      Eigen::VectorXf w = Eigen::VectorXf::Zero(S);
      if (known) {
        const rig::RigidPose p = PoseInCrop(tracked[c]->Pose(k), ingested[c].CropCamera(k, ingested[c].crop_size()));
        angles[0] = p.pitch;
        angles[1] = p.yaw;
        angles[2] = p.roll;
        w = tracked[c]->Weights(k);
      }
      add_truth(angles, w.data());
      d.has_truth.push_back(known ? 1 : 0);
      d.num_truth_frames += known ? 1 : 0;
    }
  }
  d.sizes.code = static_cast<int>(dim);
  d.sizes.pose = kPose;
  d.sizes.jaw = static_cast<int>(d.jaw_shapes.size());
  d.sizes.expression = static_cast<int>(d.expression_shapes.size());
  d.sizes.landmarks = 2 * kLandmarks;
  return d;
}

// The phase of a global step and the step within it.
struct PhaseStep {
  nn::Regressor::Phase phase;
  int64_t step;
};

// The regressor as the training controller sees them: the phases one after the other, each an
// epoch-wise permutation of its examples (the samples; phase 3 also the real frames).
class RegressTraining : public train::Network {
 public:
  RegressTraining(const RegressTrainOptions& o, const dist::Comm& comm, const RegressData& data)
      : o_(o), comm_(comm), d_(data), model_(o.net, data.sizes) {}
  int64_t total_steps() const {
    return static_cast<int64_t>(o_.pose_steps) + o_.landmark_steps + o_.finetune_steps;
  }
  int64_t NumParameters() const { return model_.NumParameters(); }

  int NumLosses() const override { return nn::Regressor::kNumLosses; }
  void Backward(int64_t step, double* losses) override {
    const PhaseStep ps = PhaseOf(step);
    // Phase 1 trains on the examples with truth (the samples, then the tracked clips), phase 2
    // on the samples, phase 3 on every example.
    const int examples = static_cast<int>(
        ps.phase == nn::Regressor::Phase::kFineTune            ? d_.num_samples + d_.num_frames
        : ps.phase == nn::Regressor::Phase::kPoseJawExpression && d_.num_truth_frames > 0
            ? d_.num_samples + d_.num_tracked_clip_frames
            : d_.num_samples);
    const int per_epoch = (examples + o_.batch - 1) / o_.batch;
    int size = 0;
    std::vector<nn::RegressorExample> mine;
    if (ps.phase == nn::Regressor::Phase::kFineTune && o_.net.anchor_weight > 0.f && anchors_.empty()) Anchor();
    const uint64_t seed = static_cast<uint64_t>(o_.seed) * 4 + static_cast<uint64_t>(ps.phase);
    for (int e : train::RankShareOfBatch(examples, o_.batch, seed, static_cast<uint64_t>(ps.step / per_epoch),
                                         static_cast<int>(ps.step % per_epoch), comm_.rank(), comm_.size(), &size)) {
      nn::RegressorExample x;
      x.code = &d_.codes[static_cast<size_t>(e) * d_.sizes.code];
      x.landmarks = &d_.landmarks[static_cast<size_t>(e) * d_.sizes.landmarks];
      if (d_.has_truth[e]) {
        x.pose = &d_.pose[static_cast<size_t>(e) * d_.sizes.pose];
        x.jaw = &d_.jaw[static_cast<size_t>(e) * d_.sizes.jaw];
        x.expression = &d_.expression[static_cast<size_t>(e) * d_.sizes.expression];
      } else if (!anchors_.empty()) {
        x.anchor = &anchors_[static_cast<size_t>(e - d_.num_samples) * AnchorSize()];
      }
      mine.push_back(x);
    }
    model_.Backward(ps.phase, mine, 1.f / static_cast<float>(size), losses);
    for (int k = 0; k < nn::Regressor::kNumLosses; ++k) losses[k] /= size;
  }
  float* gradients() override { return model_.Gradients(); }
  int64_t num_gradients() const override { return model_.NumParameters(); }
  void Apply(int64_t step) override {
    const PhaseStep ps = PhaseOf(step);
    if (ps.step == 0) model_.StartPhase(ps.phase);
    model_.OptimizerStep(ps.phase);
  }
  uint64_t ParameterHash() override { return model_.ParameterHash(); }
  void WriteState(io::H5File* f, int64_t) override {
    f->WriteVector<float>("/regressor/state", model_.State());
    f->SetAttribute("/regressor/state", "meaning",
                    std::string("the networks' parameters, Adam's moments and step count"));
    if (!anchors_.empty()) {
      f->WriteVector<float>("/regressor/anchors", anchors_);
      f->SetAttribute("/regressor/anchors", "meaning",
                      std::string("phase 3's anchors: each real frame's P, J, W outputs before phase 3"));
    }
  }
  void ReadState(const io::H5File& f) override {
    state_ = f.ReadVector<float>("/regressor/state", 3 * model_.NumParameters() + 1);
    if (f.Exists("/regressor/anchors")) anchors_ = f.ReadVector<float>("/regressor/anchors", d_.num_frames * AnchorSize());
  }
  void BroadcastState(const dist::Comm& comm, bool) override {
    comm.Broadcast(&state_);
    comm.Broadcast(&anchors_);
    if (!state_.empty()) model_.SetState(state_);
  }
  void WriteModel(io::H5File* f, int64_t steps_done) override {
    WriteState(f, steps_done);
    const char* r = "/regressor/state";
    f->SetAttribute(r, "code", static_cast<int64_t>(d_.sizes.code));
    f->SetAttribute(r, "hidden", static_cast<int64_t>(o_.net.hidden));
    f->SetAttribute(r, "layers", static_cast<int64_t>(o_.net.layers));
    f->SetAttribute(r, "leaky_slope", static_cast<double>(o_.net.leaky_slope));
    f->SetAttribute(r, "phase_steps", std::to_string(o_.pose_steps) + ", " + std::to_string(o_.landmark_steps) +
                                          ", " + std::to_string(o_.finetune_steps));
    f->WriteVector<float>("/regressor/code_mean", d_.code_mean);
    f->WriteVector<float>("/regressor/code_scale", d_.code_scale);
    f->SetAttribute("/regressor/code_scale", "meaning",
                    std::string("the networks' input is (e - code_mean) * code_scale, e = E(D_S(E(I)))"));
    f->WriteStrings("/regressor/shape_names", d_.shape_names);
    f->WriteVector<int32_t>("/regressor/jaw_shapes", d_.jaw_shapes);
    f->WriteVector<int32_t>("/regressor/expression_shapes", d_.expression_shapes);
    f->SetAttribute("/regressor/jaw_shapes", "meaning", std::string("indices into shape_names that J predicts"));
    f->SetAttribute("/regressor/expression_shapes", "meaning",
                    std::string("indices into shape_names that W predicts"));
    f->SetAttribute("/regressor", "pose", std::string("pitch, yaw, roll (rad) = (P(e) - 0.5) * pi, in the crop's camera"));
    f->SetAttribute("/regressor", "landmarks", std::string("L's (x, y) of the 51 iBUG points 17-67 (off the jaw contour) as fractions of the crop's size"));
    WriteFit(f);
  }
  std::string FormatLosses(int64_t done, const double* m) const override {
    const int phase = static_cast<int>(PhaseOf(std::max<int64_t>(0, done - 1)).phase);
    return fmt::format("phase {}  L_P {:.4f}  L_J {:.4f}  L_W {:.4f}  L_L {:.4f}", phase, m[0], m[1], m[2], m[3]);
  }

 private:
  // /regressor/fit: the model on its own training examples. On the samples the mean absolute
  // angle error (deg), the weights' mean absolute error and L(P, J, W)'s mean landmark
  // distance (fraction of the crop); on the real frames that landmark distance to the detected
  // landmarks. Logged as well.
  void WriteFit(io::H5File* f) {
    const nn::RegressorSizes& z = d_.sizes;
    const int64_t n = d_.num_samples + d_.num_frames;
    std::vector<float> pose(n * z.pose), jaw(n * z.jaw), expression(n * z.expression), lm(n * z.landmarks);
    model_.Predict(d_.codes.data(), static_cast<int>(n), pose.data(), jaw.data(), expression.data(), lm.data());
    double angle = 0, weight = 0, lm_samples = 0, lm_frames = 0;
    for (int64_t i = 0; i < d_.num_samples; ++i) {
      for (int k = 0; k < z.pose; ++k) angle += std::abs(pose[i * z.pose + k] - d_.pose[i * z.pose + k]);
      for (int k = 0; k < z.jaw; ++k) weight += std::abs(jaw[i * z.jaw + k] - d_.jaw[i * z.jaw + k]);
      for (int k = 0; k < z.expression; ++k) {
        weight += std::abs(expression[i * z.expression + k] - d_.expression[i * z.expression + k]);
      }
    }
    for (int64_t i = 0; i < n; ++i) {
      double sum = 0;
      for (int k = 0; k < z.landmarks; k += 2) {
        sum += std::hypot(lm[i * z.landmarks + k] - d_.landmarks[i * z.landmarks + k],
                          lm[i * z.landmarks + k + 1] - d_.landmarks[i * z.landmarks + k + 1]);
      }
      (i < d_.num_samples ? lm_samples : lm_frames) += sum / (z.landmarks / 2);
    }
    const double samples = static_cast<double>(d_.num_samples);
    const double pose_deg = angle / (samples * z.pose) * kPoseRange * 180.0 / M_PI;
    const double weights_mae = weight / (samples * (z.jaw + z.expression));
    lm_samples /= samples;
    if (d_.num_frames > 0) lm_frames /= static_cast<double>(d_.num_frames);
    f->SetAttribute("/regressor", "fit_samples_angle_err_deg", pose_deg);
    f->SetAttribute("/regressor", "fit_samples_weights_mae", weights_mae);
    f->SetAttribute("/regressor", "fit_samples_landmark_err", lm_samples);
    if (d_.num_frames > 0) f->SetAttribute("/regressor", "fit_frames_landmark_err", lm_frames);
    FC_INFO("regress train: on its training examples: samples' angles {:.2f} deg, weights MAE {:.4f}, L's "
            "landmarks {:.4f}; real frames' landmarks {} (fractions of the crop)",
            pose_deg, weights_mae, lm_samples, d_.num_frames > 0 ? fmt::format("{:.4f}", lm_frames) : "-");
  }

  int64_t AnchorSize() const { return d_.sizes.pose + d_.sizes.jaw + d_.sizes.expression; }
  // Phase 3's anchors: the real frames' P, J, W outputs as phase 3 starts (the same on every
  // rank, kept in the checkpoints for a resumed phase 3).
  void Anchor() {
    const nn::RegressorSizes& z = d_.sizes;
    const int64_t n = d_.num_frames;
    std::vector<float> pose(n * z.pose), jaw(n * z.jaw), expression(n * z.expression);
    model_.Predict(&d_.codes[static_cast<size_t>(d_.num_samples) * z.code], static_cast<int>(n), pose.data(),
                   jaw.data(), expression.data(), nullptr);
    anchors_.clear();
    for (int64_t i = 0; i < n; ++i) {
      anchors_.insert(anchors_.end(), pose.begin() + i * z.pose, pose.begin() + (i + 1) * z.pose);
      anchors_.insert(anchors_.end(), jaw.begin() + i * z.jaw, jaw.begin() + (i + 1) * z.jaw);
      anchors_.insert(anchors_.end(), expression.begin() + i * z.expression,
                      expression.begin() + (i + 1) * z.expression);
    }
  }

  PhaseStep PhaseOf(int64_t step) const {
    if (step < o_.pose_steps) return {nn::Regressor::Phase::kPoseJawExpression, step};
    step -= o_.pose_steps;
    if (step < o_.landmark_steps) return {nn::Regressor::Phase::kLandmarks, step};
    return {nn::Regressor::Phase::kFineTune, step - o_.landmark_steps};
  }

  const RegressTrainOptions& o_;
  const dist::Comm& comm_;
  const RegressData& d_;
  nn::Regressor model_;
  std::vector<float> state_;
  std::vector<float> anchors_;  // [frames, pose + jaw + expression] once phase 3 starts
};

}  // namespace

StageSummary RunRegressTrain(const RegressTrainOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  nn::SetTorchThreads(ThreadsPerRank(o.threads));
  RegressData data;
  dist::CoordinateExceptions(comm, [&] { data = ReadRegressData(o); });
  RegressTraining network(o, comm, data);
  if (comm.IsMainRank()) {
    FC_INFO("regress train: {} samples, {} real frames, codes of {}, {} jaw and {} other controls, {} parameters, "
            "phases of {}, {} and {} steps, batch {} on {} ranks",
            data.num_samples, data.num_frames, data.sizes.code, data.sizes.jaw, data.sizes.expression,
            network.NumParameters(), o.pose_steps, o.landmark_steps, o.finetune_steps, o.batch, comm.size());
  }
  train::ControllerOptions control =
      TrainingControl(ctx, resolved, "regress train", "regress.train", o.out, TrainingIdentity(o));
  control.steps = network.total_steps();
  control.checkpoint_every = o.checkpoint_every;
  control.progress_seconds = o.progress_seconds;
  const train::TrainResult r = train::Train(control, comm, &network);
  if (comm.IsMainRank() && !r.up_to_date) {
    FC_INFO("regress train: {} steps in {:.1f} s on {} ranks -> {}", r.steps_run, r.seconds, comm.size(), o.out);
  }
  return StageSummary{o.out, "steps", control.steps, r.steps_run};
}

namespace {

// -------------------------------------------------------------------------------------------

// A regress train model read back for prediction.
class RegressorModel {
 public:
  explicit RegressorModel(const std::string& path) {
    const io::H5File f = io::H5File::OpenRead(path);
    for (const char* name : {"/regressor/state", "/regressor/code_mean", "/regressor/code_scale",
                             "/regressor/shape_names", "/regressor/jaw_shapes", "/regressor/expression_shapes"}) {
      if (!f.Exists(name)) throw FileIOError(path + ": no " + std::string(name) + " (a regress train model is expected)");
    }
    mean_ = f.ReadVector<float>("/regressor/code_mean");
    scale_ = f.ReadVector<float>("/regressor/code_scale", static_cast<int64_t>(mean_.size()));
    names_ = f.ReadStrings("/regressor/shape_names");
    jaw_ = f.ReadVector<int32_t>("/regressor/jaw_shapes");
    expression_ = f.ReadVector<int32_t>("/regressor/expression_shapes");
    for (int32_t k : jaw_) CheckShape(path, k);
    for (int32_t k : expression_) CheckShape(path, k);
    nn::RegressorOptions options;
    options.hidden = static_cast<int>(f.GetIntAttribute("/regressor/state", "hidden"));
    options.layers = static_cast<int>(f.GetIntAttribute("/regressor/state", "layers"));
    options.leaky_slope = static_cast<float>(f.GetDoubleAttribute("/regressor/state", "leaky_slope"));
    std::string why;
    if (!options.Check(&why)) throw FileIOError(path + ": " + why);
    nn::RegressorSizes sizes;
    sizes.code = static_cast<int>(mean_.size());
    sizes.pose = kPose;
    sizes.jaw = static_cast<int>(jaw_.size());
    sizes.expression = static_cast<int>(expression_.size());
    sizes.landmarks = 2 * kLandmarks;
    net_ = std::make_unique<nn::Regressor>(options, sizes);
    const std::vector<float> state = f.ReadVector<float>("/regressor/state");
    try {
      net_->SetState(state);
    } catch (const FileIOError& e) {
      throw FileIOError(path + ": " + e.what());
    }
  }
  int code_size() const { return static_cast<int>(mean_.size()); }
  const std::vector<std::string>& shape_names() const { return names_; }

  // The pose (pitch, yaw, roll) and the weights in shape_names' order of one code.
  void Predict(const float* code, float pose[kPose], std::vector<float>* weights) const {
    std::vector<float> e(mean_.size());
    for (size_t j = 0; j < e.size(); ++j) e[j] = (code[j] - mean_[j]) * scale_[j];
    std::vector<float> p(kPose), jaw(jaw_.size()), expression(expression_.size());
    net_->Predict(e.data(), 1, p.data(), jaw.data(), expression.data(), nullptr);
    for (int k = 0; k < kPose; ++k) pose[k] = static_cast<float>((p[k] - 0.5) * kPoseRange);
    weights->assign(names_.size(), 0.f);
    for (size_t k = 0; k < jaw_.size(); ++k) (*weights)[jaw_[k]] = jaw[k];
    for (size_t k = 0; k < expression_.size(); ++k) (*weights)[expression_[k]] = expression[k];
  }

 private:
  void CheckShape(const std::string& path, int32_t k) const {
    if (k < 0 || k >= static_cast<int32_t>(names_.size())) {
      throw FileIOError(path + ": a control index " + std::to_string(k) + " outside /regressor/shape_names");
    }
  }
  std::vector<float> mean_, scale_;
  std::vector<std::string> names_;
  std::vector<int32_t> jaw_, expression_;
  std::unique_ptr<nn::Regressor> net_;
};

// One regress infer run: the model, codes, crops and rig on every rank, frames spread across
// ranks, the track file on rank 0.
class RegressInference {
 public:
  RegressInference(const RegressInferOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), ctx_(ctx), resolved_(resolved), comm_(ctx.comm) {
    dist::CoordinateExceptions(comm_, [&] {
      model_ = std::make_unique<RegressorModel>(o.model);
      ingested_ = IngestedFrames::Read(o.frames);
      int64_t dim = model_->code_size();
      codes_ = ReadCodeRows(o.codes, ingested_.NumFrames(), &dim);
      rig_ = io::ReadRigFile(o.rig);
      if (rig_.landmarks.size() != kSampleLandmarks) {
        throw FileIOError(o.rig + ": placing the head needs the rig's 68 landmarks");
      }
      // The rig's shapes in the model's order (-1: not predicted).
      for (const auto& s : rig_.shapes) {
        const auto& names = model_->shape_names();
        const auto it = std::find(names.begin(), names.end(), s.name);
        model_shape_.push_back(it == names.end() ? -1 : static_cast<int>(it - names.begin()));
      }
      if (std::count(model_shape_.begin(), model_shape_.end(), -1) == static_cast<long>(model_shape_.size())) {
        throw InvalidInputError(o.rig + ": none of its shapes is one the regressor " + o.model + " predicts");
      }
    });
    frames_ = ingested_.NumFrames();
    track::TrackerOptions placement;
    placement.objective = "landmarks";
    placement.solve_rotation = false;
    placement.landmark_weight = 1.f;
    placer_ = std::make_unique<track::Tracker>(rig_, track::RigRegionColors(rig_), placement);
  }

  StageSummary Run() {
    int64_t first_found = 0;
    while (first_found + 1 < frames_ && !ingested_.Found(first_found)) ++first_found;
    out_camera_ = ingested_.SourceCamera(first_found);
    FrameOutput out = OpenFrameOutput(ctx_, resolved_, "regress infer", o_.out, frames_, [&](io::H5File* f, bool resumed) {
      CreateTrackDatasets(f, frames_, static_cast<int>(rig_.NumShapes()));
      if (resumed) return;
      std::vector<std::string> names;
      for (const auto& s : rig_.shapes) names.push_back(s.name);
      WriteTrackRecords(f, names, out_camera_, render::FramingDistance(rig_, out_camera_, 0.56f));
      f->SetAttribute("/track", "rig", o_.rig);
      f->SetAttribute("/track", "regressor", o_.model);
      f->SetAttribute("/track", "targets", o_.codes);
      WriteSourceFrames(f, ingested_, o_.frames, frames_);
    });
    StageSummary summary{o_.out, "frames", frames_, 0};
    if (out.up_to_date) return summary;
    FrameLoopOptions loop;
    loop.what = "regress infer";
    loop.batch = o_.batch;
    loop.threads = 1;  // torch parallelizes inside each prediction
    summary.computed = RunFrameLoopAndCommit(
        comm_, out.pending, frames_, loop, [&](int64_t frame, int) { return Solve(frame); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          Commit(&out.output.file, frames, results);
        },
        &out.output);
    if (comm_.IsMainRank()) FC_INFO("regress infer: {} frames -> {}", frames_, o_.out);
    return summary;
  }

 private:
  // A frame's pose (in the source camera) and weights: the regressor's angles and controls,
  // the head moved (not turned) until its landmarks meet the detected ones in the crop.
  std::vector<uint8_t> Solve(int64_t frame) {
    const auto start = std::chrono::steady_clock::now();
    const int size = ingested_.crop_size();
    const render::CropView view = ingested_.CropCamera(frame, size);
    rig::RigidPose pose;
    Eigen::VectorXf weights = Eigen::VectorXf::Zero(rig_.NumShapes());
    int32_t termination = kNoTarget;
    const float distance = render::FramingDistance(rig_, view.camera, 0.56f);
    if (ingested_.Found(frame)) {
      float angles[kPose];
      std::vector<float> predicted;
      model_->Predict(&codes_[static_cast<size_t>(frame) * model_->code_size()], angles, &predicted);
      for (int s = 0; s < rig_.NumShapes(); ++s) {
        if (model_shape_[s] >= 0) weights[s] = predicted[model_shape_[s]];
      }
      rig::RigidPose start_pose = render::FramedPose(rig_, distance, angles[0], angles[1], angles[2]);
      start_pose.translation += view.camera.RayDirection(0.5f * size, 0.5f * size) * distance -
                                Eigen::Vector3f(0.f, 0.f, -distance);
      track::TrackTarget target;
      target.camera = view.camera;
      target.landmarks = ingested_.CropLandmarks(frame, size);
      pose = PoseInSource(placer_->PoseFromLandmarks(target, start_pose, weights), view);
      termination = 0;
    } else {
      pose = PoseInSource(render::FramedPose(rig_, distance, 0.f, 0.f), view);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ByteWriter w;
    w.PutVector(std::vector<float>{pose.pitch, pose.yaw, pose.roll, pose.translation.x(), pose.translation.y(),
                                   pose.translation.z(), pose.scale});
    w.PutArray(weights.data(), rig_.NumShapes());
    w.Put<int32_t>(termination);
    w.Put<double>(seconds);
    return std::move(w.bytes());
  }

  void Commit(io::H5File* f, const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
    const int S = rig_.NumShapes();
    for (size_t k = 0; k < frames.size(); ++k) {
      ByteReader r(results[k]);
      const std::vector<float> pose = r.GetVector<float>();  // angles, translation, scale
      const std::vector<float> weights = r.GetVector<float>();
      if (pose.size() != 7 || weights.size() != static_cast<size_t>(S)) throw std::runtime_error("regress infer: corrupt result");
      const int32_t termination = r.Get<int32_t>();
      const double seconds = r.Get<double>();
      const double zero = 0.;
      const int32_t none = 0;
      const int64_t i = frames[k];
      f->WriteFrames<float>("/track/pose", i, 1, &pose[0]);
      f->WriteFrames<float>("/track/translation", i, 1, &pose[3]);
      f->WriteFrames<float>("/track/scale", i, 1, &pose[6]);
      f->WriteFrames<float>("/track/weights", i, 1, weights.data());
      f->WriteFrames<double>("/track/cost", i, 1, &zero);
      f->WriteFrames<double>("/track/initial_cost", i, 1, &zero);
      f->WriteFrames<int32_t>("/track/iterations", i, 1, &none);
      f->WriteFrames<int32_t>("/track/evaluations", i, 1, &none);
      f->WriteFrames<int32_t>("/track/termination", i, 1, &termination);
      f->WriteFrames<double>("/track/seconds", i, 1, &seconds);
    }
    io::DoneMask mask(f, frames_);
    mask.MarkDone(frames);
  }

  const RegressInferOptions& o_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  std::unique_ptr<RegressorModel> model_;
  IngestedFrames ingested_;
  std::vector<float> codes_;
  rig::Rig rig_;
  std::vector<int> model_shape_;
  std::unique_ptr<track::Tracker> placer_;
  render::Camera out_camera_;
  int64_t frames_ = 0;
};

}  // namespace

StageSummary RunRegressInfer(const RegressInferOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  nn::SetTorchThreads(1);
  return RegressInference(o, ctx, resolved).Run();
}

}  // namespace facecap::stages
