// facecap deepfake train / infer (paper 000 Sec. 4 and 4.1).
//
// train: data-parallel training with gradient allreduce. Rank 0's initial weights are
// broadcast; each rank reads its own block of A and B; every step each rank draws its share of
// the global batch from Rng(seed, step * 65536 + rank), computes its gradients (weighted by its
// share), the gradient buffers are summed over ranks (dist::Comm::SumReduce), and every rank
// takes the same Adam step, so the weights stay bitwise identical (checked by hash at every
// checkpoint). A checkpoint (weights, Adam moments, step; the sampling is counter-based, so
// (seed, step) is its whole random state) is written atomically to OUT.checkpoint every
// checkpoint_every steps and on SIGTERM/SIGUSR1 (then exit 75); rerunning the command
// continues from it, and a finished OUT trained for fewer steps is continued when --steps grows.
//
// infer: D_S(E(I)) and the codes E(I), E(D_S(E(I))) for every frame, spread across ranks and
// resumable (frame_loop.h), then the region borders of each translation (contour/) as
// polylines and an overlay PNG on the real frames.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>

#include "stages/deepfake_stage.h"

#include "contour/contours.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "nn/augment.h"
#include "nn/deepfake_batches.h"
#include "nn/deepfake.h"
#include "nn/deepfake_io.h"
#include "io/camera_file.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/holdout.h"
#include "stages/resumable.h"
#include "train/controller.h"
#include "synth/appearance.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/progress.h"
#include "util/random.h"
#include "util/signals.h"

namespace facecap::stages {
namespace {

// Image datasets a frames file may hold, in the order they are looked for when no dataset is
// named: wild clips (synth clip), ingested video (ingest), synthetic samples (synth samples).
const char* const kImageDatasets[] = {io::frames::kImage, io::frames::kCrop, "/samples/segmentation"};

constexpr int kPreviewRows = 4;  // image pairs in the preview grid

std::string FindImageDataset(const io::H5File& f, const std::string& requested) {
  if (!requested.empty()) {
    if (!f.Exists(requested)) throw FileIOError(f.path() + ": no dataset " + requested);
    return requested;
  }
  for (const char* name : kImageDatasets) {
    if (f.Exists(name)) return name;
  }
  throw FileIOError(f.path() + ": none of the image datasets /frames/image, /frames/crop, "
                    "/samples/segmentation; name one with the dataset option");
}

// The width in pixels of the images a file's camera belongs to: its recorded width, else
// the width of the file's first image dataset.
double CameraImageWidth(const io::H5File& f, const io::CameraRecord& camera) {
  if (camera.width) return *camera.width;
  for (const char* name : kImageDatasets) {
    if (f.Exists(name)) return static_cast<double>(f.DatasetShape(name)[2]);
  }
  throw FileIOError(f.path() + ": " + io::kCameraPath + " has no width attribute and the file no images");
}

// The camera of `source`, when it has one, scaled to the translations, so that the
// translations can be tracked as segmentation targets in that image frame.
void CopyScaledCamera(const io::H5File& source, int size, io::H5File* out) {
  if (!io::HasCamera(source)) return;
  const io::CameraRecord from = io::ReadCamera(source);
  const double scale = size / CameraImageWidth(source, from);
  io::CameraRecord to;
  to.fx = from.fx * scale;
  to.fy = from.fy * scale;
  to.cx = from.cx * scale;
  to.cy = from.cy * scale;
  to.width = to.height = static_cast<double>(size);
  to.distance_cm = from.distance_cm;
  io::WriteCamera(out, to);
}

// Frames usable for training: all, except ingest frames where no face was found and, with
// holdout_every = n > 0, every n-th frame (i % n == n - 1), kept out for evaluation.
std::vector<int64_t> UsableFrames(const io::H5File& f, const std::string& dataset, int64_t n,
                                  int holdout_every = 0) {
  std::vector<int64_t> usable;
  std::vector<uint8_t> found;
  // Frames where ingest found no face (ingest outputs and synth crops) are not used.
  if (dataset.rfind("/frames/", 0) == 0 && f.Exists(io::frames::kFound)) {
    found = f.ReadVector<uint8_t>(io::frames::kFound, n);
  }
  for (int64_t i = 0; i < n; ++i) {
    if (IsHeldOut(i, holdout_every)) continue;
    if (found.empty() || found[i]) usable.push_back(i);
  }
  return usable;
}

// One rank's block of an image dataset, in memory.
struct ImageShard : nn::ImageStack {
  int64_t total = 0;  // usable frames in the whole dataset
};

ImageShard ReadShard(const std::string& path, const std::string& requested, const dist::Comm& comm,
                     int holdout_every = 0) {
  io::H5File f = io::H5File::OpenRead(path);
  const std::string dataset = FindImageDataset(f, requested);
  const io::Shape shape = f.CheckShape(dataset, {-1, -1, -1, 3});
  if (shape[1] != shape[2]) {
    throw FileIOError(path + ": " + dataset + " has shape " + io::ShapeToString(shape) +
                      "; square images are expected");
  }
  const std::vector<int64_t> usable = UsableFrames(f, dataset, shape[0], holdout_every);
  ImageShard shard;
  shard.size = static_cast<int>(shape[1]);
  shard.total = static_cast<int64_t>(usable.size());
  if (shard.total < comm.size()) {
    throw FileIOError(path + ": " + dataset + " has " + std::to_string(shard.total) +
                      " usable images, fewer than the " + std::to_string(comm.size()) + " ranks");
  }
  const dist::Range range = dist::BlockRange(shard.total, comm.rank(), comm.size());
  const int64_t one = 3LL * shard.size * shard.size;
  shard.pixels.resize((range.end - range.begin) * one);
  // Contiguous runs of usable frames are read at once.
  int64_t k = range.begin;
  while (k < range.end) {
    int64_t end = k + 1;
    while (end < range.end && usable[end] == usable[end - 1] + 1) ++end;
    f.ReadFrames<uint8_t>(dataset, usable[k], end - k, shard.pixels.data() + (k - range.begin) * one);
    k = end;
  }
  return shard;
}

// Appends `more` to `all` (images of the same size; `file` names the offender otherwise).
void Append(const ImageShard& more, const std::string& file, ImageShard* all) {
  if (all->size != 0 && more.size != all->size) {
    throw FileIOError(file + ": " + std::to_string(more.size) +
                      "-pixel images, where the files before hold " + std::to_string(all->size) +
                      "-pixel ones");
  }
  all->size = more.size;
  all->total += more.total;
  all->pixels.insert(all->pixels.end(), more.pixels.begin(), more.pixels.end());
}

// Images resampled to the network's size, as uint8.
std::vector<uint8_t> ResizedImages(const ImageShard& shard, int64_t first, int count, int size) {
  const int64_t one = 3LL * size * size;
  std::vector<uint8_t> out(count * one);
  if (shard.size == size) {
    std::copy(shard.image(first), shard.image(first) + count * one, out.begin());
    return out;
  }
  std::vector<float> f(one);
  for (int i = 0; i < count; ++i) {
    nn::ResizeToFloat(shard.image(first + i), shard.size, size, f.data());
    for (int64_t k = 0; k < one; ++k) out[i * one + k] = static_cast<uint8_t>(std::lround(f[k] * 255.f));
  }
  return out;
}

// The options with those that may change between a run and its continuation (steps,
// checkpoint and preview cadence, threads, device, paths of side outputs) at their defaults.
DeepfakeTrainOptions IdentityOptions(const DeepfakeTrainOptions& o) {
  DeepfakeTrainOptions id = TrainingIdentity(o);
  const DeepfakeTrainOptions defaults;
  id.steps = defaults.steps;
  id.preview_every = defaults.preview_every;
  id.device = defaults.device;
  return id;
}

struct Regions {
  std::vector<std::string> names;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> colors;
};

Regions ReadRegions(const io::H5File& f) {
  Regions r;
  if (f.Exists("/regions/names") && f.Exists("/regions/colors")) {
    r.names = f.ReadStrings("/regions/names");
    r.colors = f.ReadMatrix<float>("/regions/colors", static_cast<int64_t>(r.names.size()), 3);
  }
  return r;
}

// The regions as the contour module's palette (label names.size(): the black background).
contour::Palette PaletteOf(const Regions& regions) {
  contour::Palette palette;
  palette.names = regions.names;
  for (int r = 0; r < regions.colors.rows(); ++r) {
    palette.colors.push_back({regions.colors(r, 0), regions.colors(r, 1), regions.colors(r, 2)});
  }
  return palette;
}

// The black background and the regions' colours, RGB in [0, 1]: the palette of D_A's palette
// head and of the palette terms.
std::vector<float> PaletteColors(const Regions& regions) {
  std::vector<float> colors = {0.f, 0.f, 0.f};
  for (int r = 0; r < regions.colors.rows(); ++r) {
    for (int c = 0; c < 3; ++c) colors.push_back(regions.colors(r, c));
  }
  return colors;
}

// Sets the palette of a model with a palette head from the regions of `path`.
void SetModelPalette(nn::DeepfakeModel* model, const Regions& regions, const std::string& path) {
  const int k = model->options().palette_colors;
  if (k == 0) return;
  if (regions.names.empty() || static_cast<int>(regions.names.size()) + 1 != k) {
    throw FileIOError(path + ": the palette head has " + std::to_string(k) + " colours, but " +
                      (regions.names.empty() ? std::string("the file has no /regions")
                                             : "/regions has " + std::to_string(regions.names.size()) +
                                                   " regions (with the background " +
                                                   std::to_string(regions.names.size() + 1) + ")"));
  }
  model->SetPalette(PaletteColors(regions));
}

// The palette index of each palette colour's mirror image (PaletteColors' order: the
// background, then the regions): left_X and right_X trade places, the others keep theirs.
std::vector<int> PaletteMirror(const Regions& regions) {
  std::vector<int> mirror = {0};
  for (int r : nn::MirrorRegions(regions.names)) mirror.push_back(r + 1);
  return mirror;
}

// The palette term's colours (the black background first, so that a region as black as the
// background, the pupil, never takes its pixels; then the regions) and region weights:
// (f_k)^-1/2 for a class covering the fraction f_k of the A targets' pixels (classified as
// contour::ClassifyPixels does; counted over every rank's shard, so the same for any number of
// ranks), scaled so that the mean pixel weight is 1, at most 20.
struct PaletteWeights {
  std::vector<float> colors, weights;
  std::string summary;
};

PaletteWeights RegionWeights(const Regions& regions, const std::vector<const ImageShard*>& shards,
                             const dist::Comm& comm) {
  PaletteWeights out;
  const contour::Palette palette = PaletteOf(regions);
  const int K = palette.num_labels();
  // Class k of the term: 0 the background, 1 + r region r.
  auto term_class = [&](int label) { return label == palette.background() ? 0 : label + 1; };
  out.colors = PaletteColors(regions);
  std::vector<double> counts(K, 0.0);
  for (const ImageShard* shard : shards) {
    Image8 image(shard->size, shard->size, 3);
    for (int64_t i = 0; i < shard->count(); ++i) {
      std::copy(shard->image(i), shard->image(i) + image.data.size(), image.data.begin());
      for (int16_t label : contour::ClassifyPixels(image, palette)) counts[term_class(label)] += 1;
    }
  }
  comm.SumReduce(counts.data(), K);
  const double total = std::max(1.0, std::accumulate(counts.begin(), counts.end(), 0.0));
  double mean = 0;  // mean pixel weight before scaling: sum_k f_k f_k^-1/2
  for (int k = 0; k < K; ++k) mean += std::sqrt(counts[k] / total);
  out.weights.assign(K, 0.f);
  for (int k = 0; k < K; ++k) {
    if (counts[k] <= 0) continue;
    out.weights[k] = static_cast<float>(std::min(20.0, std::pow(counts[k] / total, -0.5) / mean));
    char item[96];
    std::snprintf(item, sizeof(item), "%s%s %.2f", out.summary.empty() ? "" : ", ",
                  k == 0 ? "background" : regions.names[k - 1].c_str(), out.weights[k]);
    out.summary += item;
  }
  return out;
}

void WriteRegions(io::H5File* f, const Regions& r) {
  if (r.names.empty()) return;
  f->WriteStrings("/regions/names", r.names);
  f->WriteMatrix("/regions/colors", r.colors);
}

// A warm start: the weights of the model file `path` (its moving average, when it has one),
// whose network and regions must be the model's.
void StartFrom(const std::string& path, const Regions& regions, nn::DeepfakeModel* model) {
  const io::H5File f = io::H5File::OpenRead(path);
  if (ReadRegions(f).names != regions.names) {
    throw FileIOError(path + ": init model's /regions differ from domain A's; a warm start needs "
                      "a model trained on renders of the same regions");
  }
  nn::ReadWeights(f, model);
  if (nn::ReadAveragedWeights(f, *model, model->parameters())) model->ParametersWritten();
}

// What training reads: this rank's blocks of A, B and the paired clips, A's regions, the model.
struct TrainingData {
  ImageShard a, b, paired_image, paired_target;
  Regions regions;
  std::unique_ptr<nn::DeepfakeModel> model;
};

TrainingData ReadTrainingData(const DeepfakeTrainOptions& o, const dist::Comm& comm) {
  TrainingData d;
  d.a = ReadShard(o.a, o.a_dataset, comm);
  d.b = ReadShard(o.b, o.b_dataset, comm, o.b_holdout_every);
  // Each rank holds its block of every paired clip, so that every person is seen by every rank.
  for (const std::string& path : o.paired) {
    const ImageShard image = ReadShard(path, io::frames::kImage, comm);
    const ImageShard target = ReadShard(path, io::frames::kSegmentation, comm);
    if (image.size != target.size || image.total != target.total) {
      throw FileIOError(path + ": /frames/image and /frames/segmentation differ in size or count");
    }
    Append(image, path, &d.paired_image);
    Append(target, path, &d.paired_target);
  }
  d.regions = ReadRegions(io::H5File::OpenRead(o.a));
  nn::DeepfakeNetworkOptions network = o.network;
  if (o.palette_head) {
    if (d.regions.names.empty()) {
      throw FileIOError(o.a + ": palette_head needs the region names and colours (/regions) "
                        "of the segmentation renders");
    }
    network.palette_colors = static_cast<int>(d.regions.names.size()) + 1;
  }
  d.model = std::make_unique<nn::DeepfakeModel>(network, static_cast<uint64_t>(o.seed), o.device);
  SetModelPalette(d.model.get(), d.regions, o.a);
  if (!o.init.empty()) StartFrom(o.init, d.regions, d.model.get());
  return d;
}

// The deepfake as the training controller sees it: each step's batch drawn from this rank's
// shards by Rng(seed, step * 65536 + rank), DeepfakeTrainer's losses and Adam with the
// learning-rate schedule, and on rank 0 the moving average of the weights.
class DeepfakeTraining : public train::Network {
 public:
  DeepfakeTraining(const DeepfakeTrainOptions& o, const dist::Comm& comm, TrainingData* data)
      : o_(o), comm_(comm), d_(*data), model_(*data->model), trainer_(&model_, o.loss),
        size_(o.network.size), image_floats_(3LL * size_ * size_) {
    const dist::Range share = dist::BlockRange(o.batch, comm.rank(), comm.size());
    batch_.count = static_cast<int>(share.end - share.begin);
    batch_.size = size_;
    share_ = static_cast<double>(batch_.count) / o.batch;
    for (auto* v : {&batch_.input_a, &batch_.target_a, &batch_.input_b, &batch_.target_b}) {
      v->resize(batch_.count * image_floats_);
    }
    preview_rows_ = static_cast<int>(
        std::min<int64_t>(kPreviewRows, std::min(d_.a.count(), d_.b.count())));
    preview_a_ = ResizedImages(d_.a, 0, preview_rows_, size_);
    preview_b_ = ResizedImages(d_.b, 0, preview_rows_, size_);
    SetUpRegionWeights();
    composer_ = std::make_unique<nn::DeepfakeBatchComposer>(
        nn::BatchSources{&d_.a, &d_.b, &d_.paired_image, &d_.paired_target}, Composition(),
        BackgroundBank());
  }

  int NumLosses() const override { return nn::DeepfakeLosses::kCount; }
  void Backward(int64_t step, double* losses) override {
    Rng rng(static_cast<uint64_t>(o_.seed), static_cast<uint64_t>(step) * 65536u + comm_.rank());
    for (int i = 0; i < batch_.count; ++i) composer_->AddExample(i, &rng, &batch_);
    trainer_.Backward(batch_, share_).ToArray(losses);
  }
  float* gradients() override { return trainer_.gradients(); }
  int64_t num_gradients() const override { return trainer_.num_gradients(); }
  void Apply(int64_t step) override {
    trainer_.OptimizerStep();
    if (!averaged_.empty()) {
      model_.ParametersToHost();
      nn::UpdateMovingAverage(model_.parameters(), model_.num_parameters(), step + 1,
                              o_.average_decay, averaged_.data());
    }
  }
  uint64_t ParameterHash() override { return model_.ParameterHash(); }

  void WriteState(io::H5File* f, int64_t steps_done) override {
    nn::WriteWeights(f, &model_);
    nn::WriteTrainingState(f, &trainer_, {steps_done, static_cast<uint64_t>(o_.seed)});
    if (!averaged_.empty()) {
      nn::WriteAveragedWeights(f, model_, averaged_.data(), o_.average_decay);
    }
    f->SetAttribute("/weights", "hash", train::HexHash(model_.ParameterHash()));
    WriteRegions(f, d_.regions);
    // The palette terms' class weights (palette order: the background, then the regions), a
    // record of how the training weighed the regions.
    if (!region_weights_.empty()) f->WriteVector<float>("/training/region_weights", region_weights_);
  }
  void ReadState(const io::H5File& f) override {
    nn::ReadWeights(f, &model_);
    nn::ReadTrainingState(f, &trainer_);
    if (o_.average_decay > 0) {
      averaged_.resize(model_.num_parameters());
      if (!nn::ReadAveragedWeights(f, model_, averaged_.data())) {
        throw FileIOError(f.path() + ": no /averaged_weights to continue the moving average");
      }
    }
  }
  void BroadcastState(const dist::Comm& comm, bool resumed) override {
    const int64_t bytes = model_.num_parameters() * static_cast<int64_t>(sizeof(float));
    comm.Broadcast(model_.parameters(), bytes);
    model_.ParametersWritten();
    if (resumed) {
      const int64_t moments = trainer_.num_gradients() * static_cast<int64_t>(sizeof(float));
      comm.Broadcast(trainer_.first_moments(), moments);
      comm.Broadcast(trainer_.second_moments(), moments);
      trainer_.OptimizerStateWritten();
      int64_t step = trainer_.step();
      comm.Broadcast(&step, sizeof(step));
      trainer_.set_step(step);
    }
    // Rank 0 keeps the moving average, every rank's weights being alike.
    if (comm.IsMainRank() && o_.average_decay > 0 && averaged_.empty()) {
      model_.ParametersToHost();
      averaged_.assign(model_.parameters(), model_.parameters() + model_.num_parameters());
    }
  }

  std::string FormatLosses(int64_t, const double* w) const override {
    std::string palette_term;
    if (o_.loss.palette_weight > 0) palette_term += fmt::format("  palette_a {:.3f}", w[6]);
    if (o_.loss.region_l1_weight > 0) palette_term += fmt::format("  region_l1_a {:.4f}", w[7]);
    if (o_.loss.dice_weight > 0) palette_term += fmt::format("  dice_a {:.3f}", w[8]);
    return fmt::format("recon_a {:.4f}  recon_b {:.4f}{}  image_adv {:.3f}  latent_adv {:.3f}  "
                       "f_image {:.3f}  f_latent {:.3f}",
                       w[0], w[1], palette_term, w[2], w[3], w[4], w[5]);
  }
  void AfterStep(int64_t done) override {
    if (o_.preview_every > 0 && done % o_.preview_every == 0) WritePreview();
  }
  // The preview grid of paper 000 Fig. 6 (rank 0).
  void WritePreview() {
    if (!comm_.IsMainRank()) return;
    io::WriteImage(WithSuffix(o_.out, "_preview.png"), trainer_.PreviewGrid(preview_a_.data(), preview_b_.data(), preview_rows_));
  }

 private:
  // The palette terms' class weights.
  void SetUpRegionWeights() {
    if (o_.loss.palette_weight > 0 || o_.loss.region_l1_weight > 0 || o_.loss.dice_weight > 0) {
      const PaletteWeights pw = RegionWeights(d_.regions, {&d_.a, &d_.paired_target}, comm_);
      trainer_.SetPalette(pw.colors, pw.weights);
      region_weights_ = pw.weights;
      if (comm_.IsMainRank()) FC_INFO("deepfake train: region weights of the palette terms {}", pw.summary);
    }
  }

  // Random backgrounds for the paired frames (augment.random_background): a bank of procedural
  // backgrounds through the camera's degradations, the same on every rank.
  std::vector<Image8> BackgroundBank() const {
    std::vector<Image8> bank;
    if (!(o_.augment.random_background > 0 && d_.paired_target.count() > 0)) return bank;
    const int s = d_.paired_image.size;
    Rng bank_rng(static_cast<uint64_t>(o_.seed), 0x4241434bu);
    for (int k = 0; k < 64; ++k) {
      const uint64_t seed = bank_rng.NextU64();
      Image8 image(s, s, 3);
      synth::DegradeFrame(synth::MakeBackground(s, s, seed), Eigen::Vector3f::Ones(), seed, 0,
                          synth::CameraDegradationOptions{}, &image);
      bank.push_back(std::move(image));
    }
    return bank;
  }

  // What each example is drawn from.
  nn::BatchComposition Composition() const {
    nn::BatchComposition c;
    c.size = size_;
    c.paired = !o_.paired.empty();
    c.paired_fraction = o_.paired_fraction;
    c.augment = o_.augment;
    return c;
  }

  const DeepfakeTrainOptions& o_;
  const dist::Comm& comm_;
  const TrainingData& d_;
  nn::DeepfakeModel& model_;
  nn::DeepfakeTrainer trainer_;
  const int size_;
  const int64_t image_floats_;
  nn::TrainingBatch batch_;
  double share_ = 1;
  int preview_rows_ = 0;
  std::vector<uint8_t> preview_a_, preview_b_;
  std::vector<float> averaged_;         // rank 0: the moving average of the weights
  std::vector<float> region_weights_;   // the palette terms' class weights
  std::unique_ptr<nn::DeepfakeBatchComposer> composer_;
};

// --------------------------------------------------------------------------------------------

// The model as infer uses it: the moving average of the weights, D_A's label averaging and
// upsampling as the options and the model file allow.
struct Translator {
  std::unique_ptr<nn::DeepfakeModel> model;
  Regions regions;
  bool averaged = false;  // translating with the model file's moving average of the weights
};

Translator LoadTranslator(const DeepfakeInferOptions& o, const dist::Comm& comm) {
  Translator t;
  io::H5File model_file = io::H5File::OpenRead(o.model);
  t.model = std::make_unique<nn::DeepfakeModel>(nn::ReadNetworkOptions(model_file), 0, o.device);
  nn::DeepfakeModel* model = t.model.get();
  nn::ReadWeights(model_file, model);
  if (o.averaged && nn::ReadAveragedWeights(model_file, *model, model->parameters())) {
    model->ParametersWritten();
    t.averaged = true;
  }
  t.regions = ReadRegions(model_file);
  SetModelPalette(model, t.regions, o.model);
  if (model->options().palette_colors <= 0 || o.decoder != "A") return t;
  if (o.flip_average) model->SetFlipAverage(PaletteMirror(t.regions));
  model->SetShiftAverage(o.shift_average);
  model->SetLabelScale(o.label_scale);
  return t;
}

// One deepfake infer run: the model and the frames opened on every rank, the output on rank 0,
// the translations spread across ranks, then the region borders and the overlay (rank 0).
class DeepfakeInference {
 public:
  DeepfakeInference(const DeepfakeInferOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), ctx_(ctx), resolved_(resolved), comm_(ctx.comm) {
    dist::CoordinateExceptions(comm_, [&] {
      t_ = LoadTranslator(o, comm_);
      frames_file_ = io::H5File::OpenRead(o.frames);
      dataset_ = FindImageDataset(frames_file_, o.dataset);
      const io::Shape shape = frames_file_.CheckShape(dataset_, {-1, -1, -1, 3});
      if (shape[1] != shape[2]) {
        throw FileIOError(o.frames + ": " + dataset_ + " has shape " + io::ShapeToString(shape) +
                          "; square images are expected");
      }
      num_frames_ = shape[0];
      frame_size_ = static_cast<int>(shape[1]);
    });
    size_ = t_.model->options().size;
    out_size_ = t_.model->TranslationSize(Decoder());
    latent_ = t_.model->options().LatentSize();
  }

  StageSummary Run() {
    out_ = OpenFrameOutput(ctx_, resolved_, "deepfake infer", o_.out, num_frames_,
                           [&](io::H5File* f, bool resumed) { PrepareOutput(f, resumed); });
    StageSummary summary{o_.out, "frames", num_frames_, 0};
    if (out_.up_to_date) return summary;
    FrameLoopOptions loop;
    loop.what = "deepfake infer";
    loop.batch = o_.batch;
    loop.threads = 1;  // torch parallelizes inside each frame
    summary.computed = RunFrameLoop(
        comm_, out_.pending, num_frames_, loop, [&](int64_t frame, int) { return Translate(frame); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          Commit(frames, results);
        });
    // Region borders of every translation (cheap next to the network: rank 0 does them all, so
    // the table is written once, in frame order, whatever the rank count or resumes).
    dist::CoordinateExceptions(comm_, [&] {
      if (!comm_.IsMainRank()) return;
      if (o_.contours && t_.regions.names.empty()) {
        FC_WARN("deepfake infer: {} holds no /regions; no contours", o_.model);
      } else if (o_.contours) {
        WriteContours();
      }
      out_.output.file.Commit();
      const bool labels = t_.model->options().palette_colors > 0 && o_.decoder == "A";
      FC_INFO("deepfake infer: {} frames -> {}{}{}{}{}", num_frames_, o_.out,
              t_.averaged ? " (averaged weights)" : "", labels && o_.flip_average ? " (flip-averaged labels)" : "",
              labels && o_.shift_average > 0 ? " (shift-averaged labels)" : "",
              labels && o_.label_scale > 1 ? fmt::format(" ({} x {} labels)", out_size_, out_size_) : std::string());
    });
    return summary;
  }

 private:
  // The output's datasets (rank 0); `resumed`: a continued file.
  void PrepareOutput(io::H5File* f, bool resumed) {
    f->CreateFrames<uint8_t>(io::frames::kTranslated, {out_size_, out_size_, 3}, num_frames_, 16);
    f->SetAttribute(io::frames::kTranslated, "meaning",
                    std::string(o_.decoder == "A" ? "D_A(E(I)): the frame in the synthetic (segmentation) style"
                                                  : "D_B(E(I))"));
    f->SetAttribute(io::frames::kTranslated, "layout", std::string("frame, y, x, RGB"));
    f->CreateFrames<float>(io::frames::kLatent, {latent_}, num_frames_, 16);
    f->SetAttribute(io::frames::kLatent, "meaning", std::string("E(I), flattened [channels, y, x]"));
    f->CreateFrames<float>(io::frames::kLatentOfTranslation, {latent_}, num_frames_, 16);
    f->SetAttribute(io::frames::kLatentOfTranslation, "meaning",
                    std::string("E(D(E(I))) of the stored 8-bit translation (paper 000 Sec. 9)"));
    if (!resumed) WriteFrameRecords(f);
  }

  // What travels with the translations: the regions, ingest's face flags (the tracker skips
  // the frames without a face) and the camera scaled to the translations.
  void WriteFrameRecords(io::H5File* f) {
    WriteRegions(f, t_.regions);
    if (dataset_ == io::frames::kCrop && frames_file_.Exists(io::frames::kFound)) {
      f->WriteVector<uint8_t>(io::frames::kFound, frames_file_.ReadVector<uint8_t>(io::frames::kFound, num_frames_));
      f->SetAttribute(io::frames::kFound, "meaning", std::string("1: ingest found the face, 0: no face"));
    }
    if (o_.camera.empty()) {
      CopyScaledCamera(frames_file_, out_size_, f);
    } else {
      CopyScaledCamera(io::H5File::OpenRead(o_.camera), out_size_, f);
      if (!io::HasCamera(*f)) throw FileIOError(o_.camera + ": no " + io::kCameraPath);
    }
  }

  nn::DeepfakeModel::Decoder Decoder() const {
    return o_.decoder == "A" ? nn::DeepfakeModel::Decoder::kA : nn::DeepfakeModel::Decoder::kB;
  }

  // Frame `frame` of the input at `size` pixels (the network's by default).
  std::vector<uint8_t> InputImage(int64_t frame, int size = 0) {
    ImageShard image;
    image.size = frame_size_;
    image.pixels.resize(3LL * frame_size_ * frame_size_);
    frames_file_.ReadFrames<uint8_t>(dataset_, frame, 1, image.pixels.data());
    return ResizedImages(image, 0, 1, size > 0 ? size : size_);
  }

  std::vector<uint8_t> Translate(int64_t frame) {
    const std::vector<uint8_t> input = InputImage(frame);
    std::vector<uint8_t> translated(3LL * out_size_ * out_size_);
    std::vector<float> code(latent_), code_of_translation(latent_);
    t_.model->Translate(input.data(), 1, Decoder(), translated.data(), code.data(), code_of_translation.data());
    ByteWriter w;
    w.PutVector(translated);
    w.PutVector(code);
    w.PutVector(code_of_translation);
    return std::move(w.bytes());
  }

  void Commit(const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = out_.output.file;
    for (size_t k = 0; k < frames.size(); ++k) {
      ByteReader r(results[k]);
      const auto translated = r.GetVector<uint8_t>();
      const auto code = r.GetVector<float>();
      const auto code2 = r.GetVector<float>();
      f.WriteFrames<uint8_t>(io::frames::kTranslated, frames[k], 1, translated.data());
      f.WriteFrames<float>(io::frames::kLatent, frames[k], 1, code.data());
      f.WriteFrames<float>(io::frames::kLatentOfTranslation, frames[k], 1, code2.data());
    }
    io::DoneMask mask(&f, num_frames_);
    mask.MarkDone(frames);
  }

  // Rank 0: /contours (every translation's region borders as polylines) and the overlay PNG.
  void WriteContours() {
    io::H5File& f = out_.output.file;
    const contour::Palette palette = PaletteOf(t_.regions);
    contour::BorderOptions border_options;
    border_options.min_points = o_.contour_min_points;
    std::vector<int32_t> table;  // frame, region, neighbor, closed, first point, point count
    std::vector<float> points;
    const int overlay_frames = static_cast<int>(std::min<int64_t>(o_.overlay_count, num_frames_));
    const int cell = out_size_ * o_.overlay_scale;
    Image8 overlay(3 * cell, std::max(1, overlay_frames) * cell, 3);
    for (int64_t frame = 0; frame < num_frames_; ++frame) {
      Image8 translated(out_size_, out_size_, 3);
      f.ReadFrames<uint8_t>(io::frames::kTranslated, frame, 1, translated.data.data());
      const auto labels = contour::ClassifyPixels(translated, palette);
      const auto borders = contour::ExtractBorders(labels, out_size_, out_size_, palette.num_labels(), border_options);
      for (const auto& b : borders) {
        table.insert(table.end(), {static_cast<int32_t>(frame), b.region, b.neighbor, b.closed ? 1 : 0,
                                   static_cast<int32_t>(points.size() / 2),
                                   static_cast<int32_t>(b.points.size())});
        for (const auto& p : b.points) points.insert(points.end(), {p[0], p[1]});
      }
      if (frame < overlay_frames) AddOverlayRow(frame, translated, borders, palette, cell, &overlay);
    }
    const int64_t rows = static_cast<int64_t>(table.size() / 6);
    if (f.Exists("/contours")) f.Remove("/contours");
    f.Write<int32_t>("/contours/borders", {rows, 6}, table.data());
    f.SetAttribute("/contours/borders", "columns",
                   std::string("frame, region, neighbor, closed, first_point, point_count"));
    f.SetAttribute("/contours/borders", "labels",
                   std::string("indices into /regions/names; the background is len(names)"));
    f.Write<float>("/contours/points", {static_cast<int64_t>(points.size() / 2), 2}, points.data());
    f.SetAttribute("/contours/points", "units",
                   std::string("pixels of /frames/translated (x right, y down), pixel centres at +0.5"));
    if (o_.overlay != "none") {
      io::WriteImage(o_.overlay.empty() ? WithSuffix(o_.out, "_contours.png") : o_.overlay, overlay);
    }
    FC_INFO("deepfake infer: {} borders ({} points) over {} frames", rows, points.size() / 2, num_frames_);
  }

  // Row `frame` of the overlay: I_R, D_S(E(I_R)), and the borders of D_S(E(I_R)) on I_R
  // (paper 000 Fig. 7).
  void AddOverlayRow(int64_t frame, const Image8& translated, const std::vector<contour::Border>& borders,
                     const contour::Palette& palette, int cell, Image8* overlay) {
    Image8 real_image(out_size_, out_size_, 3);
    real_image.data = InputImage(frame, out_size_);
    const Image8 columns[3] = {contour::DrawBorders(real_image, {}, palette, o_.overlay_scale),
                               contour::DrawBorders(translated, {}, palette, o_.overlay_scale),
                               contour::DrawBorders(real_image, borders, palette, o_.overlay_scale)};
    for (int c = 0; c < 3; ++c) {
      for (int y = 0; y < cell; ++y) {
        std::memcpy(overlay->pixel(c * cell, static_cast<int>(frame) * cell + y),
                    columns[c].pixel(0, y), static_cast<size_t>(cell) * 3);
      }
    }
  }

  const DeepfakeInferOptions& o_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  Translator t_;
  io::H5File frames_file_;
  std::string dataset_;
  int64_t num_frames_ = 0;
  int frame_size_ = 0;
  int size_ = 0;        // the network's image size
  int out_size_ = 0;    // the translations' size
  int64_t latent_ = 0;  // floats of a code E(I)
  FrameOutput out_;
};

}  // namespace

StageSummary RunDeepfakeTrain(const DeepfakeTrainOptions& o, const StageContext& ctx,
                              const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  const int threads = ThreadsPerRank(o.threads);
  nn::SetTorchThreads(threads);
  TrainingData data;
  dist::CoordinateExceptions(comm, [&] { data = ReadTrainingData(o, comm); });
  if (comm.IsMainRank()) {
    FC_INFO("deepfake train: A {} images {}px, B {} images {}px, network {}px, {} parameters, "
            "{} ranks x {} threads, global batch {}",
            data.a.total, data.a.size, data.b.total, data.b.size, o.network.size,
            data.model->num_parameters(), comm.size(), threads, o.batch);
    if (!o.paired.empty()) {
      FC_INFO("deepfake train: paired A examples: {} frames of {} clip(s), the first {}, "
              "with their segmentation, {:.0f}% of A",
              data.paired_target.total, o.paired.size(), o.paired.front(), 100.0 * o.paired_fraction);
    }
  }
  DeepfakeTraining network(o, comm, &data);
  train::ControllerOptions control = TrainingControl(ctx, resolved, "deepfake train",
                                                     "deepfake.train", o.out, IdentityOptions(o));
  control.steps = o.steps;
  control.checkpoint_every = o.checkpoint_every;
  control.progress_seconds = o.progress_seconds;
  control.continue_finished = true;
  const train::TrainResult result = train::Train(control, comm, &network);
  if (!result.up_to_date) network.WritePreview();
  return StageSummary{o.out, "steps", result.start_step + result.steps_run, result.steps_run};
}

StageSummary RunDeepfakeInfer(const DeepfakeInferOptions& o, const StageContext& ctx,
                              const io::Config& resolved) {
  nn::SetTorchThreads(ThreadsPerRank(o.threads));
  return DeepfakeInference(o, ctx, resolved).Run();
}

}  // namespace facecap::stages
