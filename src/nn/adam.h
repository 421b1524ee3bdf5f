// Adam (Kingma and Ba) with bias correction and AdamW's decoupled weight decay on plain float
// arrays, in double arithmetic: the same summed gradients give bitwise the same parameters on
// every rank.
#ifndef FACECAP_NN_ADAM_H_
#define FACECAP_NN_ADAM_H_

#include <cmath>
#include <cstdint>

namespace facecap::nn {

struct AdamStep {
  double learning_rate = 1e-3;
  int64_t step = 1;      // 1-based count of steps taken, this one included
  double keep = 1.0;     // the parameters are multiplied by this first (1 - lr x weight decay)
  double beta1 = 0.9, beta2 = 0.999, epsilon = 1e-8;
};

// One step on n parameters with their gradients and first and second moments.
inline void AdamUpdate(const AdamStep& s, const float* gradient, float* parameter, float* first, float* second,
                       int64_t n) {
  const double correction1 = 1.0 - std::pow(s.beta1, static_cast<double>(s.step));
  const double correction2 = 1.0 - std::pow(s.beta2, static_cast<double>(s.step));
  for (int64_t i = 0; i < n; ++i) {
    const double g = gradient[i];
    first[i] = static_cast<float>(s.beta1 * first[i] + (1 - s.beta1) * g);
    second[i] = static_cast<float>(s.beta2 * second[i] + (1 - s.beta2) * g * g);
    const double mhat = first[i] / correction1, vhat = second[i] / correction2;
    parameter[i] = static_cast<float>(s.keep * parameter[i] - s.learning_rate * mhat / (std::sqrt(vhat) + s.epsilon));
  }
}

}  // namespace facecap::nn

#endif  // FACECAP_NN_ADAM_H_
