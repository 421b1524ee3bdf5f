// facecap textures train / infer: the expression texture networks (paper 001 Sec. 5.2, Fig.
// 7) trained on a textured scan database with the training controller, and a person's dynamic
// texture library made from their predicted expression textures (eq. 12-13).
#include "stages/textures_net_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "io/config.h"
#include "io/dynamic_texture_file.h"
#include "io/rig_io.h"
#include "nn/blendshape_generator.h"
#include "nn/texture_net.h"
#include "rig/evaluate.h"
#include "stages/frame_loop.h"
#include "stages/resumable.h"
#include "stages/rig_texture.h"
#include "stages/stage.h"
#include "stages/texture_networks.h"
#include "textures/network_channels.h"
#include "util/errors.h"
#include "util/hash.h"
#include "util/log.h"
#include "util/parallel_for.h"

namespace facecap::stages {
namespace {

static_assert(textures::kPersonChannels == nn::TextureNets::kPersonChannels);
static_assert(textures::kExpressionChannels == nn::TextureNets::kExpressionChannels);
static_assert(textures::kOutputChannels == nn::TextureNets::kOutputChannels);

// The training people's channels, normalized, and the normalizations.
struct TextureTrainingData {
  rig::Rig topology;
  int size = 0;
  std::vector<float> coverage;                        // S x S
  std::vector<std::vector<float>> person;             // per training person, [9, S, S]
  std::vector<std::vector<float>> expression, output; // per example (person-major), [5 | 6, S, S]
  std::vector<int> example_person;                    // the person of each example
  textures::ChannelNormalization person_norm, expression_norm, output_norm;
  Eigen::MatrixXf facs_weights;
  std::vector<std::string> facs_names;
};

TextureTrainingData PrepareTextureTraining(const TexturesTrainOptions& o) {
  TextureTrainingData d;
  const io::H5File f = io::H5File::OpenRead(o.scans);
  if (!f.Exists("/scans/textures/neutral")) {
    throw FileIOError(o.scans + ": no skin maps (/scans/textures); make it with scans synth (texture_size > 0) or "
                      "scans import of meshes with maps beside them");
  }
  d.topology = io::ReadRig(f, "/template");
  const auto tshape = f.DatasetShape("/scans/textures/neutral");
  const int P = static_cast<int>(tshape[0]);
  d.size = static_cast<int>(tshape[1]);
  if (d.size % 4 != 0) throw FileIOError(o.scans + ": skin maps of " + std::to_string(d.size) + "^2 texels; the networks need a multiple of 4");
  const std::vector<int32_t> split = f.ReadVector<int32_t>("/scans/people/split", P);
  std::vector<int> train;
  for (int j = 0; j < P; ++j) if (split[j] == 0) train.push_back(j);
  if (train.empty()) throw FileIOError(o.scans + ": no training people (split 0)");
  const auto fshape = f.DatasetShape("/scans/facs/weights");
  const std::vector<float> w = f.Read<float>("/scans/facs/weights", fshape);
  d.facs_weights = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      w.data(), fshape[0], fshape[1]);
  d.facs_names = f.ReadStrings("/scans/facs/names");
  const textures::TexelInterpolator texels(d.topology, d.size);
  const textures::OneRing ring = textures::BuildOneRing(d.topology.triangles, d.topology.NumVertices());
  const int S = d.size;
  d.coverage.resize(static_cast<size_t>(S) * S);
  for (size_t t = 0; t < d.coverage.size(); ++t) d.coverage[t] = texels.Covered(static_cast<int>(t)) ? 1.f : 0.f;
  std::vector<ScanTexturedPerson> people;
  for (int j : train) people.push_back(ReadScanTexturedPerson(f, o.scans, j));
  const int K = static_cast<int>(people[0].expressions.size());
  d.person.resize(train.size());
  d.expression.resize(train.size() * K);
  d.output.resize(train.size() * K);
  ParallelFor(0, static_cast<int>(train.size()), ThreadsPerRank(o.threads), [&](int t) {
    const ScanTexturedPerson& p = people[t];
    d.person[t] = textures::PersonChannels(texels, p.neutral, d.topology.neutral, p.neutral_maps);
    const Eigen::VectorXf en = textures::MeanEdgeLength(ring, p.neutral);
    for (int k = 0; k < K; ++k) {
      d.expression[t * K + k] = textures::ExpressionChannels(texels, ring, en, p.neutral, p.expressions[k]);
      d.output[t * K + k] = textures::OutputChannels(p.neutral_maps, p.expression_maps[k], S, o.low_frequency_sigma);
    }
  });
  for (size_t t = 0; t < train.size(); ++t) for (int k = 0; k < K; ++k) d.example_person.push_back(static_cast<int>(t));
  auto pointers = [](const std::vector<std::vector<float>>& v) {
    std::vector<const float*> out;
    for (const auto& x : v) out.push_back(x.data());
    return out;
  };
  std::vector<bool> centered(textures::kPersonChannels, true);
  centered.back() = false;  // coverage
  d.person_norm = textures::ChannelNormalization::Fit(pointers(d.person), textures::kPersonChannels, d.coverage.data(), S, centered);
  d.expression_norm = textures::ChannelNormalization::Fit(pointers(d.expression), textures::kExpressionChannels,
                                                          d.coverage.data(), S, std::vector<bool>(textures::kExpressionChannels, false));
  d.output_norm = textures::ChannelNormalization::Fit(pointers(d.output), textures::kOutputChannels, d.coverage.data(),
                                                      S, std::vector<bool>(textures::kOutputChannels, false));
  for (auto& x : d.person) d.person_norm.Apply(x.data(), d.coverage.data(), S);
  ParallelFor(0, static_cast<int>(d.expression.size()), ThreadsPerRank(o.threads), [&](int e) {
    d.expression_norm.Apply(d.expression[e].data(), d.coverage.data(), S);
    d.output_norm.Apply(d.output[e].data(), d.coverage.data(), S);
  });
  return d;
}

// The texture networks as the training controller sees them: each epoch a permutation of the
// (person, expression) examples, the ranks taking every comm.size()-th of a step's batch.
class TextureTraining : public train::Network {
 public:
  TextureTraining(const TexturesTrainOptions& o, const dist::Comm& comm, const TextureTrainingData& data)
      : o_(o), comm_(comm), data_(data), model_(o.net, data.size),
        examples_(static_cast<int>(data.expression.size())),
        steps_per_epoch_((examples_ + o.batch - 1) / o.batch) {}
  int64_t total_steps() const { return static_cast<int64_t>(o_.epochs) * steps_per_epoch_; }
  int64_t NumParameters() const { return model_.NumParameters(); }
  int examples() const { return examples_; }

  int NumLosses() const override { return 2; }
  void Backward(int64_t step, double* losses) override {
    int size = 0;
    std::vector<nn::TextureExample> mine;
    for (int e : train::RankShareOfBatch(examples_, o_.batch, static_cast<uint64_t>(o_.seed),
                                         static_cast<uint64_t>(step / steps_per_epoch_),
                                         static_cast<int>(step % steps_per_epoch_), comm_.rank(), comm_.size(), &size)) {
      nn::TextureExample x;
      x.person = data_.person[data_.example_person[e]].data();
      x.expression = data_.expression[e].data();
      x.target = data_.output[e].data();
      x.mask = data_.coverage.data();
      mine.push_back(x);
    }
    model_.Backward(mine, 1.f / static_cast<float>(size), losses);
    losses[0] /= size;
    losses[1] /= size;
  }
  float* gradients() override { return model_.GradientBuffer(); }
  int64_t num_gradients() const override { return model_.NumParameters(); }
  void Apply(int64_t) override { model_.OptimizerStep(); }
  uint64_t ParameterHash() override {
    const std::vector<float> parameters = model_.Parameters();
    return Fnv1a(parameters.data(), parameters.size() * sizeof(float));
  }
  void WriteState(io::H5File* f, int64_t) override { f->WriteVector<float>("/optimizer/state", model_.State()); }
  void ReadState(const io::H5File& f) override {
    state_ = f.ReadVector<float>("/optimizer/state", 3 * model_.NumParameters() + 1);
  }
  void BroadcastState(const dist::Comm& comm, bool) override {
    comm.Broadcast(&state_);
    if (!state_.empty()) model_.SetState(state_);
    started_ = std::chrono::steady_clock::now();
  }
  void WriteModel(io::H5File* f, int64_t steps_done) override {
    WriteState(f, steps_done);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    io::WriteRig(data_.topology, f, "/template");
    const char* p = "/model/parameters";
    f->WriteVector<float>(p, model_.Parameters());
    f->SetAttribute(p, "size", static_cast<int64_t>(data_.size));
    f->SetAttribute(p, "channels", static_cast<int64_t>(o_.net.channels));
    f->SetAttribute(p, "residual_blocks", static_cast<int64_t>(o_.net.residual_blocks));
    f->SetAttribute(p, "low_frequency_sigma", static_cast<double>(o_.low_frequency_sigma));
    f->SetAttribute(p, "train_seconds", seconds);
    f->SetAttribute(p, "train_steps", steps_done);
    f->WriteVector<float>("/model/person_mean", data_.person_norm.mean);
    f->WriteVector<float>("/model/person_scale", data_.person_norm.scale);
    f->WriteVector<float>("/model/expression_scale", data_.expression_norm.scale);
    f->WriteVector<float>("/model/output_scale", data_.output_norm.scale);
    const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> w = data_.facs_weights;
    f->Write<float>("/model/facs_weights", {w.rows(), w.cols()}, w.data());
    f->WriteStrings("/model/facs_names", data_.facs_names);
  }
  std::string FormatLosses(int64_t, const double* means) const override {
    return fmt::format("L1 albedo {:.4f}  detail {:.4f} (normalized)", means[0], means[1]);
  }

 private:
  const TexturesTrainOptions& o_;
  const dist::Comm& comm_;
  const TextureTrainingData& data_;
  nn::TextureNets model_;
  const int examples_;
  const int steps_per_epoch_;
  std::vector<float> state_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

}  // namespace

StageSummary RunTexturesTrain(const TexturesTrainOptions& o, const StageContext& ctx,
                              const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  nn::SetTensorThreads(ThreadsPerRank(o.threads));
  TextureTrainingData data;
  dist::CoordinateExceptions(comm, [&] { data = PrepareTextureTraining(o); });
  TextureTraining network(o, comm, data);
  if (comm.IsMainRank()) {
    FC_INFO("textures train: {} training people, {} examples, {} parameters, {} steps, batch {} on {} ranks, maps {}x{}",
            data.person.size(), network.examples(), network.NumParameters(), network.total_steps(), o.batch,
            comm.size(), data.size, data.size);
  }
  train::ControllerOptions control = TrainingControl(ctx, resolved, "textures train", "textures.train", o.out,
                                                     TrainingIdentity(o));
  control.steps = network.total_steps();
  control.checkpoint_every = o.checkpoint_every;
  control.progress_seconds = o.progress_seconds;
  const train::TrainResult r = train::Train(control, comm, &network);
  if (comm.IsMainRank() && !r.up_to_date) {
    FC_INFO("textures train: {} steps in {:.1f} s ({:.3f} s per step) on {} ranks -> {}", r.steps_run, r.seconds,
            r.seconds / std::max<int64_t>(1, r.steps_run), comm.size(), o.out);
  }
  return StageSummary{o.out, "steps", control.steps, r.steps_run};
}

StageSummary RunTexturesInfer(const TexturesInferOptions& o, const StageContext& ctx,
                              const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const TextureModel model(o.model);
  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (rig.NumVertices() != model.template_rig().NumVertices() || rig.NumShapes() != model.template_rig().NumShapes()) {
    throw InvalidInputError(o.rig + ": " + std::to_string(rig.NumVertices()) + " vertices and " +
                            std::to_string(rig.NumShapes()) + " shapes; the model " + o.model + " was trained on " +
                            std::to_string(model.template_rig().NumVertices()) + " and " +
                            std::to_string(model.template_rig().NumShapes()));
  }
  const io::H5File f = io::H5File::OpenRead(o.scans);
  const int P = static_cast<int>(f.DatasetShape("/scans/people/neutral").at(0));
  const ScanTexturedPerson person = ReadScanTexturedPerson(f, o.scans, ScanPersonIndex(f, o.scans, o.person, P));
  const int S = model.size();
  if (person.neutral_maps.size() != static_cast<size_t>(S) * S * io::kSkinMapChannels) {
    throw InvalidInputError(o.scans + ": skin maps of another size than the model's " + std::to_string(S) + "^2");
  }
  ResumableOutput output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "textures infer", resolved));
  summary.items = 1;
  if (output.up_to_date) {
    FC_INFO("textures infer: {} is up to date", o.out);
    return summary;
  }
  // The expressions: the rig at each FACS row of the model's table.
  const int K = static_cast<int>(model.facs_weights().rows());
  std::vector<rig::Vertices> expressions(K);
  std::vector<std::vector<float>> maps(K);
  rig::RigidPose identity;
  identity.translation.setZero();
  for (int k = 0; k < K; ++k) {
    const Eigen::VectorXf w = model.facs_weights().row(k).transpose();
    rig::EvaluatePosed(rig, identity, w, &expressions[k]);
  }
  ParallelFor(0, K, ThreadsPerRank(0), [&](int k) {
    maps[k] = model.ExpressionMaps(rig.neutral, person.neutral_maps, expressions[k]);
  });
  const io::DynamicTextureLibrary lib =
      MakeDynamicTextureLibrary(rig, rig.neutral, expressions, person.neutral_maps, maps, S, o.sharpness);
  io::WriteRig(rig, &output.file);
  io::WriteDynamicTextureLibrary(&output.file, lib);
  std::vector<float> all;
  for (const auto& m : maps) all.insert(all.end(), m.begin(), m.end());
  output.file.Write<float>("/predicted", {K, S, S, io::kSkinMapChannels}, all.data());
  output.file.SetAttribute("/predicted", "channels", std::string(io::kSkinMapChannelNames));
  output.file.WriteStrings("/predicted_names", model.facs_names());
  output.file.Commit();
  FC_INFO("textures infer: {} predicted expression textures {}x{}, library -> {}", K, S, S, o.out);
  summary.computed = 1;
  return summary;
}

}  // namespace facecap::stages
