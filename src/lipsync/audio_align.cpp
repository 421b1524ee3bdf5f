#include "lipsync/audio_align.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "util/errors.h"

namespace facecap::lipsync {

std::vector<float> OnsetEnvelope(const std::vector<float>& samples, int rate,
                                 const AlignOptions& options) {
  const int hop = std::max(1, static_cast<int>(std::lround(options.hop_seconds * rate)));
  const int window = std::max(hop, static_cast<int>(std::lround(options.window_seconds * rate)));
  const int64_t n = static_cast<int64_t>(samples.size());
  if (n < window) return {};
  const int64_t frames = (n - window) / hop + 1;
  std::vector<double> log_energy(frames);
  for (int64_t f = 0; f < frames; ++f) {
    double e = 0.;
    for (int k = 0; k < window; ++k) {
      const double x = samples[f * hop + k];
      e += x * x;
    }
    log_energy[f] = std::log(1e-8 + e / window);
  }
  std::vector<float> out(frames, 0.f);
  for (int64_t f = 1; f < frames; ++f) {
    out[f] = static_cast<float>(std::max(0., log_energy[f] - log_energy[f - 1]));
  }
  double mean = 0., var = 0.;
  for (float x : out) mean += x;
  mean /= frames;
  for (float x : out) var += (x - mean) * (x - mean);
  const double sd = std::sqrt(var / frames) + 1e-12;
  for (float& x : out) x = static_cast<float>((x - mean) / sd);
  return out;
}

AlignResult EstimateOffset(const std::vector<float>& a, const std::vector<float>& b, int rate,
                           const AlignOptions& options) {
  const std::vector<float> ea = OnsetEnvelope(a, rate, options);
  const std::vector<float> eb = OnsetEnvelope(b, rate, options);
  if (ea.size() < 8 || eb.size() < 8) {
    throw InvalidInputError("audio alignment: a recording is shorter than " +
                            std::to_string(8 * options.hop_seconds + options.window_seconds) +
                            " s");
  }
  const int max_lag = static_cast<int>(std::ceil(options.max_offset_seconds / options.hop_seconds));
  // Normalized cross-correlation at lag L: b[i + L] against a[i] over the overlap.
  auto correlation = [&](int lag) {
    double sum = 0., saa = 0., sbb = 0.;
    const int na = static_cast<int>(ea.size()), nb = static_cast<int>(eb.size());
    for (int i = std::max(0, -lag); i < na && i + lag < nb; ++i) {
      sum += static_cast<double>(ea[i]) * eb[i + lag];
      saa += static_cast<double>(ea[i]) * ea[i];
      sbb += static_cast<double>(eb[i + lag]) * eb[i + lag];
    }
    return saa > 0 && sbb > 0 ? sum / std::sqrt(saa * sbb) : -1.;
  };
  int best = 0;
  double best_value = -2.;
  std::vector<double> values(2 * max_lag + 1);
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    values[lag + max_lag] = correlation(lag);
    if (values[lag + max_lag] > best_value) {
      best_value = values[lag + max_lag];
      best = lag;
    }
  }
  double refined = best;
  if (best > -max_lag && best < max_lag) {
    const double ym = values[best - 1 + max_lag], y0 = best_value, yp = values[best + 1 + max_lag];
    const double denominator = ym - 2 * y0 + yp;
    if (denominator < 0) refined += std::clamp(0.5 * (ym - yp) / denominator, -0.5, 0.5);
  }
  AlignResult r;
  r.offset_seconds = refined * options.hop_seconds;
  r.peak = best_value;
  return r;
}

std::vector<float> ResampleAudio(const std::vector<float>& samples, int from_rate, int to_rate) {
  if (from_rate <= 0 || to_rate <= 0) throw InvalidInputError("resampling: rates must be positive");
  if (from_rate == to_rate || samples.empty()) return samples;
  const double ratio = static_cast<double>(to_rate) / from_rate;
  const double cutoff = std::min(1.0, ratio);  // of the input's Nyquist frequency
  constexpr int kHalfWidth = 16;               // taps each side, in output-rate periods
  const double half = kHalfWidth / cutoff;
  const int64_t n_in = static_cast<int64_t>(samples.size());
  const int64_t n_out = static_cast<int64_t>(std::floor((n_in - 1) * ratio)) + 1;
  std::vector<float> out(n_out);
  for (int64_t i = 0; i < n_out; ++i) {
    const double x = i / ratio;
    const int64_t lo = std::max<int64_t>(0, static_cast<int64_t>(std::ceil(x - half)));
    const int64_t hi = std::min<int64_t>(n_in - 1, static_cast<int64_t>(std::floor(x + half)));
    double sum = 0., weights = 0.;
    for (int64_t k = lo; k <= hi; ++k) {
      const double d = (k - x) * cutoff;
      const double sinc = std::abs(d) < 1e-9 ? 1. : std::sin(M_PI * d) / (M_PI * d);
      const double window = 0.5 * (1. + std::cos(M_PI * (k - x) / half));  // Hann
      const double w = sinc * window;
      sum += w * samples[k];
      weights += w;
    }
    out[i] = static_cast<float>(weights != 0. ? sum / weights : 0.);
  }
  return out;
}

std::vector<char> SilentFrames(const std::vector<float>& samples, int rate, const std::vector<double>& times,
                               double silence_db, double margin_seconds) {
  const size_t n = times.size();
  std::vector<char> silent(n, 0);
  if (n == 0 || samples.empty() || rate <= 0) return silent;
  std::vector<double> steps;
  for (size_t i = 1; i < n; ++i) steps.push_back(times[i] - times[i - 1]);
  double step = 0.04;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    step = steps[steps.size() / 2];
  }
  const double duration = static_cast<double>(samples.size()) / rate;
  std::vector<double> rms(n, -1.);  // -1: outside the sound
  double loudest = 0.;
  for (size_t i = 0; i < n; ++i) {
    if (times[i] < 0. || times[i] > duration) continue;
    const auto a = static_cast<size_t>(std::max(0., (times[i] - 0.5 * step) * rate));
    const auto b = std::min(samples.size(), static_cast<size_t>(std::max(0., (times[i] + 0.5 * step) * rate)) + 1);
    double sum = 0.;
    for (size_t k = a; k < b; ++k) sum += static_cast<double>(samples[k]) * samples[k];
    rms[i] = b > a ? std::sqrt(sum / static_cast<double>(b - a)) : 0.;
    loudest = std::max(loudest, rms[i]);
  }
  if (!(loudest > 0.)) return silent;
  const double threshold = loudest * std::pow(10., silence_db / 20.);
  std::vector<double> loud_times;
  for (size_t i = 0; i < n; ++i) {
    if (rms[i] > threshold) loud_times.push_back(times[i]);
  }
  for (size_t i = 0; i < n; ++i) {
    if (rms[i] < 0. || rms[i] > threshold) continue;
    // The nearest louder frame, from the sorted loud times.
    const auto it = std::lower_bound(loud_times.begin(), loud_times.end(), times[i]);
    double nearest = std::numeric_limits<double>::infinity();
    if (it != loud_times.end()) nearest = std::min(nearest, *it - times[i]);
    if (it != loud_times.begin()) nearest = std::min(nearest, times[i] - *(it - 1));
    silent[i] = nearest >= margin_seconds;
  }
  return silent;
}

}  // namespace facecap::lipsync
