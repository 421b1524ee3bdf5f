// Blendshape generation from one neutral scan (paper 001 Sec. 4): the Blendshape Generator
// (a CNN encoder-decoder on the neutral's geometry image with two decoder branches, for the
// large-motion and the small-motion shapes, each ending in a 1x1 output convolution plus a
// head that conditions a shape's offsets on its template motion at each vertex) and, for the
// Tuning Stage, a second generator fed the initial blendshapes (as the Estimation decoders'
// features) with a skip connection, plus the Blending Weight Predictor.
//
// Torch stays in blendshape_generator.cpp; this header takes plain arrays. Training follows
// facecap's data-parallel pattern: each rank calls Backward on its share of the batch, the
// controller sums GradientBuffer() over ranks (dist::Comm::SumReduce), and OptimizerStep applies
// Adam, bitwise the same on every rank.
//
// Layouts: images are channels-first [C, H, W] floats; per-vertex arrays are [A, 3] over the
// A chart vertices of the geometry image; shapes [N, A, 3]; weights [K, N].
#ifndef FACECAP_NN_BLENDSHAPE_GENERATOR_H_
#define FACECAP_NN_BLENDSHAPE_GENERATOR_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace facecap::nn {

struct BlendshapeNetOptions {
  int channels = 12;              // feature channels of the first generator layer (x2, x4 deeper)
  int residual_blocks = 2;        // encoder residual blocks at 1/4 resolution
  int head_width = 32;            // hidden units of the template-conditioned heads (0: none)
  int head_depth = 2;             // hidden layers of the heads (1 or 2; models without the attribute: 1)
  bool head_frame = true;         // heads also in the frame of the template motion (see the .cpp)
  bool head_local_frame = true;   // the heads' free offsets in the frame of the motion and the displacement
                                  // (models without the attribute: off)
  int amplitude_width = 32;       // hidden units of the pooled-image amplitude (amplitude_components 0; both 0: none)
  bool amplitude_on_path = true;  // the amplitude scales the motion along the template path only
  int amplitude_components = 24;  // >0: the amplitude reads this many whitened principal components
                                  // of the training neutrals (models without the attribute: 0)
  float learning_rate = 2e-3f;    // Adam step size
  float reg_weight = 1.f;         // omega_reg of L_G = L_rec + omega_reg L_reg (eq. 7)
  float tuning_reg_weight = 0.1f; // omega_reg_FT of L_G_FT (eq. 9)
  float amplitude_decay = 0.f;    // lambda of the ridge term lambda |W|^2 on the amplitude's weights
  float weight_decay = 0.f;       // decoupled weight decay of the convolution and linear weights
  int seed = 1;                   // parameter initialization seed

  template <class V>
  void Visit(V&& v) {
    v("channels", channels, "feature channels of the first generator layer (doubled twice deeper)");
    v("residual_blocks", residual_blocks, "encoder residual blocks at quarter resolution");
    v("head_width", head_width, "hidden units of the output head that conditions each shape's offsets on its template motion (0: 1x1 output convolutions only)");
    v("head_depth", head_depth, "hidden layers of the heads, 1 or 2 (both head_width wide)");
    v("head_frame", head_frame, "the heads also see the neutral's displacement along each shape's template motion and output a gain on that motion");
    v("head_local_frame", head_local_frame, "with head_frame: the heads give their free offsets in a frame built from each shape's template motion and the neutral's displacement at the point (along the motion, along the displacement, across both) and also see the displacement's length, so they map rotation-invariant scalars to scalars");
    v("amplitude_width", amplitude_width, "hidden units of the per-shape amplitude a_i predicted from the whole neutral, which scales how far the person moves along each shape (used when amplitude_components is 0; both 0: no amplitude)");
    v("amplitude_components", amplitude_components, "0: the amplitude is a tanh layer on the pooled neutral image (amplitude_width wide); > 0: it reads that many whitened principal components of the training people's pooled neutral images, one tanh per shape, a_i = b_i tanh(w_i . z + c_i)");
    v("amplitude_on_path", amplitude_on_path, "the amplitude scales only the motion along the template path, (1 + a_i)(S_i + gain S_i), not the heads' free offsets (off: all of S_i + Delta S_i)");
    v("learning_rate", learning_rate, "Adam step size");
    v("reg_weight", reg_weight, "omega_reg: weight of L_reg in the Estimation Stage (eq. 7)");
    v("tuning_reg_weight", tuning_reg_weight, "omega_reg_FT: weight of L_reg_FT in the Tuning Stage (eq. 9)");
    v("amplitude_decay", amplitude_decay, "ridge penalty lambda |W|^2 on the amplitude network's weight matrices (its few training people fit it by heart without one)");
    v("weight_decay", weight_decay, "decoupled weight decay (AdamW): each step multiplies the convolution and linear weight matrices of the stage in training by 1 - learning_rate x weight_decay (not the biases, nor the amplitude, which amplitude_decay covers)");
    v("net_seed", seed, "parameter initialization seed");
  }
  bool Check(std::string* why) const;
};

// What the networks need that is the same for every person.
struct BlendshapeNetGeometry {
  int image_size = 64;                   // H = W of the geometry images
  int num_shapes = 0;                    // N
  int num_chart_vertices = 0;            // A
  std::vector<int> large_motion_shapes;  // shapes of the large-motion branch (the rest: small)
  std::vector<float> template_deltas;    // S_i on the chart vertices, [N, A, 3] (cm)
  std::vector<float> reg_weights;        // g_i m_i(x) of eq. 4-6, [N, A]
  std::vector<int32_t> sample_pixels;    // bilinear stencil of each chart vertex, [A, 4]
  std::vector<float> sample_weights;     // its weights, [A, 4]
  std::vector<float> static_channels;    // constant input channels [C_s, H, W] (template, mask)
  int num_static_channels = 0;           // C_s
};

// One training person.
struct BlendshapePerson {
  std::vector<float> neutral_image;      // normalized identity displacement image [3, H, W]
  std::vector<float> neutral;            // S_0^j on the chart vertices [A, 3] (cm)
  std::vector<float> expressions;        // P_k^j on the chart vertices [K, A, 3] (cm)
  std::vector<float> expression_images;  // normalized (P_k^j - S_0^j) images [K, 3, H, W]
  std::vector<float> nominal_weights;    // alpha_k: the FACS table's 0/1 weights (times a nominal weight) [K, N]
  int num_expressions = 0;               // K
};

enum class TrainingStage { kEstimation = 0, kTuning = 1 };

class BlendshapeGenerator {
 public:
  BlendshapeGenerator(const BlendshapeNetOptions& options,
                      std::shared_ptr<const BlendshapeNetGeometry> geometry);
  ~BlendshapeGenerator();
  BlendshapeGenerator(const BlendshapeGenerator&) = delete;
  BlendshapeGenerator& operator=(const BlendshapeGenerator&) = delete;

  // Parameters of all networks, flattened in a fixed order.
  int64_t NumParameters() const;
  // Forward and backward of the stage's loss summed over `batch`, times loss_scale (use
  // 1 / global batch size); gradients replace GradientBuffer(). Returns the scaled loss; the
  // unscaled reconstruction term L_rec (mean cm per vertex, summed over the batch) goes to
  // *reconstruction when not null. The Tuning Stage keeps each person's outputs of the fixed
  // Estimation networks (about 1 MB per person at 55 shapes and 1,649 chart vertices), keyed
  // by the person's address and checked against their neutral image, until the Estimation
  // parameters or the amplitude basis change.
  double Backward(const std::vector<const BlendshapePerson*>& batch, TrainingStage stage,
                  float loss_scale, double* reconstruction = nullptr);
  // NumParameters() floats: the gradient of the last Backward (reduce it across ranks).
  float* GradientBuffer();
  // Adam on GradientBuffer() for the stage's networks (Estimation: generator; Tuning: tuning
  // generator and weight predictor; the other networks stay fixed).
  void OptimizerStep(TrainingStage stage);

  // Everything a checkpoint needs: parameters, Adam moments and step counts.
  std::vector<float> State() const;
  void SetState(const std::vector<float>& state);
  // Parameters only (what inference needs).
  std::vector<float> Parameters() const;
  void SetParameters(const std::vector<float>& parameters);

  // With amplitude_components > 0: the whitened principal components of the people's pooled
  // neutral images that the amplitude reads, computed in double from `people` (the training
  // people: the same arithmetic on the same people gives bitwise the same basis on every rank).
  // Components beyond the people's rank are zero. Not parameters: a model file stores
  // AmplitudeBasis() ([components + 1, features]: the mean, then the rows) beside them.
  void FitAmplitudeBasis(const std::vector<const BlendshapePerson*>& people);
  std::vector<float> AmplitudeBasis() const;
  void SetAmplitudeBasis(const std::vector<float>& basis);

  // The personalized offsets Delta S_i (eq. 3) for one neutral image [3, H, W]: [N, A, 3]
  // (cm). tuned: Estimation + Tuning generator (the final shapes); else Estimation only.
  // Runs an inference form of the networks, prepared on the first call after the parameters
  // change (oneDNN convolutions; output layers, channel order and sampling folded into one
  // matrix); safe to call from several threads.
  std::vector<float> PredictOffsets(const std::vector<float>& neutral_image, bool tuned) const;
  // Builds the inference form now and runs it once on a zero image (which creates the
  // convolution kernels), so that the first PredictOffsets costs what later ones do.
  void PrepareInference() const;
  // The same through the training modules' forward (the reference PredictOffsets matches to
  // float rounding; slower).
  std::vector<float> PredictOffsetsWithModules(const std::vector<float>& neutral_image, bool tuned) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Sets the intra-op threads of the tensor library for this process.
void SetTensorThreads(int threads);

}  // namespace facecap::nn

#endif  // FACECAP_NN_BLENDSHAPE_GENERATOR_H_
