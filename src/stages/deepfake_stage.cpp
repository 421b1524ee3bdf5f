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

#include "contour/contours.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "nn/augment.h"
#include "nn/deepfake.h"
#include "nn/deepfake_io.h"
#include "io/camera_file.h"
#include "stages/cli.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/holdout.h"
#include "stages/registry.h"
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

// [deepfake.train]
struct DeepfakeTrainOptions {
  std::string a = "samples.h5";                  // domain A: synthetic segmentation renders
  std::string a_dataset = "/samples/segmentation";  // A's image dataset
  std::string b = "frames.h5";                   // domain B: real frames (ingest) or a wild clip
  std::string b_dataset = "";                    // image dataset of B ("": first found of
                                                 // /frames/image, /frames/crop, /samples/segmentation)
  int b_holdout_every = 0;                       // B frames i % n == n - 1 are not trained on
  std::vector<std::string> paired;               // wild clips of other people (synth clip) as
                                                 // paired A examples (empty: none)
  double paired_fraction = 0.8;                  // share of A examples drawn from `paired`
  bool palette_head = true;                      // D_A chooses among A's region colours
  std::string out = "deepfake.h5";               // model file
  int steps = 4500;                              // training steps (global batches)
  double average_decay = 0.999;                  // moving average of the weights (0: none)
  int batch = 8;                                 // global batch: images of A and of B per step
  int seed = 1;                                  // initial weights and batch sampling
  std::string init = "";                         // model whose weights start training ("": random)
  int checkpoint_every = 200;                    // steps between checkpoints (0: only at the end)
  int preview_every = 200;                       // steps between preview grids (0: only at the end)
  std::string device = "cpu";                    // cpu or cuda
  int threads = 0;                               // torch threads per rank (0: cores / ranks)
  double progress_seconds = 10;                  // interval of the progress lines
  nn::DeepfakeNetworkOptions network;            // architecture
  nn::DeepfakeLossOptions loss;                  // loss weights and Adam
  nn::AugmentOptions augment;                    // augmentation

  // The subcommand's defaults are the recipe that measured best (analysis/RESULTS.md): U-Net
  // skips from the two finest levels and one at the input resolution, D_A at width 24 with a
  // palette head, a narrow D_B, the palette cross-entropy and Dice terms, the gradient cap,
  // random backgrounds behind half of the paired frames.
  DeepfakeTrainOptions() {
    network.skips = 2;
    network.decoder_width = 24;
    network.decoder_b_width = 16;
    network.input_skip_width = 16;
    loss.palette_weight = 1.f;
    loss.region_l1_weight = 0.f;
    loss.dice_weight = 1.f;
    loss.gradient_clip = 3.f;
    augment.random_background = 0.5f;
  }

  // --help's sections: data, schedule and checkpoints, network, losses, augmentation.
  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"a", "Data"}, {"out", "Schedule and checkpoints"}, {"network.size", "Network"},
            {"loss.learning_rate", "Losses and optimizer"}, {"augment.random_background", "Augmentation"}};
  }
  // The options, by concern, in HelpSections' order. The rest of the recipe is fixed (nn::DeepfakeLossOptions and nn::AugmentOptions
  // defaults): L1 + DSSIM reconstruction, adversarial weights 0.02, Adam (0.5, 0.999) with
  // discriminator rate 2e-4, the warp, similarity, flip and colour jitter of domain B.
  template <class V>
  void Visit(V&& v) {
    v("a", a, "domain A file: synthetic segmentation renders (synth samples, /samples/segmentation)");
    v("a_dataset", a_dataset,
      "image dataset of A (e.g. /frames/image of appearance turntable's renders, with an RGB head)");
    v("b", b, "domain B file: real frames (ingest) or a wild clip (synth clip)");
    v("b_dataset", b_dataset,
      "image dataset of B (empty: the first of /frames/image, /frames/crop, /samples/segmentation)");
    v("b_holdout_every", b_holdout_every,
      "keep every n-th frame of B (i % n == n - 1) out of training, for evaluation (0: none)");
    v("paired", paired,
      "wild clips of other people (synth clip), one file or more (comma-separated), whose "
      "frames, with their true segmentation as the target, serve as paired domain-A examples: "
      "E and D_A also learn the translation from camera-like images (empty: none, the unpaired "
      "setting)");
    v("paired_fraction", paired_fraction,
      "share of the domain-A examples drawn from the paired clips");

    v("out", out, "model file (HDF5); OUT.checkpoint holds the checkpoint while training, "
                   "OUT with _preview.png the preview grid");
    v("steps", steps, "training steps; a finished model is trained further when this grows");
    v("batch", batch, "global batch (images of A and of B per step), shared among the ranks");
    v("seed", seed, "seed of the initial weights and of the batch sampling");
    v("init", init,
      "a warm start: a model file (deepfake train) whose weights, its moving average when it "
      "has one, start this training instead of random ones, e.g. a model of other footage "
      "fine-tuned to a new video; its network and regions must be this one's (empty: random "
      "weights)");
    v("average_decay", average_decay,
      "decay of an exponential moving average of the weights, kept beside them in the model "
      "file (/averaged_weights), which infer uses by default (0: none; e.g. 0.999)");
    v("checkpoint_every", checkpoint_every, "steps between checkpoints (0: only at the end)");
    v("preview_every", preview_every, "steps between preview grids (0: only at the end)");
    v("progress_seconds", progress_seconds, "seconds between progress lines");
    v("device", device, "cpu, or cuda when libtorch has CUDA");
    v("threads", threads, "torch threads per rank (0: the cores divided among the node's ranks)");

    v("network.size", network.size, "image width and height in pixels (a power of two, 16 or more)");
    v("network.palette_head", palette_head,
      "D_A gives per pixel logits over domain A's region colours (its /regions and the black "
      "background) and shows their softmax-weighted colour; translations take the most likely "
      "region's colour (false: an RGB head)");
    v("network.skips", network.skips,
      "finest encoder levels whose features also feed the decoders (U-Net skips; 0: none)");
    v("network.input_skip_width", network.input_skip_width,
      "channels of an encoder level at the input resolution that feeds the decoders' last "
      "convolution (0: none)");
    v("network.encoder_width", network.encoder_width, "channels of the encoder's first level, doubled per level");
    v("network.latent_channels", network.latent_channels, "channels of the latent code E(I) (8x8)");
    v("network.decoder_width", network.decoder_width, "channels of the decoders' last level, doubled per level up");
    v("network.decoder_b_width", network.decoder_b_width,
      "channels of D_B's last level, doubled per level up (0: decoder_width)");
    v("network.discriminator_width", network.discriminator_width, "channels of the discriminators");

    v("loss.learning_rate", loss.learning_rate, "Adam learning rate of the encoder and decoders");
    v("loss.gradient_clip", loss.gradient_clip,
      "cap on each step's gradient norm, as a multiple of its running RMS in Adam's second "
      "moment (0: no cap)");
    v("loss.palette_weight", loss.palette_weight,
      "weight of the region cross-entropy of D_A's output over the segmentation palette, rare "
      "regions weighted up (0: none)");
    v("loss.dice_weight", loss.dice_weight,
      "weight of a per-image soft Dice term on D_A's region probabilities, every region "
      "counted alike (0: none; needs the palette)");
    v("loss.region_l1_weight", loss.region_l1_weight,
      "weight of an L1 term on D_A's output with each pixel weighted by its target region's "
      "rarity, as the palette terms' regions (0: none)");

    v("augment.random_background", augment.random_background,
      "probability that a paired camera frame's background is replaced by a random procedural "
      "one (0: never)");
  }
  void DerivedOutputs(std::vector<NamedPath>* outputs) const {
    outputs->push_back({"out + .checkpoint", out + ".checkpoint", OutputKind::kText});
    outputs->push_back({"preview (out with _preview.png)", WithSuffix(out, "_preview.png"),
                        OutputKind::kImage});
  }
  bool Check(std::string* why) const {
    if (steps < 0) { *why = "steps must be >= 0"; return false; }
    if (!(average_decay >= 0 && average_decay < 1)) { *why = "average_decay must be in [0, 1)"; return false; }
    if (b_holdout_every < 0 || b_holdout_every == 1) { *why = "b_holdout_every must be 0 or >= 2"; return false; }
    if (!(paired_fraction >= 0 && paired_fraction <= 1)) { *why = "paired_fraction must be in [0, 1]"; return false; }
    if (batch < 1) { *why = "batch must be positive"; return false; }
    if (checkpoint_every < 0 || preview_every < 0) {
      *why = "checkpoint_every and preview_every must be >= 0";
      return false;
    }
    if (device != "cpu" && device != "cuda") { *why = "device must be cpu or cuda"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (!(progress_seconds > 0)) { *why = "progress_seconds must be positive"; return false; }
    return network.Check(why) && loss.Check(why) && augment.Check(why);
  }
};

// [deepfake.infer]
struct DeepfakeInferOptions {
  std::string model = "deepfake.h5";      // model file (deepfake train)
  std::string frames = "frames.h5";       // frames to translate
  std::string dataset = "";               // image dataset ("": first found, as for train's B)
  std::string out = "translated.h5";      // output file
  std::string decoder = "A";              // A: D_A (the synthetic style), B: D_B
  // File whose /camera/intrinsics (scaled to the translations) is stored with them, so that
  // they can be tracked; "": the frames file's camera, when it has one. Crops of real footage
  // have none: name the synthetic samples (domain A), whose framing the translations imitate.
  std::string camera = "";
  int batch = 16;                         // frames per rank per round (a checkpoint per round)
  int threads = 0;                        // torch threads per rank (0: cores / ranks)
  std::string device = "cpu";             // cpu or cuda
  // With a palette head and decoder A: average D_A's region log-probabilities over each frame
  // and its mirror image (left and right regions swapped back), at twice the cost per frame;
  // ignored for an RGB head or decoder B. It raised the benchmark's held-out mean IoU by
  // 0.014-0.027 (analysis/deepfake_iou.sh).
  bool flip_average = true;
  // With a palette head and decoder A: also average over the frame moved by this many pixels
  // in x, y or both, either way, each moved back (with flip_average, each with its mirror
  // image): nine times the cost per frame. 0: off.
  int shift_average = 3;
  // With a palette head and decoder A: each pixel's label maximizes log p_k - a log w_k over
  // the colours k, for the class weights w_k of the palette terms (the model file's
  // /training/region_weights). 0: the network's own most likely colour.
  double prior_correction = 0;
  // Translate with the model file's moving average of the weights (/averaged_weights, from
  // training with average_decay > 0) when it has one; false: the last step's weights.
  bool averaged = true;
  bool contours = true;                   // region borders of the translations (Sec. 4.1)
  int contour_min_points = 3;             // shorter border runs are dropped
  std::string overlay = "";               // PNG: frame, translation, borders on the frame
                                          // ("": OUT with _contours.png; "none": no PNG)
  int overlay_count = 8;                  // frames in the overlay PNG
  int overlay_scale = 4;                  // magnification of the overlay PNG

  template <class V>
  void Visit(V&& v) {
    v("model", model, "model file (deepfake train)");
    v("frames", frames, "frames file to translate");
    v("dataset", dataset,
      "image dataset (empty: the first of /frames/image, /frames/crop, /samples/segmentation)");
    v("out", out, "output file (HDF5)");
    v("decoder", decoder, "A: translate to domain A with D_A (segmentation style); B: D_B");
    v("camera", camera,
      "file whose /camera/intrinsics is stored with the translations (empty: the frames "
      "file's; for crops of real footage name the synthetic samples)");
    v("batch", batch, "frames per rank per round; each round is a checkpoint");
    v("threads", threads, "torch threads per rank (0: the cores divided among the node's ranks)");
    v("device", device, "cpu, or cuda when libtorch has CUDA");
    v("flip_average", flip_average,
      "with a palette head and decoder A, average D_A's region log-probabilities over each "
      "frame and its mirror image, left and right regions swapped (twice the time; ignored "
      "otherwise)");
    v("shift_average", shift_average,
      "with a palette head and decoder A, also average D_A's region log-probabilities over the "
      "frame moved by this many pixels in x, y or both, either way, each moved back (nine "
      "times the time; 0: off)");
    v("prior_correction", prior_correction,
      "with a palette head and decoder A, subtract this multiple of the log of each region's "
      "class weight in the palette terms (the model file's /training/region_weights) from "
      "D_A's log-probabilities before each pixel takes its most likely region; training with "
      "the weights moved borders into the common regions beside rare ones (0: off; a model "
      "without region weights is translated without it, with a warning)");
    v("averaged", averaged,
      "use the model file's moving average of the weights when it has one (train's "
      "average_decay); false: the weights of the last step");
    v("contours", contours, "extract region borders of the translations as polylines");
    v("contour_min_points", contour_min_points, "border runs with fewer points are dropped");
    v("overlay", overlay, "overlay PNG (empty: OUT with _contours.png; none: no PNG)");
    v("overlay_count", overlay_count, "frames in the overlay PNG");
    v("overlay_scale", overlay_scale, "magnification of the overlay PNG");
  }
  void DerivedOutputs(std::vector<NamedPath>* outputs) const {
    if (overlay == "none") return;
    outputs->push_back({overlay.empty() ? "overlay (out with _contours.png)" : "overlay",
                        overlay.empty() ? WithSuffix(out, "_contours.png") : overlay,
                        OutputKind::kImage});
  }
  bool Check(std::string* why) const {
    if (decoder != "A" && decoder != "B") { *why = "decoder must be A or B"; return false; }
    if (batch < 1) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (device != "cpu" && device != "cuda") { *why = "device must be cpu or cuda"; return false; }
    if (shift_average < 0) { *why = "shift_average must be >= 0"; return false; }
    if (contour_min_points < 2) { *why = "contour_min_points must be >= 2"; return false; }
    if (overlay_count < 1 || overlay_scale < 1 || overlay_scale > 16) {
      *why = "overlay_count must be positive and overlay_scale in [1, 16]";
      return false;
    }
    return true;
  }
};

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
struct ImageShard {
  int size = 0;
  int64_t total = 0;                  // usable frames in the whole dataset
  std::vector<uint8_t> pixels;        // [count, size, size, 3]
  int64_t count() const { return size ? static_cast<int64_t>(pixels.size()) / (3LL * size * size) : 0; }
  const uint8_t* image(int64_t i) const { return pixels.data() + i * 3LL * size * size; }
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
    SetUpBackgrounds();
  }

  int NumLosses() const override { return nn::DeepfakeLosses::kCount; }
  void Backward(int64_t step, double* losses) override {
    Rng rng(static_cast<uint64_t>(o_.seed), static_cast<uint64_t>(step) * 65536u + comm_.rank());
    for (int i = 0; i < batch_.count; ++i) AddExample(i, &rng);
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
    // The palette terms' class weights (palette order: the background, then the regions),
    // which infer's prior correction divides back out.
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
  // backgrounds through the camera's degradations, the same on every rank, and each paired
  // frame's background mask.
  void SetUpBackgrounds() {
    if (!(o_.augment.random_background > 0 && d_.paired_target.count() > 0)) return;
    const int s = d_.paired_image.size;
    Rng bank_rng(static_cast<uint64_t>(o_.seed), 0x4241434bu);
    for (int k = 0; k < 64; ++k) {
      const uint64_t seed = bank_rng.NextU64();
      Image8 image(s, s, 3);
      synth::DegradeFrame(synth::MakeBackground(s, s, seed), Eigen::Vector3f::Ones(), seed, 0,
                          synth::CameraDegradationOptions{}, &image);
      background_bank_.push_back(std::move(image));
    }
    for (int64_t i = 0; i < d_.paired_target.count(); ++i) {
      paired_masks_.push_back(nn::BorderBackgroundMask(d_.paired_target.image(i), s));
    }
    composite_.resize(3LL * s * s);
  }

  // Example i of this rank's batch: an A pair (a segmentation render, or a paired frame of
  // another person with its segmentation) and a B pair.
  void AddExample(int i, Rng* rng) {
    const int64_t ia = rng->UniformInt(d_.a.count()), ib = rng->UniformInt(d_.b.count());
    const uint8_t* input_a = nullptr;
    const ImageShard* target_a = &d_.a;
    int64_t index_a = ia;
    nn::PairKind kind_a = nn::PairKind::kSegmentation;
    if (!o_.paired.empty() && rng->Uniform() < o_.paired_fraction) {
      // A paired example: a camera-like frame of another person, its true segmentation.
      index_a = rng->UniformInt(d_.paired_target.count());
      target_a = &d_.paired_target;
      input_a = d_.paired_image.image(index_a);
      kind_a = nn::PairKind::kPairedCamera;
      if (!background_bank_.empty() && rng->Uniform() < o_.augment.random_background) {
        const Image8& background = background_bank_[rng->UniformInt(background_bank_.size())];
        nn::ReplaceBackground(input_a, background.data.data(), paired_masks_[index_a],
                              d_.paired_image.size, composite_.data());
        input_a = composite_.data();
      }
    }
    nn::AugmentPair(target_a->image(index_a), target_a->size, size_, o_.augment, kind_a, rng,
                    &batch_.input_a[i * image_floats_], &batch_.target_a[i * image_floats_], input_a);
    nn::AugmentPair(d_.b.image(ib), d_.b.size, size_, o_.augment, nn::PairKind::kCamera, rng,
                    &batch_.input_b[i * image_floats_], &batch_.target_b[i * image_floats_]);
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
  std::vector<Image8> background_bank_;
  std::vector<std::vector<uint8_t>> paired_masks_;
  std::vector<uint8_t> composite_;
};

void RunDeepfakeTrain(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<DeepfakeTrainOptions>(flags, &ctx, &resolved);
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
  if (!train::Train(control, comm, &network).up_to_date) network.WritePreview();
}

// --------------------------------------------------------------------------------------------

// The model as infer uses it: the moving average of the weights, D_A's label averaging and
// prior correction as the options and the model file allow.
struct Translator {
  std::unique_ptr<nn::DeepfakeModel> model;
  Regions regions;
  bool averaged = false;   // translating with the model file's moving average of the weights
  bool corrected = false;  // labels with the prior correction
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
  const bool has_weights = model_file.Exists("/training/region_weights");
  if (o.prior_correction != 0 && !has_weights && comm.IsMainRank()) {
    FC_WARN("deepfake infer: {} has no /training/region_weights (trained without the palette "
            "terms, or before they were stored); prior_correction is not applied", o.model);
  }
  if (o.prior_correction != 0 && has_weights) {
    const auto weights =
        model_file.ReadVector<float>("/training/region_weights", model->options().palette_colors);
    std::vector<float> bias(weights.size(), 0.f);
    for (size_t k = 0; k < weights.size(); ++k) {
      // A class absent from the targets (weight 0) keeps its own log-probability.
      if (weights[k] > 0) bias[k] = static_cast<float>(-o.prior_correction * std::log(weights[k]));
    }
    model->SetLabelBias(bias);
    t.corrected = true;
  }
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
    latent_ = t_.model->options().LatentSize();
  }

  void Run() {
    out_ = OpenFrameOutput(ctx_, resolved_, "deepfake infer", o_.out, num_frames_,
                           [&](io::H5File* f, bool resumed) { PrepareOutput(f, resumed); });
    if (out_.up_to_date) return;
    FrameLoopOptions loop;
    loop.what = "deepfake infer";
    loop.batch = o_.batch;
    loop.threads = 1;  // torch parallelizes inside each frame
    RunFrameLoop(
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
              t_.corrected ? fmt::format(" (prior correction {})", o_.prior_correction) : std::string());
    });
  }

 private:
  // The output's datasets (rank 0); `resumed`: a continued file.
  void PrepareOutput(io::H5File* f, bool resumed) {
    f->CreateFrames<uint8_t>(io::frames::kTranslated, {size_, size_, 3}, num_frames_, 16);
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
      CopyScaledCamera(frames_file_, size_, f);
    } else {
      CopyScaledCamera(io::H5File::OpenRead(o_.camera), size_, f);
      if (!io::HasCamera(*f)) throw FileIOError(o_.camera + ": no " + io::kCameraPath);
    }
  }

  // Frame `frame` of the input at the network's size.
  std::vector<uint8_t> InputImage(int64_t frame) {
    ImageShard image;
    image.size = frame_size_;
    image.pixels.resize(3LL * frame_size_ * frame_size_);
    frames_file_.ReadFrames<uint8_t>(dataset_, frame, 1, image.pixels.data());
    return ResizedImages(image, 0, 1, size_);
  }

  std::vector<uint8_t> Translate(int64_t frame) {
    const std::vector<uint8_t> input = InputImage(frame);
    std::vector<uint8_t> translated(3LL * size_ * size_);
    std::vector<float> code(latent_), code_of_translation(latent_);
    const auto decoder = o_.decoder == "A" ? nn::DeepfakeModel::Decoder::kA : nn::DeepfakeModel::Decoder::kB;
    t_.model->Translate(input.data(), 1, decoder, translated.data(), code.data(), code_of_translation.data());
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
    const int cell = size_ * o_.overlay_scale;
    Image8 overlay(3 * cell, std::max(1, overlay_frames) * cell, 3);
    for (int64_t frame = 0; frame < num_frames_; ++frame) {
      Image8 translated(size_, size_, 3);
      f.ReadFrames<uint8_t>(io::frames::kTranslated, frame, 1, translated.data.data());
      const auto labels = contour::ClassifyPixels(translated, palette);
      const auto borders = contour::ExtractBorders(labels, size_, size_, palette.num_labels(), border_options);
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
    Image8 real_image(size_, size_, 3);
    real_image.data = InputImage(frame);
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
  int64_t latent_ = 0;  // floats of a code E(I)
  FrameOutput out_;
};

void RunDeepfakeInfer(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<DeepfakeInferOptions>(flags, &ctx, &resolved);
  nn::SetTorchThreads(ThreadsPerRank(o.threads));
  DeepfakeInference(o, ctx, resolved).Run();
}

}  // namespace

void RegisterDeepfake(CLI::App* app, AppState* state) {
  CLI::App* deepfake = app->add_subcommand(
      "deepfake", "The deepfake of paper 000 Sec. 4: train with gradient allreduce, translate frames");
  deepfake->require_subcommand(1);
  AddStage<DeepfakeTrainOptions>(
      deepfake, state, "train", "deepfake.train", "deepfake train",
      "Train E, D_A, D_B with the discriminators G_image and G_latent on A (synthetic renders) and "
      "B (real frames), data-parallel across ranks with gradient allreduce; checkpoints, resumes, "
      "progress lines with each loss, preview grid",
      PathKeys{{"a", "b", "paired", "init"}, {{"out", OutputKind::kHdf5}}},
      RunDeepfakeTrain);
  AddStage<DeepfakeInferOptions>(
      deepfake, state, "infer", "deepfake.infer", "deepfake infer",
      "Translate frames with D(E(I)), store the codes E(I) and E(D(E(I))), and the region borders "
      "of each translation as polylines with an overlay PNG; spread across ranks, resumable",
      PathKeys{{"model", "frames", "camera"}, {{"out", OutputKind::kHdf5}}},
      RunDeepfakeInfer);
}

}  // namespace facecap::stages
