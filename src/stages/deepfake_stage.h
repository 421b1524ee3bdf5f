// facecap deepfake train / infer (paper 000 Sec. 4 and 4.1).
//
// train: E, D_A, D_B with the discriminators G_image and G_latent, trained on A (synthetic
// renders) and B (real frames), data-parallel with gradient allreduce. Rank 0's initial
// weights are broadcast; each rank reads its own block of A and B; every step each rank draws
// its share of the global batch from Rng(seed, step * 65536 + rank), computes its gradients
// (weighted by its share), the gradient buffers are summed over ranks, and every rank takes
// the same Adam step, so the weights stay bitwise identical. A checkpoint is written
// atomically to OUT.checkpoint every checkpoint_every steps and on SIGTERM/SIGUSR1 (then exit
// 75); rerunning the command continues from it, and a finished OUT trained for fewer steps is
// continued when --steps grows. Progress lines with each loss, and a preview grid.
//
// infer: D_S(E(I)) and the codes E(I), E(D_S(E(I))) for every frame, spread across ranks and
// resumable (frame_loop.h), then the region borders of each translation (contour/) as
// polylines and an overlay PNG on the real frames.
#ifndef FACECAP_STAGES_DEEPFAKE_STAGE_H_
#define FACECAP_STAGES_DEEPFAKE_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "io/config.h"
#include "nn/augment.h"
#include "nn/deepfake.h"
#include "stages/stage.h"
#include "stages/stage_paths.h"

namespace facecap::stages {

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
  // With a palette head and decoder A: the translations are this many times the network's
  // size on a side, D_A's log-probabilities upsampled bilinearly before each pixel takes its
  // most likely region (borders between the network's pixels: a brow raise of a pixel of the
  // network's output shows). 1: the network's size.
  int label_scale = 2;
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
    v("label_scale", label_scale,
      "with a palette head and decoder A, translations this many times the network's size on a "
      "side: the region log-probabilities upsampled bilinearly before each pixel takes its most "
      "likely region (1-4; 1: the network's size; ignored otherwise)");
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
    if (label_scale < 1 || label_scale > 4) { *why = "label_scale must be 1-4"; return false; }
    if (contour_min_points < 2) { *why = "contour_min_points must be >= 2"; return false; }
    if (overlay_count < 1 || overlay_scale < 1 || overlay_scale > 16) {
      *why = "overlay_count must be positive and overlay_scale in [1, 16]";
      return false;
    }
    return true;
  }
};

// Runs deepfake train on every rank of ctx.comm (collective). The summary counts the
// optimizer steps the model holds and those this run made (0 when OUT was up to date).
StageSummary RunDeepfakeTrain(const DeepfakeTrainOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

// Runs deepfake infer on every rank of ctx.comm (collective). The summary counts the frames
// translated in the output and those this run translated (0 when it was up to date).
StageSummary RunDeepfakeInfer(const DeepfakeInferOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_DEEPFAKE_STAGE_H_
