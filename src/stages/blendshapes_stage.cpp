// facecap blendshapes train | baselines | infer, and facecap eval blendshapes: personalized
// blendshapes from one neutral scan (paper 001 Sec. 4) and their comparison with the template
// and example-based rigging (paper 001 Table 2).
//
// bsgen.h5: /template (rig.h5 layout: S_0 and the template shapes S_i), /model/parameters
// (the networks' parameters, attributes: image_size, channels, residual_blocks, head_width,
// head_depth, head_frame, head_local_frame, amplitude_width, amplitude_on_path,
// amplitude_components, input_scale, expression_scale; /model/amplitude_basis with
// amplitude_components), /training (train/controller.h). While training, bsgen.h5.checkpoint:
// /optimizer/state (parameters, Adam moments, steps) and /optimizer/parameter_sum (double: the
// sum of the parameters so far over the averaged steps) inside a stage's averaged steps
// (average_fraction).
// baselines.h5: /baselines/template/deltas and /baselines/example_based/deltas [P, N, V, 3].
// eval --shapes: /shapes/ours/deltas, /shapes/ours_estimation/deltas [P, N, V, 3] (cm),
// /errors/<method> [P, K] (mm, per scan), /errors/split [P].
#include "stages/blendshapes_stage.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <numeric>

#include "assets/bounded_least_squares.h"
#include "assets/deformation_transfer.h"
#include "assets/example_based_rigging.h"
#include "assets/geometry_image.h"
#include "assets/template_shapes.h"
#include "io/config.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "nn/blendshape_generator.h"
#include "stages/blendshape_predictor.h"
#include "stages/frame_loop.h"
#include "stages/holdout.h"
#include "stages/resumable.h"
#include "stages/texture_networks.h"
#include "train/controller.h"
#include "util/errors.h"
#include "util/hash.h"
#include "util/log.h"
#include "util/parallel_for.h"
#include "util/random.h"
#include "util/signals.h"

namespace facecap::stages {
namespace {

constexpr int kLargeMotionShapes = 14;  // paper 001 Sec. 4.1: 14 extreme blendshapes

// The scan database in memory.
struct ScanData {
  rig::Rig topology;                   // the template rig (S_0, topology, UVs)
  assets::LinearShapes tmpl;           // S_0 and S_i
  Eigen::MatrixXf alpha;               // K x N FACS weights
  std::vector<Eigen::VectorXf> neutral;      // per person, 3V
  std::vector<Eigen::MatrixXf> expressions;  // per person, 3V x K
  std::vector<Eigen::MatrixXf> truth;        // per person, 3V x N (synthetic only)
  std::vector<int> split;                    // 0 train, 1 held out
  int NumPeople() const { return static_cast<int>(neutral.size()); }
};

ScanData ReadScans(const std::string& path, bool with_truth) {
  ScanData d;
  io::H5File f = io::H5File::OpenRead(path);
  d.topology = io::ReadRig(f, "/template");
  d.tmpl = assets::LinearizeRig(d.topology);
  d.alpha = f.ReadMatrix<float>("/scans/facs/weights", -1, d.tmpl.NumShapes());
  const int V = d.tmpl.NumVertices(), K = static_cast<int>(d.alpha.rows()), N = d.tmpl.NumShapes();
  d.split = f.ReadVector<int32_t>("/scans/people/split", f.NumFrames("/scans/people/neutral"));
  const int P = static_cast<int>(d.split.size());
  with_truth = with_truth && f.Exists("/scans/truth/deltas");
  for (int j = 0; j < P; ++j) {
    Eigen::VectorXf n(3 * V);
    f.ReadFrames<float>("/scans/people/neutral", j, 1, n.data());
    d.neutral.push_back(n);
    Eigen::MatrixXf e(3 * V, K);
    f.ReadFrames<float>("/scans/people/expressions", j, 1, e.data());
    d.expressions.push_back(e);
    if (with_truth) {
      Eigen::MatrixXf t(3 * V, N);
      f.ReadFrames<float>("/scans/truth/deltas", j, 1, t.data());
      d.truth.push_back(t);
    }
  }
  return d;
}

// Everything the networks need that follows from the template and the image size.
struct NetSetup {
  std::unique_ptr<assets::GeometryImageLayout> layout;
  std::shared_ptr<nn::BlendshapeNetGeometry> geometry;
  std::vector<float> template_image;   // HWC image of S_0
};

NetSetup MakeNetSetup(const rig::Rig& topology, const assets::LinearShapes& tmpl, int image_size) {
  NetSetup s;
  const std::vector<int> chart = assets::ChartVertices(topology, assets::MovingVertices(tmpl));
  assets::GeometryImageOptions go;
  go.size = image_size;
  s.layout = std::make_unique<assets::GeometryImageLayout>(topology, chart, go);
  auto g = std::make_shared<nn::BlendshapeNetGeometry>();
  const int N = tmpl.NumShapes(), A = static_cast<int>(chart.size()), H = image_size;
  g->image_size = H;
  g->num_shapes = N;
  g->num_chart_vertices = A;
  g->template_deltas.resize(static_cast<size_t>(N) * A * 3);
  g->reg_weights.resize(static_cast<size_t>(N) * A);
  std::vector<double> total(N, 0.0);
  for (int i = 0; i < N; ++i) {
    float largest = 0.f;
    for (int k = 0; k < A; ++k) {
      const Eigen::Vector3f d = tmpl.deltas.block<3, 1>(3 * chart[k], i);
      for (int c = 0; c < 3; ++c) g->template_deltas[(static_cast<size_t>(i) * A + k) * 3 + c] = d[c];
      total[i] += d.norm();
      largest = std::max(largest, d.norm());
    }
    // m_i(x) (eq. 6): lambda_l / ||S_i(x)|| on moving vertices (>= 1% of the largest motion),
    // normalized to at most 1; 4 on the fixed vertices.
    const float moving = 0.01f * largest;
    for (int k = 0; k < A; ++k) {
      const float n = tmpl.deltas.block<3, 1>(3 * chart[k], i).norm();
      g->reg_weights[static_cast<size_t>(i) * A + k] = n > moving ? moving / n : 4.f;
    }
  }
  // g_i (eq. 5): lambda_g / sum_x ||S_i(x)||, lambda_g making the largest g_i 1.
  const double lambda_g = *std::min_element(total.begin(), total.end());
  for (int i = 0; i < N; ++i) {
    const float gi = total[i] > 0 ? static_cast<float>(lambda_g / total[i]) : 1.f;
    for (int k = 0; k < A; ++k) g->reg_weights[static_cast<size_t>(i) * A + k] *= gi;
  }
  std::vector<int> order(N);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return total[a] > total[b]; });
  g->large_motion_shapes.assign(order.begin(), order.begin() + std::min(N, kLargeMotionShapes));
  for (size_t k = 0; k < chart.size(); ++k) {
    for (int j = 0; j < 4; ++j) {
      g->sample_pixels.push_back(s.layout->sample_pixels()[k][j]);
      g->sample_weights.push_back(s.layout->sample_weights()[k][j]);
    }
  }
  // Static channels: the template's geometry image (normalized per channel) and coverage.
  s.template_image = s.layout->Render(tmpl.neutral);
  g->num_static_channels = 4;
  g->static_channels.resize(4 * static_cast<size_t>(H) * H);
  for (int c = 0; c < 3; ++c) {
    double mean = 0, sq = 0;
    for (int p = 0; p < H * H; ++p) mean += s.template_image[3 * p + c];
    mean /= H * H;
    for (int p = 0; p < H * H; ++p) sq += std::pow(s.template_image[3 * p + c] - mean, 2);
    const double sd = std::sqrt(sq / (H * H)) + 1e-6;
    for (int p = 0; p < H * H; ++p) {
      g->static_channels[c * H * H + p] = static_cast<float>((s.template_image[3 * p + c] - mean) / sd);
    }
  }
  for (int p = 0; p < H * H; ++p) g->static_channels[3 * H * H + p] = s.layout->coverage()[p];
  s.geometry = g;
  return s;
}

// Channels-first image of (mesh - reference) / scale; mesh as a 3V column.
std::vector<float> DisplacementImage(const NetSetup& s, const Eigen::Ref<const Eigen::VectorXf>& mesh,
                                     const std::vector<float>& reference, float scale) {
  const std::vector<float> image = s.layout->RenderColumn(mesh);
  const int P = s.layout->NumPixels();
  std::vector<float> out(3 * static_cast<size_t>(P));
  for (int p = 0; p < P; ++p) {
    for (int c = 0; c < 3; ++c) out[c * P + p] = (image[3 * p + c] - reference[3 * p + c]) / scale;
  }
  return out;
}

std::vector<float> ChartValues(const std::vector<int>& chart, const Eigen::Ref<const Eigen::VectorXf>& column) {
  std::vector<float> out(3 * chart.size());
  for (size_t k = 0; k < chart.size(); ++k) {
    for (int c = 0; c < 3; ++c) out[3 * k + c] = column[3 * chart[k] + c];
  }
  return out;
}

// Personal shapes S_i^j = S_i + Delta S_i (eq. 3) on the chart vertices, template elsewhere.
Eigen::MatrixXf ShapesFromOffsets(const assets::LinearShapes& tmpl, const std::vector<int>& chart,
                                  const std::vector<float>& offsets) {
  Eigen::MatrixXf shapes = tmpl.deltas;
  const int N = tmpl.NumShapes(), A = static_cast<int>(chart.size());
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < A; ++k) {
      for (int c = 0; c < 3; ++c) shapes(3 * chart[k] + c, i) += offsets[(static_cast<size_t>(i) * A + k) * 3 + c];
    }
  }
  return shapes;
}

// ---------------------------------------------------------------------------------------------

float RmsOverChart(const std::vector<int>& chart, const std::vector<Eigen::VectorXf>& meshes,
                   const Eigen::VectorXf& reference) {
  double sum = 0;
  int64_t count = 0;
  for (const auto& m : meshes) {
    for (int v : chart) { sum += (m.segment<3>(3 * v) - reference.segment<3>(3 * v)).squaredNorm(); count += 3; }
  }
  return count ? static_cast<float>(std::sqrt(sum / count)) + 1e-6f : 1.f;
}

// The training people as the networks see them, and the scales of their displacement images.
struct TrainingPeople {
  std::vector<nn::BlendshapePerson> people;
  float input_scale = 1.f, expression_scale = 1.f;
};

TrainingPeople PrepareTrainingPeople(const ScanData& data, const NetSetup& setup,
                                     const BlendshapesTrainOptions& o) {
  const std::vector<int>& chart = setup.layout->chart_vertices();
  std::vector<int> train;
  for (int j = 0; j < data.NumPeople(); ++j) if (data.split[j] == 0) train.push_back(j);
  const Eigen::VectorXf template_column = Eigen::Map<const Eigen::VectorXf>(data.tmpl.neutral.data(), data.tmpl.neutral.size());
  std::vector<Eigen::VectorXf> train_neutrals, train_expressions;
  for (int j : train) {
    train_neutrals.push_back(data.neutral[j]);
    for (int k = 0; k < data.alpha.rows(); ++k) train_expressions.push_back(data.expressions[j].col(k) - data.neutral[j] + template_column);
  }
  TrainingPeople out;
  out.input_scale = RmsOverChart(chart, train_neutrals, template_column);
  out.expression_scale = RmsOverChart(chart, train_expressions, template_column);
  const int K = static_cast<int>(data.alpha.rows());
  out.people.resize(train.size());
  ParallelFor(0, static_cast<int>(train.size()), ThreadsPerRank(o.threads), [&](int t) {
    const int j = train[t];
    nn::BlendshapePerson& p = out.people[t];
    p.num_expressions = K;
    p.neutral_image = DisplacementImage(setup, data.neutral[j], setup.template_image, out.input_scale);
    p.neutral = ChartValues(chart, data.neutral[j]);
    const std::vector<float> neutral_image_raw = setup.layout->RenderColumn(data.neutral[j]);
    for (int k = 0; k < K; ++k) {
      const auto e = ChartValues(chart, data.expressions[j].col(k));
      p.expressions.insert(p.expressions.end(), e.begin(), e.end());
      const auto img = DisplacementImage(setup, data.expressions[j].col(k), neutral_image_raw, out.expression_scale);
      p.expression_images.insert(p.expression_images.end(), img.begin(), img.end());
    }
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> a = o.nominal_weight * data.alpha;
    p.nominal_weights.assign(a.data(), a.data() + a.size());
  });
  return out;
}

// The blendshape generator as the training controller sees it: the Estimation Stage's steps,
// then the Tuning Stage's, each epoch a permutation of the training people drawn from
// Rng(seed, epoch), the ranks taking every comm.size()-th person of a step's batch; each stage
// ends on the mean of its last average_fraction of iterates.
class BlendshapesTraining : public train::Network {
 public:
  BlendshapesTraining(const BlendshapesTrainOptions& o, const dist::Comm& comm,
                      const ScanData& data, const NetSetup& setup, TrainingPeople* people)
      : o_(o), comm_(comm), data_(data), people_(*people), model_(o.net, setup.geometry),
        num_people_(static_cast<int>(people->people.size())),
        steps_per_epoch_((num_people_ + o.batch - 1) / o.batch),
        estimation_steps_(static_cast<int64_t>(o.estimation_epochs) * steps_per_epoch_),
        total_steps_(estimation_steps_ + static_cast<int64_t>(o.tuning_epochs) * steps_per_epoch_) {
    std::vector<const nn::BlendshapePerson*> all;
    for (const auto& p : people_.people) all.push_back(&p);
    model_.FitAmplitudeBasis(all);  // (amplitude_components > 0 only)
  }
  int64_t total_steps() const { return total_steps_; }
  int64_t estimation_steps() const { return estimation_steps_; }
  int64_t NumParameters() const { return model_.NumParameters(); }

  int NumLosses() const override { return 2; }
  void Backward(int64_t step, double* losses) override {
    const Position at = PositionOf(step);
    const int64_t epoch = at.stage_step / steps_per_epoch_ + (at.stage == nn::TrainingStage::kTuning ? 100000 : 0);
    const int in_epoch = static_cast<int>(at.stage_step % steps_per_epoch_);
    int size = 0;
    std::vector<const nn::BlendshapePerson*> mine;
    for (int j : train::RankShareOfBatch(num_people_, o_.batch, static_cast<uint64_t>(o_.seed),
                                         static_cast<uint64_t>(epoch), in_epoch, comm_.rank(), comm_.size(), &size)) {
      mine.push_back(&people_.people[j]);
    }
    double rec = 0;
    losses[0] = model_.Backward(mine, at.stage, 1.f / static_cast<float>(size), &rec);
    losses[1] = rec / size;
  }
  float* gradients() override { return model_.GradientBuffer(); }
  int64_t num_gradients() const override { return model_.NumParameters(); }
  void Apply(int64_t step) override {
    const Position at = PositionOf(step);
    model_.OptimizerStep(at.stage);
    // Iterate averaging over the stage's last average_fraction of steps; at the stage's end the
    // model takes the mean (the other stage's parameters are constant meanwhile).
    const int64_t averaged = static_cast<int64_t>(std::floor(o_.average_fraction * static_cast<double>(at.stage_steps)));
    if (averaged > 1 && at.stage_step >= at.stage_steps - averaged) {
      const std::vector<float> now = model_.Parameters();
      if (average_.empty()) average_.assign(now.size(), 0.0);
      for (size_t k = 0; k < now.size(); ++k) average_[k] += now[k];
      if (at.stage_step + 1 == at.stage_steps) {
        std::vector<float> mean(now.size());
        for (size_t k = 0; k < now.size(); ++k) mean[k] = static_cast<float>(average_[k] / static_cast<double>(averaged));
        model_.SetParameters(mean);
        average_.clear();
      }
    }
  }
  uint64_t ParameterHash() override {
    const std::vector<float> parameters = model_.Parameters();
    return Fnv1a(parameters.data(), parameters.size() * sizeof(float));
  }

  // /optimizer/state: the parameters, Adam moments and step counts; /optimizer/parameter_sum
  // (double): the running sum of the parameters inside a stage's averaged steps.
  void WriteState(io::H5File* f, int64_t) override {
    f->WriteVector<float>("/optimizer/state", model_.State());
    if (!average_.empty()) f->WriteVector<double>("/optimizer/parameter_sum", average_);
  }
  void ReadState(const io::H5File& f) override {
    state_ = f.ReadVector<float>("/optimizer/state", 3 * model_.NumParameters() + 2);
    if (f.Exists("/optimizer/parameter_sum")) {
      average_ = f.ReadVector<double>("/optimizer/parameter_sum", model_.NumParameters());
    }
  }
  void BroadcastState(const dist::Comm& comm, bool) override {
    comm.Broadcast(&state_);
    comm.Broadcast(&average_);
    if (!state_.empty()) model_.SetState(state_);
    started_ = std::chrono::steady_clock::now();
  }
  void WriteModel(io::H5File* f, int64_t steps_done) override;

  std::string FormatLosses(int64_t done, const double* means) const override {
    return fmt::format("{}  loss {:.5f}  L_rec {:.4f} mm", done <= estimation_steps_ ? "estimation" : "tuning",
                       means[0], 10.0 * means[1]);
  }

 private:
  struct Position {
    nn::TrainingStage stage;
    int64_t stage_step;   // the step within its stage
    int64_t stage_steps;  // the stage's steps
  };
  Position PositionOf(int64_t step) const {
    if (step < estimation_steps_) return {nn::TrainingStage::kEstimation, step, estimation_steps_};
    return {nn::TrainingStage::kTuning, step - estimation_steps_, total_steps_ - estimation_steps_};
  }

  const BlendshapesTrainOptions& o_;
  const dist::Comm& comm_;
  const ScanData& data_;
  const TrainingPeople& people_;
  nn::BlendshapeGenerator model_;
  const int num_people_;
  const int steps_per_epoch_;
  const int64_t estimation_steps_, total_steps_;
  std::vector<float> state_;     // rank 0: the state a continued run starts from
  // The running sum of the parameters over the averaged steps of the current stage (empty
  // outside them), in double: the same on every rank and after a resume.
  std::vector<double> average_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

void BlendshapesTraining::WriteModel(io::H5File* f, int64_t steps_done) {
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  f->SetAttribute("/", "parameter_hash", std::to_string(ParameterHash()));
  io::WriteRig(data_.topology, f, "/template");
  f->WriteVector<float>("/model/parameters", model_.Parameters());
  const char* p = "/model/parameters";
  f->SetAttribute(p, "image_size", static_cast<int64_t>(o_.image_size));
  f->SetAttribute(p, "channels", static_cast<int64_t>(o_.net.channels));
  f->SetAttribute(p, "residual_blocks", static_cast<int64_t>(o_.net.residual_blocks));
  f->SetAttribute(p, "head_width", static_cast<int64_t>(o_.net.head_width));
  f->SetAttribute(p, "amplitude_width", static_cast<int64_t>(o_.net.amplitude_width));
  f->SetAttribute(p, "head_frame", static_cast<int64_t>(o_.net.head_frame ? 1 : 0));
  f->SetAttribute(p, "head_depth", static_cast<int64_t>(o_.net.head_depth));
  f->SetAttribute(p, "head_local_frame", static_cast<int64_t>(o_.net.head_local_frame ? 1 : 0));
  f->SetAttribute(p, "amplitude_on_path", static_cast<int64_t>(o_.net.amplitude_on_path ? 1 : 0));
  f->SetAttribute(p, "amplitude_components", static_cast<int64_t>(o_.net.amplitude_components));
  if (o_.net.amplitude_components > 0) {
    const std::vector<float> basis = model_.AmplitudeBasis();  // [components + 1, features]
    const int64_t rows = o_.net.amplitude_components + 1;
    f->Write<float>("/model/amplitude_basis", {rows, static_cast<int64_t>(basis.size()) / rows}, basis.data());
  }
  f->SetAttribute(p, "input_scale", static_cast<double>(people_.input_scale));
  f->SetAttribute(p, "expression_scale", static_cast<double>(people_.expression_scale));
  f->SetAttribute(p, "train_seconds", seconds);
  f->SetAttribute(p, "train_steps", steps_done);
}

}  // namespace

StageSummary RunBlendshapesTrain(const BlendshapesTrainOptions& o, const StageContext& ctx,
                                 const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  ScanData data;
  dist::CoordinateExceptions(comm, [&] { data = ReadScans(o.scans, false); });
  nn::SetTensorThreads(ThreadsPerRank(o.threads));
  const NetSetup setup = MakeNetSetup(data.topology, data.tmpl, o.image_size);
  TrainingPeople people = PrepareTrainingPeople(data, setup, o);
  BlendshapesTraining network(o, comm, data, setup, &people);
  if (comm.IsMainRank()) {
    FC_INFO("blendshapes train: {} training people, {} parameters, {} steps ({} estimation), batch {} on {} ranks, "
            "geometry images {}x{}, {} chart vertices", people.people.size(), network.NumParameters(),
            network.total_steps(), network.estimation_steps(), o.batch, comm.size(), o.image_size, o.image_size,
            setup.layout->chart_vertices().size());
  }
  train::ControllerOptions control = TrainingControl(ctx, resolved, "blendshapes train",
                                                     "blendshapes.train", o.out, TrainingIdentity(o));
  control.steps = network.total_steps();
  control.checkpoint_every = o.checkpoint_every;
  control.progress_seconds = o.progress_seconds;
  const train::TrainResult r = train::Train(control, comm, &network);
  if (comm.IsMainRank() && !r.up_to_date) {
    FC_INFO("blendshapes train: {} steps in {:.1f} s ({:.3f} s per step) on {} ranks -> {}", r.steps_run,
            r.seconds, r.seconds / std::max<int64_t>(1, r.steps_run), comm.size(), o.out);
  }
  return StageSummary{o.out, "steps", control.steps, r.steps_run};
}

namespace {

// A trained model loaded for inference.
struct LoadedModel {
  rig::Rig topology;
  assets::LinearShapes tmpl;
  NetSetup setup;
  std::unique_ptr<nn::BlendshapeGenerator> model;
  float input_scale = 1.f;

  // The personalized shapes (3V x N) for one neutral (3V).
  // tuned: Estimation and Tuning Stage (the final shapes); else the Estimation Stage alone.
  Eigen::MatrixXf Personalize(const Eigen::VectorXf& neutral, bool tuned = true) const {
    const auto image = DisplacementImage(setup, neutral, setup.template_image, input_scale);
    return ShapesFromOffsets(tmpl, setup.layout->chart_vertices(), model->PredictOffsets(image, tuned));
  }
};

LoadedModel LoadModel(const std::string& path) {
  LoadedModel m;
  io::H5File f = io::H5File::OpenRead(path);
  m.topology = io::ReadRig(f, "/template");
  m.tmpl = assets::LinearizeRig(m.topology);
  const int size = static_cast<int>(f.GetIntAttribute("/model/parameters", "image_size"));
  nn::BlendshapeNetOptions no;
  no.channels = static_cast<int>(f.GetIntAttribute("/model/parameters", "channels"));
  no.residual_blocks = static_cast<int>(f.GetIntAttribute("/model/parameters", "residual_blocks"));
  if (!f.HasAttribute("/model/parameters", "head_width")) {
    throw FileIOError(path + ": a model from before the template-conditioned heads (no head_width attribute); train it again");
  }
  no.head_width = static_cast<int>(f.GetIntAttribute("/model/parameters", "head_width"));
  // (Models from before the per-shape amplitude and the motion-frame heads have neither.)
  no.head_frame = f.HasAttribute("/model/parameters", "head_frame") &&
                  f.GetIntAttribute("/model/parameters", "head_frame") != 0;
  no.head_depth = f.HasAttribute("/model/parameters", "head_depth")
                      ? static_cast<int>(f.GetIntAttribute("/model/parameters", "head_depth")) : 1;
  no.head_local_frame = f.HasAttribute("/model/parameters", "head_local_frame") &&
                        f.GetIntAttribute("/model/parameters", "head_local_frame") != 0;
  no.amplitude_on_path = f.HasAttribute("/model/parameters", "amplitude_on_path") &&
                         f.GetIntAttribute("/model/parameters", "amplitude_on_path") != 0;
  no.amplitude_width = f.HasAttribute("/model/parameters", "amplitude_width")
                           ? static_cast<int>(f.GetIntAttribute("/model/parameters", "amplitude_width")) : 0;
  no.amplitude_components = f.HasAttribute("/model/parameters", "amplitude_components")
                                ? static_cast<int>(f.GetIntAttribute("/model/parameters", "amplitude_components")) : 0;
  m.input_scale = static_cast<float>(f.GetDoubleAttribute("/model/parameters", "input_scale"));
  m.setup = MakeNetSetup(m.topology, m.tmpl, size);
  m.model = std::make_unique<nn::BlendshapeGenerator>(no, m.setup.geometry);
  m.model->SetParameters(f.ReadVector<float>("/model/parameters", m.model->NumParameters()));
  if (no.amplitude_components > 0) {
    if (!f.Exists("/model/amplitude_basis")) throw FileIOError(path + ": no /model/amplitude_basis for its amplitude_components");
    m.model->SetAmplitudeBasis(f.Read<float>("/model/amplitude_basis", {}));
  }
  m.model->PrepareInference();
  return m;
}

}  // namespace

struct BlendshapePredictor::Impl {
  LoadedModel m;
};

BlendshapePredictor::BlendshapePredictor(const std::string& model_path)
    : impl_(std::make_unique<Impl>(Impl{LoadModel(model_path)})) {}
BlendshapePredictor::~BlendshapePredictor() = default;

const rig::Rig& BlendshapePredictor::topology() const { return impl_->m.topology; }

assets::LinearShapes BlendshapePredictor::Personalize(const rig::Vertices& neutral) const {
  if (neutral.rows() != impl_->m.tmpl.NumVertices()) {
    throw InvalidInputError("blendshape model: a neutral of " + std::to_string(neutral.rows()) +
                            " vertices for a template of " + std::to_string(impl_->m.tmpl.NumVertices()));
  }
  assets::LinearShapes out;
  out.neutral = neutral;
  out.names = impl_->m.tmpl.names;
  out.deltas = impl_->m.Personalize(Eigen::Map<const Eigen::VectorXf>(neutral.data(), neutral.size()));
  return out;
}

namespace {

// The expressions an example-based fit with hold-out sees: all but every holdout_every-th
// (k % holdout_every == holdout_every - 1); all when holdout_every is 0.
std::vector<int> SeenExpressions(int count, int holdout_every) {
  std::vector<int> seen;
  for (int k = 0; k < count; ++k) {
    if (!IsHeldOut(k, holdout_every)) seen.push_back(k);
  }
  return seen;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
StageSummary RunBlendshapesBaselines(const BlendshapesBaselinesOptions& options,
                                     const StageContext& ctx, const io::Config& resolved) {
  BlendshapesBaselinesOptions o = options;  // example.threads is set below
  const dist::Comm& comm = ctx.comm;
  ResumableOutput output;
  int up_to_date = 0;
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "blendshapes baselines", resolved));
    up_to_date = output.up_to_date ? 1 : 0;
  });
  comm.Broadcast(&up_to_date, sizeof(up_to_date));
  if (up_to_date) {
    if (comm.IsMainRank()) FC_INFO("blendshapes baselines: {} is up to date", o.out);
    return StageSummary{o.out, "files", 1, 0};
  }
  ScanData data;
  dist::CoordinateExceptions(comm, [&] { data = ReadScans(o.scans, false); });
  const std::vector<int> moving = assets::MovingVertices(data.tmpl);
  const int P = data.NumPeople(), V = data.tmpl.NumVertices(), N = data.tmpl.NumShapes();
  const dist::Range mine = dist::BlockRange(P, comm.rank(), comm.size());
  const int count = static_cast<int>(mine.end - mine.begin);
  std::vector<Eigen::MatrixXf> transferred(count), example(count), holdout(count);
  const std::vector<int> seen = SeenExpressions(static_cast<int>(data.alpha.rows()), o.holdout_every);
  o.example.threads = 1;
  const auto started = std::chrono::steady_clock::now();
  ParallelFor(0, count, ThreadsPerRank(o.threads), [&](int k) {
    const int j = static_cast<int>(mine.begin) + k;
    const rig::Vertices neutral = Eigen::Map<const rig::Vertices>(data.neutral[j].data(), V, 3);
    const assets::DeformationTransfer transfer(data.tmpl.neutral, neutral, data.topology.triangles);
    transferred[k] = transfer.TransferDeltas(data.tmpl.deltas);
    example[k] = assets::FitExampleBasedRig(data.neutral[j], data.expressions[j], data.alpha, transferred[k],
                                            data.tmpl.deltas, moving, o.example).deltas;
    if (o.holdout_every > 0) {
      Eigen::MatrixXf expressions(data.expressions[j].rows(), static_cast<int>(seen.size()));
      Eigen::MatrixXf alpha(static_cast<int>(seen.size()), data.alpha.cols());
      for (size_t i = 0; i < seen.size(); ++i) {
        expressions.col(i) = data.expressions[j].col(seen[i]);
        alpha.row(i) = data.alpha.row(seen[i]);
      }
      holdout[k] = assets::FitExampleBasedRig(data.neutral[j], expressions, alpha, transferred[k],
                                              data.tmpl.deltas, moving, o.example).deltas;
    } else {
      holdout[k] = example[k];
    }
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::vector<uint8_t> bytes;
  for (int k = 0; k < count; ++k) {
    for (const Eigen::MatrixXf* m : {&transferred[k], &example[k], &holdout[k]}) {
      const uint8_t* b = reinterpret_cast<const uint8_t*>(m->data());
      bytes.insert(bytes.end(), b, b + m->size() * sizeof(float));
    }
  }
  const auto gathered = comm.Gather(bytes);
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    io::H5File& f = output.file;
    f.CreateFrames<float>("/baselines/template/deltas", {N, V, 3}, P, 1);
    f.CreateFrames<float>("/baselines/example_based/deltas", {N, V, 3}, P, 1);
    f.SetAttribute("/baselines/template/deltas", "method", std::string("template shapes moved onto the neutral by deformation transfer"));
    f.SetAttribute("/baselines/example_based/deltas", "method", std::string("example-based facial rigging on the person's scans"));
    if (o.holdout_every > 0) {
      f.CreateFrames<float>("/baselines/example_based_holdout/deltas", {N, V, 3}, P, 1);
      f.SetAttribute("/baselines/example_based_holdout/deltas", "method",
                     std::string("example-based facial rigging on the person's scans except the held-out expressions"));
      f.SetAttribute("/baselines/example_based_holdout/deltas", "holdout_every", static_cast<int64_t>(o.holdout_every));
    }
    int person = 0;
    const size_t per = sizeof(float) * 3 * V * N;
    for (const auto& chunk : gathered) {
      for (size_t at = 0; at + 3 * per <= chunk.size(); at += 3 * per, ++person) {
        f.WriteFrames<float>("/baselines/template/deltas", person, 1, reinterpret_cast<const float*>(chunk.data() + at));
        f.WriteFrames<float>("/baselines/example_based/deltas", person, 1, reinterpret_cast<const float*>(chunk.data() + at + per));
        if (o.holdout_every > 0) {
          f.WriteFrames<float>("/baselines/example_based_holdout/deltas", person, 1,
                               reinterpret_cast<const float*>(chunk.data() + at + 2 * per));
        }
      }
    }
    f.Commit();
    FC_INFO("blendshapes baselines: {} people in {:.1f} s on rank 0 -> {}", P, seconds, o.out);
  });
  return StageSummary{o.out, "files", 1, 1};
}

// ---------------------------------------------------------------------------------------------
StageSummary RunBlendshapesInfer(const BlendshapesInferOptions& o, const StageContext& ctx,
                                 const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    nn::SetTensorThreads(o.threads);
    const LoadedModel m = LoadModel(o.model);
    io::Mesh mesh;
    if (!o.neutral.empty()) {
      mesh = io::ReadMeshObj(o.neutral);
    } else {
      const io::H5File f = io::H5File::OpenRead(o.scans);
      const io::Shape shape = f.DatasetShape("/scans/people/neutral");
      if (shape.size() != 3 || shape[2] != 3) throw FileIOError(o.scans + ": /scans/people/neutral is not [P, V, 3]");
      mesh.vertices.resize(shape[1], 3);
      f.ReadFrames<float>("/scans/people/neutral", ScanPersonIndex(f, o.scans, o.person, static_cast<int>(shape[0])), 1,
                          mesh.vertices.data());
    }
    const std::string input = o.neutral.empty() ? o.scans : o.neutral;
    if (mesh.vertices.rows() != m.tmpl.NumVertices()) {
      throw FileIOError(input + ": " + std::to_string(mesh.vertices.rows()) + " vertices, the model's template has " +
                        std::to_string(m.tmpl.NumVertices()));
    }
    const Eigen::VectorXf neutral = Eigen::Map<const Eigen::VectorXf>(mesh.vertices.data(), mesh.vertices.size());
    const auto started = std::chrono::steady_clock::now();
    assets::LinearShapes personal;
    personal.neutral = mesh.vertices;
    personal.names = m.tmpl.names;
    personal.deltas = m.Personalize(neutral);
    const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    io::H5File f = io::H5File::CreateAtomic(o.out);
    f.WriteProvenance(MakeProvenance(ctx, "blendshapes infer", resolved));
    io::WriteRig(assets::RigFromLinearShapes(personal, m.topology), &f);
    f.Commit();
    FC_INFO("blendshapes infer: {} shapes in {:.1f} ms -> {}", personal.NumShapes(), ms, o.out);
    summary.items = 1;
    summary.computed = 1;
  });
  return summary;
}

// ---------------------------------------------------------------------------------------------
StageSummary RunEvalBlendshapes(const EvalBlendshapesOptions& o, const StageContext& ctx,
                                const io::Config& resolved) {
  StageSummary summary{o.markdown, "files", 0, 0};
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    nn::SetTensorThreads(1);
    const ScanData data = ReadScans(o.scans, true);
    const LoadedModel m = LoadModel(o.model);
    io::H5File bf = io::H5File::OpenRead(o.baselines);
    const std::vector<int> moving = assets::MovingVertices(data.tmpl);
    const int P = data.NumPeople(), V = data.tmpl.NumVertices(), N = data.tmpl.NumShapes();
    const bool has_truth = !data.truth.empty();
    // Held-out expressions: those the example-based fit with hold-out did not see.
    int holdout_every = 0;
    if (bf.Exists("/baselines/example_based_holdout/deltas")) {
      holdout_every = static_cast<int>(bf.GetIntAttribute("/baselines/example_based_holdout/deltas", "holdout_every"));
    }
    const int K = static_cast<int>(data.alpha.rows());
    std::vector<int> unseen;
    for (int k = 0; k < K; ++k) {
      if (IsHeldOut(k, holdout_every)) unseen.push_back(k);
    }
    // Methods: the template, example-based rigging, ours, and the true personal shapes (the
    // floor that capture noise and unwanted motion leave; synthetic databases only).
    // (ours_estimation: the Estimation Stage's shapes alone, the ablation of paper 001 Fig. 6.)
    const int M = has_truth ? 5 : 4;
    const char* methods[5] = {"template", "example_based", "ours", "ours_estimation", "truth"};
    // [method][split] sums of per-scan errors (mm): all expressions (paper 001 Table 2) and the
    // held-out expressions; shape distances to the truth.
    double error[5][2] = {}, unseen_error[5][2] = {}, truth_distance[5][2] = {};
    int scans_count[2] = {0, 0}, unseen_count[2] = {0, 0}, people_count[2] = {0, 0};
    double inference_ms = 0;
    io::H5File shapes_file;
    std::vector<Eigen::MatrixXd> scan_errors(M, Eigen::MatrixXd(K, P));  // per method: [K, P] (mm)
    if (!o.shapes.empty()) {
      shapes_file = io::H5File::CreateAtomic(o.shapes);
      shapes_file.WriteProvenance(MakeProvenance(ctx, "eval blendshapes", resolved));
      for (const char* name : {"/shapes/ours/deltas", "/shapes/ours_estimation/deltas"}) {
        shapes_file.CreateFrames<float>(name, {N, V, 3}, P, 1);
      }
    }
    for (int j = 0; j < P; ++j) {
      const int s = data.split[j];
      Eigen::MatrixXf shapes[5], holdout;
      for (int t = 0; t < 2; ++t) {
        shapes[t].resize(3 * V, N);
        bf.ReadFrames<float>(t == 0 ? "/baselines/template/deltas" : "/baselines/example_based/deltas", j, 1, shapes[t].data());
      }
      const auto started = std::chrono::steady_clock::now();
      shapes[2] = m.Personalize(data.neutral[j]);
      inference_ms += 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      shapes[3] = m.Personalize(data.neutral[j], false);
      if (has_truth) shapes[4] = data.truth[j];
      Eigen::MatrixXf unseen_expressions(data.expressions[j].rows(), static_cast<int>(unseen.size()));
      for (size_t i = 0; i < unseen.size(); ++i) unseen_expressions.col(i) = data.expressions[j].col(unseen[i]);
      if (!unseen.empty()) {
        holdout.resize(3 * V, N);
        bf.ReadFrames<float>("/baselines/example_based_holdout/deltas", j, 1, holdout.data());
      }
      for (int t = 0; t < M; ++t) {
        const Eigen::VectorXd e = assets::ReconstructionErrors(data.neutral[j], shapes[t], data.expressions[j], moving);
        error[t][s] += 10.0 * e.sum();
        scan_errors[t].col(j) = 10.0 * e;
        if (!unseen.empty()) {
          const Eigen::MatrixXf& used = t == 1 ? holdout : shapes[t];
          unseen_error[t][s] += 10.0 * assets::ReconstructionErrors(data.neutral[j], used, unseen_expressions, moving).sum();
        }
        if (has_truth) truth_distance[t][s] += 10.0 * assets::MeanShapeDistance(shapes[t], data.truth[j], moving);
      }
      if (!o.shapes.empty()) {
        shapes_file.WriteFrames<float>("/shapes/ours/deltas", j, 1, shapes[2].data());
        shapes_file.WriteFrames<float>("/shapes/ours_estimation/deltas", j, 1, shapes[3].data());
      }
      scans_count[s] += static_cast<int>(data.expressions[j].cols());
      unseen_count[s] += static_cast<int>(unseen.size());
      people_count[s] += 1;
    }
    auto mean = [&](double sum, int n) { return n ? sum / n : 0.0; };
    char buffer[4096];
    std::string json = "{";
    for (int t = 0; t < M; ++t) {
      std::snprintf(buffer, sizeof(buffer), "%s\"%s_train\": %.4f, \"%s_test\": %.4f", t ? ", " : "", methods[t],
                    mean(error[t][0], scans_count[0]), methods[t], mean(error[t][1], scans_count[1]));
      json += buffer;
    }
    if (has_truth) {
      for (int t = 0; t < 4; ++t) {
        std::snprintf(buffer, sizeof(buffer), ", \"%s_vs_truth_train\": %.4f, \"%s_vs_truth_test\": %.4f", methods[t],
                      mean(truth_distance[t][0], people_count[0]), methods[t], mean(truth_distance[t][1], people_count[1]));
        json += buffer;
      }
    }
    if (!unseen.empty()) {
      json += ", \"unseen_expressions\": {";
      for (int t = 0; t < M; ++t) {
        std::snprintf(buffer, sizeof(buffer), "%s\"%s_train\": %.4f, \"%s_test\": %.4f", t ? ", " : "", methods[t],
                      mean(unseen_error[t][0], unseen_count[0]), methods[t], mean(unseen_error[t][1], unseen_count[1]));
        json += buffer;
      }
      std::snprintf(buffer, sizeof(buffer), ", \"holdout_every\": %d, \"expressions_per_person\": %d}",
                    holdout_every, static_cast<int>(unseen.size()));
      json += buffer;
    }
    std::snprintf(buffer, sizeof(buffer), ", \"inference_ms_per_person\": %.2f, \"units\": \"mm\", \"train_people\": %d, "
                  "\"test_people\": %d, \"train_scans\": %d, \"test_scans\": %d}",
                  mean(inference_ms, P), people_count[0], people_count[1], scans_count[0], scans_count[1]);
    json += buffer;
    const char* labels[5] = {"Template blendshapes (deformation transfer)", "Example-based rigging [Li et al. 2010]",
                             "Ours (generator + tuning)", "Ours, Estimation Stage alone (ablation)",
                             "True personal shapes (floor)"};
    std::string table = "| Method | Training (mm) | Testing (mm) | vs truth, testing (mm) |";
    if (!unseen.empty()) table += " Unseen expressions, testing (mm) |";
    table += "\n| --- | --- | --- | --- |";
    if (!unseen.empty()) table += " --- |";
    table += "\n";
    for (int t = 0; t < M; ++t) {
      std::snprintf(buffer, sizeof(buffer), "| %s | %.4f | %.4f | %.4f |", labels[t], mean(error[t][0], scans_count[0]),
                    mean(error[t][1], scans_count[1]), mean(truth_distance[t][1], people_count[1]));
      table += buffer;
      if (!unseen.empty()) {
        std::snprintf(buffer, sizeof(buffer), " %.4f |", mean(unseen_error[t][1], unseen_count[1]));
        table += buffer;
      }
      table += "\n";
    }
    FC_INFO("eval blendshapes: mean per-vertex reconstruction error over {} moving vertices, weights in [0, 1] by "
            "bounded least squares; {} training and {} held-out people{}\n{}", moving.size(), people_count[0],
            people_count[1],
            unseen.empty() ? std::string()
                           : "; unseen expressions: every " + std::to_string(holdout_every) +
                                 "th, which the example-based fit of that column did not see",
            table);
    if (!o.markdown.empty()) {
      std::ofstream md(o.markdown);
      md << table;
      if (!md) throw OutputError(o.markdown + ": cannot write the table");
    }
    if (!o.shapes.empty()) {
      for (int t = 0; t < M; ++t) {
        const Eigen::MatrixXf e = scan_errors[t].cast<float>();  // column-major [K, P]: row-major [P, K]
        shapes_file.Write<float>(std::string("/errors/") + methods[t], {P, K}, e.data());
      }
      shapes_file.Write<int32_t>("/errors/split", {P}, data.split.data());
      shapes_file.Commit();
      FC_INFO("eval blendshapes: shapes and per-scan errors -> {}", o.shapes);
    }
    if (o.json) std::cout << json << std::endl;
    summary.items = summary.computed = 1;
  });
  return summary;
}

}  // namespace facecap::stages
