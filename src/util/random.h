// A small counter-based random generator whose stream depends only on (seed, stream index),
// never on the thread, rank or call order that reaches it: sample i of a dataset draws from
// Rng(seed, i), so a dataset is the same whatever the number of ranks. Distributions are
// written out here (not std::*_distribution, whose results differ between standard libraries).
#ifndef FACECAP_UTIL_RANDOM_H_
#define FACECAP_UTIL_RANDOM_H_

#include <cmath>
#include <cstdint>

namespace facecap {

class Rng {
 public:
  Rng(uint64_t seed, uint64_t stream) : state_(Mix(seed * 0x9E3779B97F4A7C15ull + Mix(stream))) {}

  // SplitMix64 step.
  uint64_t NextU64() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    return Mix(z);
  }
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(NextU64() >> 11) * (1.0 / 9007199254740992.0); }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [0, n).
  int64_t UniformInt(int64_t n) { return static_cast<int64_t>(Uniform() * static_cast<double>(n)); }
  // Standard normal (Box-Muller, one value per call).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  // Normal(mean, sigma) truncated to [lo, hi] by rejection (falls back to uniform after 64
  // rejections, which only happens for a range far in the tail).
  double TruncatedNormal(double mean, double sigma, double lo, double hi) {
    if (sigma <= 0) return std::fmin(hi, std::fmax(lo, mean));
    for (int i = 0; i < 64; ++i) {
      const double x = mean + sigma * Normal();
      if (x >= lo && x <= hi) return x;
    }
    return Uniform(lo, hi);
  }

 private:
  static uint64_t Mix(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  uint64_t state_;
};

}  // namespace facecap

#endif  // FACECAP_UTIL_RANDOM_H_
