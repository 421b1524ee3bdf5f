// The deepfake of paper 000 Sec. 4: one encoder E and two decoders D_A, D_B trained without
// pairs on images of domain A (synthetic segmentation renders) and domain B (real frames), with
// an image discriminator G_image on D_A's outputs and a latent discriminator G_latent on E's
// codes (the asymmetric GAN losses f_image and f_latent), so that D_A(E(I_B)) shows a real
// frame in the rig's segmentation style.
//
// Torch stays inside nn/*.cpp: DeepfakeModel and DeepfakeTrainer are pimpl classes over plain
// float buffers. Every parameter of the five networks lives in ONE contiguous buffer, and so
// does every gradient, in the same layout (ParameterLayout()). Training is split the way a
// data-parallel controller needs it:
//
//   trainer.Backward(batch, share);            // local gradients into trainer.gradients()
//   comm.SumReduce(trainer.gradients(), n);    // the controller (stages/) sums over ranks
//   trainer.OptimizerStep();                   // Adam on the summed gradients
//
// With the same parameters and the same summed gradients, OptimizerStep gives bitwise the same
// parameters on every rank. There is no MPI here.
#ifndef FACECAP_NN_DEEPFAKE_H_
#define FACECAP_NN_DEEPFAKE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "util/image.h"

namespace facecap::nn {

// The architecture; stored beside the weights so that a model file rebuilds its networks.
struct DeepfakeNetworkOptions {
  int size = 64;                  // image width and height in pixels (a power of two, >= 16)
  int encoder_width = 32;         // channels of E's first level; doubled at every level down
  int latent_resolution = 8;      // side of the spatial code E(I) (a power of two < size)
  int latent_channels = 32;       // channels of the code E(I): its size is channels x res^2
  int decoder_width = 32;         // channels of D_A/D_B's last level; doubled at every level up
  int discriminator_width = 32;   // channels of G_image's first level, and of G_latent
  // Encoder levels, finest first, whose features also reach the decoders at the same
  // resolution (U-Net skip connections). 0 is the plain autoencoder of paper 000, where
  // everything passes through the code E(I); skips let the decoders draw fine borders from
  // fewer training steps, and the latent discriminator still acts on the code.
  int skips = 0;
  // Channels of D_B's last level (0: decoder_width). D_B only reconstructs domain B, so that
  // E learns to encode real frames; a narrower D_B leaves more of each step to E and D_A.
  int decoder_b_width = 0;
  // Channels of an extra encoder level at the input resolution (a stride-1 3x3 convolution of
  // the image) whose features feed the decoders' last convolution, which draws the output at
  // that resolution (0: none). The strided levels stop at half the input resolution, so
  // without it the decoders place borders from features a pixel pair apart; an iris or a lip
  // at 64x64 is a few pixels wide.
  int input_skip_width = 0;
  // Colours of D_A's palette head (0: an RGB head). With K > 0, D_A's last convolution gives
  // per pixel K logits over domain A's region colours (DeepfakeModel::SetPalette, the
  // background first), and D_A shows their softmax-weighted colour while training and the
  // colour of the most likely region in translations. A segmentation image is a choice among
  // K colours per pixel; an RGB head must reach each one by regression, and a pixel between
  // two regions comes out in a blend that is nearer a third region's colour (lips and mouth
  // interior blend to the lower eyelid's).
  int palette_colors = 0;

  template <class V>
  void Visit(V&& v) {
    v("size", size, "image width and height in pixels (a power of two, 16 or more)");
    v("encoder_width", encoder_width, "channels of the encoder's first level, doubled per level");
    v("latent_resolution", latent_resolution, "side of the spatial latent code E(I)");
    v("latent_channels", latent_channels, "channels of the latent code E(I)");
    v("decoder_width", decoder_width, "channels of the decoders' last level, doubled per level up");
    v("discriminator_width", discriminator_width, "channels of the discriminators");
    v("skips", skips,
      "finest encoder levels whose features also feed the decoders (U-Net skips; 0: none)");
    v("decoder_b_width", decoder_b_width,
      "channels of D_B's last level, doubled per level up (0: decoder_width)");
    v("input_skip_width", input_skip_width,
      "channels of an encoder level at the input resolution that feeds the decoders' last "
      "convolution (0: none)");
    v("palette_colors", palette_colors,
      "colours of D_A's palette head, domain A's regions and the background (0: an RGB head; "
      "deepfake train --palette-head sets it)");
  }
  bool Check(std::string* why) const;
  int64_t LatentSize() const {
    return static_cast<int64_t>(latent_channels) * latent_resolution * latent_resolution;
  }
};

// Loss weights and the optimizer (paper 000 Sec. 4: f_recon, f_image, f_latent).
struct DeepfakeLossOptions {
  float l1_weight = 1.f;              // weight of the L1 term of f_recon
  float l2_weight = 0.f;              // weight of the L2 term of f_recon
  float dssim_weight = 1.f;           // weight of the DSSIM term of f_recon ((1 - SSIM) / 2)
  float image_gan_weight = 0.02f;     // weight of D_A's adversarial term (against G_image)
  float latent_gan_weight = 0.02f;    // weight of E's adversarial term (against G_latent)
  // Weight of the palette term on D_A's output (DeepfakeTrainer::SetPalette): per pixel, the
  // cross-entropy of the target's region under logits -|y - c_k|^2 / palette_temperature over
  // the palette colours c_k (with a palette head: its own logits), each region weighted by its
  // rarity. D_A's targets are flat region
  // colours, so their labels are known; L1 and DSSIM in RGB let a region a few pixels wide cost
  // almost nothing when it is missing, the weighted cross-entropy does not.
  float palette_weight = 0.f;
  float palette_temperature = 0.02f;  // colour distance scale of the palette logits
  // Weight of a region-weighted L1 term on D_A's output: each pixel's |D_A(E(I)) - I| is
  // weighted by its target region's rarity (the palette's weights, DeepfakeTrainer::SetPalette),
  // so that an iris or a lower eyelid a few pixels wide costs as much as its share of the
  // face, not of the image (DeepFaceLab's eyes-and-mouth priority in spirit). 0: none; 2
  // raised the held-out IoU after 1,200 steps from 0.400 to 0.435 (analysis/deepfake_iou.sh).
  float region_l1_weight = 2.f;
  // Weight of a soft Dice term on D_A's region probabilities (the palette head's softmax, or
  // the palette term's logits): per image and palette colour k,
  // 1 - (2 sum p_k t_k + 1) / (sum p_k + sum t_k + 1) with t_k the target's one-hot region,
  // averaged over colours and images. Each region counts as much as any other whatever its
  // size, as in the mean IoU it stands in for. Per image, so a rank's share is exact. 0: none.
  float dice_weight = 0.f;
  float learning_rate = 1e-3f;        // Adam step of E, D_A, D_B
  // Caps each step's gradient norm (generators and discriminators apart) at this multiple of
  // the running RMS norm Adam has seen (its second moment, bias-corrected): a sudden gradient
  // far above it would otherwise move the weights up to (1 - beta1) / sqrt(1 - beta2) = 16
  // learning rates at once. 0: no cap.
  float gradient_clip = 0.f;
  float discriminator_learning_rate = 2e-4f;  // Adam step of G_image, G_latent
  float beta1 = 0.5f;                 // Adam first-moment decay
  float beta2 = 0.999f;               // Adam second-moment decay

  template <class V>
  void Visit(V&& v) {
    v("l1_weight", l1_weight, "weight of the L1 reconstruction term");
    v("l2_weight", l2_weight, "weight of the L2 reconstruction term");
    v("dssim_weight", dssim_weight, "weight of the DSSIM reconstruction term");
    v("image_gan_weight", image_gan_weight, "weight of D_A's adversarial loss against G_image");
    v("latent_gan_weight", latent_gan_weight, "weight of E's adversarial loss against G_latent");
    v("palette_weight", palette_weight,
      "weight of the region cross-entropy of D_A's output over the segmentation palette, rare "
      "regions weighted up (0: none)");
    v("palette_temperature", palette_temperature,
      "squared colour distance scale of the palette cross-entropy's logits");
    v("region_l1_weight", region_l1_weight,
      "weight of an L1 term on D_A's output with each pixel weighted by its target region's "
      "rarity, as the palette term's regions (0: none)");
    v("dice_weight", dice_weight,
      "weight of a per-image soft Dice term on D_A's region probabilities, every region "
      "counted alike (0: none; needs the palette)");
    v("learning_rate", learning_rate, "Adam learning rate of the encoder and decoders");
    v("gradient_clip", gradient_clip,
      "cap on each step's gradient norm, as a multiple of its running RMS in Adam's second "
      "moment (0: no cap)");
    v("discriminator_learning_rate", discriminator_learning_rate,
      "Adam learning rate of the discriminators");
    v("beta1", beta1, "Adam first-moment decay");
    v("beta2", beta2, "Adam second-moment decay");
  }
  bool Check(std::string* why) const;
};

// One parameter (or gradient, or Adam moment) inside the contiguous buffers.
struct TensorSlot {
  std::string name;            // module path: "encoder/down0/weight"
  std::vector<int64_t> shape;  // e.g. [32, 3, 5, 5]
  int64_t offset = 0;          // first element in the buffer
  int64_t count = 0;           // number of elements
};

// Training images after augmentation: float RGB in [0, 1], [count, size, size, 3] each.
struct TrainingBatch {
  int count = 0;
  int size = 0;
  std::vector<float> input_a, target_a;  // I_A warped (input) and unwarped (target)
  std::vector<float> input_b, target_b;  // I_B likewise
};

// The terms of one training step (means over the batch, summed over ranks by the caller when
// each rank passes its share).
struct DeepfakeLosses {
  double recon_a = 0;               // ||D_A(E(I_A)) - I_A||
  double recon_b = 0;               // ||D_B(E(I_B)) - I_B||
  double image_adversarial = 0;     // D_A's term: G_image(D_A(E(I_A))) pushed to 1
  double latent_adversarial = 0;    // E's term: G_latent(E(I_B)) pushed to 1 (looks like A)
  double image_discriminator = 0;   // f_image = ||G_image(D_A(E(I_A)))|| + ||1 - G_image(I_A)||
  double latent_discriminator = 0;  // f_latent = ||G_latent(E(I_B))|| + ||1 - G_latent(E(I_A))||
  double palette_a = 0;             // weighted region cross-entropy of D_A(E(I_A)) (palette_weight)
  double region_l1_a = 0;           // region-weighted L1 of D_A(E(I_A)) (region_l1_weight)
  double dice_a = 0;                // soft Dice term of D_A(E(I_A)) (dice_weight)
  static constexpr int kCount = 9;
  void ToArray(double* v) const;
  void FromArray(const double* v);
};

// One step of the exponential moving average of the weights after `steps_done` optimizer
// steps: averaged = d * averaged + (1 - d) * weights with
// d = min(decay, (1 + steps_done) / (10 + steps_done)), so that the early average does not hold
// on to the initial weights. Elementwise in a fixed order: the same on every rank.
void UpdateMovingAverage(const float* weights, int64_t count, int64_t steps_done, double decay,
                         float* averaged);

// Uses `threads` intra-op threads in torch (and one inter-op thread).
void SetTorchThreads(int threads);
// True when libtorch was built with CUDA and a device is present.
bool CudaAvailable();

// The five networks, their parameters in one buffer, and inference.
class DeepfakeModel {
 public:
  // Builds the networks with weights drawn from `init_seed` on `device` ("cpu" or "cuda";
  // InvalidInputError when CUDA is asked for and not available).
  DeepfakeModel(const DeepfakeNetworkOptions& options, uint64_t init_seed,
                const std::string& device = "cpu");
  ~DeepfakeModel();
  DeepfakeModel(const DeepfakeModel&) = delete;
  DeepfakeModel& operator=(const DeepfakeModel&) = delete;

  const DeepfakeNetworkOptions& options() const;
  // Every parameter of E, D_A, D_B, G_image, G_latent, in this order.
  const std::vector<TensorSlot>& ParameterLayout() const;
  int64_t num_parameters() const;
  // The contiguous parameter buffer in host memory. After writing into it (a broadcast, a
  // checkpoint) call ParametersWritten(); before reading it after training on a device call
  // ParametersToHost() (both do nothing on the CPU, where the buffer is the weights).
  float* parameters();
  void ParametersWritten();
  void ParametersToHost();
  // The colours of the palette head (RGB in [0, 1], [palette_colors, 3], the background
  // first); InvalidInputError when their number differs from options().palette_colors.
  // Without a palette head it does nothing. Not a parameter: it is domain A's, stored with
  // the regions of the model file.
  void SetPalette(const std::vector<float>& colors);
  // Flip averaging of the palette head at inference: `mirror[k]` is the palette index of colour
  // k's mirror image (a left region's right region; k itself for the others). D_A's logits of
  // an image and the mirrored logits of its mirror image are averaged before each pixel's most
  // likely region is taken. Empty: off (the default). InvalidInputError when the size differs
  // from options().palette_colors or an index is out of range.
  void SetFlipAverage(const std::vector<int>& mirror);
  // Shift averaging of the palette head at inference: D_A's log-probabilities are summed over
  // the image and the image moved by `pixels` in x, y or both, in either direction (eight
  // moves, edges repeated), each moved back; with SetFlipAverage each pass has its mirror image
  // too. The encoder's strided grid then samples every frame at other phases. 0: off (the
  // default); InvalidInputError when negative.
  void SetShiftAverage(int pixels);
  enum class Decoder { kA, kB };
  // Label upsampling of the palette head at inference: D_A's log-probabilities (after flip and
  // shift averaging) are upsampled bilinearly by `scale` before each pixel takes
  // its most likely colour, so the translation has scale x size pixels on a side and its
  // borders fall between the network's pixels where its probabilities cross. 1: off (the
  // default); InvalidInputError outside 1-4.
  void SetLabelScale(int scale);
  // The side of D_A's translations in pixels: options().size times the label scale with a
  // palette head, options().size otherwise (and for D_B).
  int TranslationSize(Decoder decoder) const;
  // FNV-1a hash of the parameter bytes (to compare ranks).
  uint64_t ParameterHash();

  // For `count` uint8 RGB images [count, size, size, 3] (size == options().size): the
  // translation D(E(I)) as uint8 [count, t, t, 3] (t = TranslationSize(decoder)), E(I) and
  // E(D(E(I))) as [count, LatentSize()] (paper 000 Sec. 9 regresses on the latter; of the
  // translation at the network's size). Null outputs are skipped. With a palette head, D_A's
  // translation is the colour of each pixel's most likely region (averaged over the image and
  // its mirror image after SetFlipAverage).
  void Translate(const uint8_t* images, int count, Decoder decoder, uint8_t* translated,
                 float* code, float* code_of_translation);

 private:
  friend class DeepfakeTrainer;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Gradients in one buffer and Adam, over a DeepfakeModel.
class DeepfakeTrainer {
 public:
  DeepfakeTrainer(DeepfakeModel* model, const DeepfakeLossOptions& losses);
  ~DeepfakeTrainer();
  DeepfakeTrainer(const DeepfakeTrainer&) = delete;
  DeepfakeTrainer& operator=(const DeepfakeTrainer&) = delete;

  DeepfakeModel& model();
  // The gradient buffer (host memory, ParameterLayout() of the model): Backward fills it with
  // this rank's gradients, the caller may sum it over ranks, OptimizerStep applies it.
  float* gradients();
  int64_t num_gradients() const;
  // Forward and backward on one batch: E, D_A, D_B get the gradients of
  // f_recon + image_gan_weight * (D_A's adversarial term) + latent_gan_weight * (E's term)
  // (+ the palette terms on D_A's output when their weights and a palette are set);
  // G_image and G_latent the gradients of f_image and f_latent (on detached inputs).
  // Every loss is multiplied by `share` (this rank's fraction of the global batch), so that
  // the sum over ranks is the gradient of the global batch mean.
  DeepfakeLosses Backward(const TrainingBatch& batch, double share = 1.0);
  // The region colours of domain A (RGB in [0, 1], [K, 3], background included) and each
  // region's weight in the palette and region-weighted L1 terms (K); without a palette both
  // terms are off.
  void SetPalette(const std::vector<float>& colors, const std::vector<float>& weights);
  // One Adam step on the gradient buffer with both learning rates times `learning_rate_scale`
  // (a schedule of the caller's); increments step().
  void OptimizerStep(double learning_rate_scale = 1.0);

  // Adam state, ParameterLayout() of the model: first and second moments and the step count.
  float* first_moments();
  float* second_moments();
  int64_t step() const;
  void set_step(int64_t step);
  // After writing the moments (a checkpoint).
  void OptimizerStateWritten();
  void OptimizerStateToHost();

  // The preview grid of paper 000 Fig. 6: one row per image pair, columns
  // I_A, D_A(E(I_A)), I_B, D_B(E(I_B)), D_A(E(I_B)). Images uint8 [count, size, size, 3].
  Image8 PreviewGrid(const uint8_t* images_a, const uint8_t* images_b, int count);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::nn

#endif  // FACECAP_NN_DEEPFAKE_H_
