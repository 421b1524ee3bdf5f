// The personalized regressor of paper 000 Sec. 9 (Fig. 23). From a frame's code
// e = E(D_S(E(I))) it predicts, the way a solver does, the pose p = P(e), the jaw controls
// w_j = J(e, p), the other (expression) controls w_c = W(e, p, w_j), and the 2D landmarks
// m = L(p, w_j, w_c). Each network is a stack of fully connected layers with leaky ReLUs and a
// sigmoid output: every target is normalized to [0, 1] by the caller.
//
// Training has three phases (Regressor::Phase):
//   kPoseJawExpression  P, J, W on synthetic examples:
//                         L_P = |P(e) - p|
//                         L_J = |J(e, P(e)) - w_j| + |J(e, p) - w_j|
//                         L_W = |W(e, P(e), J(e, P(e))) - w_c| + |W(e, p, w_j) - w_c|
//   kLandmarks          L alone (P, J, W frozen), on synthetic examples:
//                         L_L = sum_k max(0, |L_k(P, J, W) - m_k| - delta)
//                             + max(0, |L_k(p, w_j, w_c) - m_k| - delta)
//   kFineTune           P, J, W with L frozen, on synthetic and real examples: L_P, L_J, L_W
//                       where the truth is known, and L_L* = sum_k max(0, |L_k(P, J, W) - m_k|
//                       - delta) wherever landmarks are known; where an example has anchors
//                       (a real frame's P, J, W outputs before this phase), anchor_weight times
//                       |P - P_0| + |J - J_0| + |W - W_0|, which keeps the outputs the
//                       landmarks do not determine where the synthetic truth put them.
// |.| of a pose or control vector difference is its mean squared value (with a mean absolute
// difference the sigmoid outputs of the sparse controls saturate at 0 under Adam and never
// fit); |L_k - m_k| is landmark k's Euclidean distance.
//
// Torch stays in regressor.cpp. Training follows facecap's data-parallel pattern: each rank's
// Backward on its share of a step, the caller sums Gradients() over the ranks, and
// OptimizerStep applies Adam to the networks the phase trains, bitwise the same on every rank;
// StartPhase gives each phase a fresh Adam, as separate trainings would have.
#ifndef FACECAP_NN_REGRESSOR_H_
#define FACECAP_NN_REGRESSOR_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace facecap::nn {

struct RegressorOptions {
  int hidden = 256;                // width of each hidden layer
  int layers = 2;                  // hidden layers of each network
  float leaky_slope = 0.2f;        // slope of the leaky ReLUs below zero
  float learning_rate = 1e-3f;     // Adam step size
  float landmark_margin = 0.01f;   // delta of the landmark loss (landmarks in [0, 1])
  float landmark_weight = 0.01f;  // weight of the landmark loss against L_P + L_J + L_W
  float anchor_weight = 10.f;      // weight of phase 3's anchor term
  int seed = 1;                    // parameter initialization seed

  template <class V>
  void Visit(V&& v) {
    v("hidden", hidden, "width of each hidden layer of P, J, W and L");
    v("layers", layers, "hidden layers of each network");
    v("leaky_slope", leaky_slope, "slope of the leaky ReLUs below zero");
    v("learning_rate", learning_rate, "Adam step size");
    v("landmark_margin", landmark_margin,
      "delta: a landmark within this distance of its target costs nothing (landmarks in [0, 1])");
    v("landmark_weight", landmark_weight, "weight of the landmark loss");
    v("anchor_weight", anchor_weight,
      "weight of phase 3's pull of P, J, W on the real frames toward their outputs before phase 3");
    v("net_seed", seed, "parameter initialization seed");
  }
  bool Check(std::string* why) const;
};

// Sizes of the code and of each output.
struct RegressorSizes {
  int code = 0;
  int pose = 2;         // pitch, yaw
  int jaw = 0;          // jaw controls
  int expression = 0;   // the other controls
  int landmarks = 136;  // 68 x (x, y)
};

// One example: its code, and each target in [0, 1] or null where unknown (a real frame has
// no pose or controls; an example without landmarks has no landmark term).
struct RegressorExample {
  const float* code = nullptr;
  const float* pose = nullptr;
  const float* jaw = nullptr;
  const float* expression = nullptr;
  const float* landmarks = nullptr;
  const float* anchor = nullptr;  // phase 3: P, J, W's earlier outputs [pose, jaw, expression]
};

class Regressor {
 public:
  enum class Phase { kPoseJawExpression = 1, kLandmarks = 2, kFineTune = 3 };
  static constexpr int kNumLosses = 4;  // L_P, L_J, L_W, L_L

  // InvalidInputError for bad options or sizes.
  Regressor(const RegressorOptions& options, const RegressorSizes& sizes);
  ~Regressor();
  Regressor(const Regressor&) = delete;
  Regressor& operator=(const Regressor&) = delete;

  const RegressorSizes& sizes() const;
  int64_t NumParameters() const;
  // Forward and backward of `phase`'s loss over `batch`, times loss_scale (1 / the global
  // batch size); the gradients replace Gradients() (zero for the networks the phase does not
  // train). losses: L_P, L_J, L_W, L_L summed over the batch, unscaled. An empty batch gives
  // zero gradients.
  void Backward(Phase phase, const std::vector<RegressorExample>& batch, float loss_scale,
                double losses[kNumLosses]);
  float* Gradients();
  // Adam on Gradients() for the networks `phase` trains; the others stay bitwise as they are.
  void OptimizerStep(Phase phase);
  // A fresh Adam for `phase`: the moments of the networks it trains zeroed and the step count
  // (of the bias correction) restarted. Called before a phase's first step.
  void StartPhase(Phase phase);

  // Parameters, the Adam moments and the step count (a checkpoint), and back; FileIOError
  // when the state does not fit.
  std::vector<float> State() const;
  void SetState(const std::vector<float>& state);
  uint64_t ParameterHash() const;

  // Predictions for `count` codes ([count, sizes().code]): pose [count, pose], jaw
  // [count, jaw], expression [count, expression], landmarks [count, landmarks]; null outputs
  // are skipped.
  void Predict(const float* codes, int count, float* pose, float* jaw, float* expression,
               float* landmarks) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::nn

#endif  // FACECAP_NN_REGRESSOR_H_
