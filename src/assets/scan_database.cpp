#include "assets/scan_database.h"

#include <algorithm>
#include <cmath>

#include "rig/demo_head.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::assets {

bool ScanSynthOptions::Check(std::string* why) const {
  if (seed < 0) { *why = "seed must be >= 0"; return false; }
  if (!(identity_scale >= 0.f && identity_scale <= 3.f)) { *why = "identity_scale must be in [0, 3]"; return false; }
  if (!(personal_strength >= 0.f && personal_strength <= 3.f)) { *why = "personal_strength must be in [0, 3]"; return false; }
  if (!(personal_noise >= 0.f && personal_noise <= 0.5f)) { *why = "personal_noise must be in [0, 0.5]"; return false; }
  if (!(weight_jitter >= 0.f && weight_jitter <= 1.f)) { *why = "weight_jitter must be in [0, 1]"; return false; }
  if (unwanted_shapes < 0 || unwanted_shapes > 10) { *why = "unwanted_shapes must be in [0, 10]"; return false; }
  if (!(unwanted_max >= 0.f && unwanted_max <= 1.f)) { *why = "unwanted_max must be in [0, 1]"; return false; }
  if (!(vertex_noise_cm >= 0.f && vertex_noise_cm <= 1.f)) { *why = "vertex_noise_cm must be in [0, 1]"; return false; }
  return true;
}

ScanPerson SynthesizeScanPerson(const rig::Rig& rig, const LinearShapes& template_shapes,
                                const std::vector<int>& personal_vertices,
                                const Eigen::MatrixXf& facs, int person,
                                const ScanSynthOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("scan synthesis: " + why);
  const int V = template_shapes.NumVertices(), N = template_shapes.NumShapes();
  const int K = static_cast<int>(facs.rows());
  if (rig.NumVertices() != V || facs.cols() != N) {
    throw InvalidInputError("scan synthesis: rig, template and FACS table disagree in size");
  }
  ScanPerson out;
  out.identity_seed = options.seed * 100003 + person + 1;
  const int M = static_cast<int>(rig.identity_modes.size());
  const rig::Rig person_rig = rig::WithIdentity(rig, out.identity_seed, options.identity_scale);
  const rig::Vertices& neutral = person_rig.neutral;
  out.neutral = Eigen::Map<const Eigen::VectorXf>(neutral.data(), 3 * V);
  const std::vector<float> coefficients = rig::DemoIdentityCoefficients(out.identity_seed, M);

  // Per-shape global factors g_ij from fixed directions c_i (same for every person).
  Eigen::VectorXf global(N), personal(N);
  for (int i = 0; i < N; ++i) {
    Rng direction(static_cast<uint64_t>(options.seed) + 7777, static_cast<uint64_t>(i));
    double dot = 0;
    for (int m = 0; m < M; ++m) dot += direction.Normal() / std::sqrt(std::max(M, 1)) * coefficients[m] * options.identity_scale;
    global[i] = 1.f + 0.25f * static_cast<float>(std::tanh(dot));
    Rng noise(static_cast<uint64_t>(options.seed) * 31 + 1, static_cast<uint64_t>(person) * 4096 + i);
    personal[i] = static_cast<float>(options.personal_noise * noise.Normal());
  }
  out.global_factors = global;
  out.personal_factors = personal;
  const float s = options.personal_strength;
  out.true_deltas = template_shapes.deltas;
  for (int v : personal_vertices) {
    const Eigen::Vector3f d = (neutral.row(v) - template_shapes.neutral.row(v)).transpose();
    const float d_norm = d.norm();
    for (int i = 0; i < N; ++i) {
      const Eigen::Vector3f t = template_shapes.deltas.block<3, 1>(3 * v, i);
      const float t_norm = t.norm();
      if (t_norm <= 0.f) continue;
      const float local = 1.f + 0.35f * std::tanh(2.f * d.dot(t) / t_norm);
      Eigen::Vector3f bend = Eigen::Vector3f::Zero();
      if (d_norm > 1e-6f) bend = 0.3f * t_norm * std::tanh(d_norm / 0.5f) * d / d_norm;
      const Eigen::Vector3f personal_shape = global[i] * local * t + bend;
      out.true_deltas.block<3, 1>(3 * v, i) = (1.f + personal[i]) * (t + s * (personal_shape - t));
    }
  }
  // Scans with unwanted motion and noise.
  out.true_weights = facs;
  out.expressions.resize(3 * V, K);
  for (int k = 0; k < K; ++k) {
    Rng rng(static_cast<uint64_t>(options.seed) * 131 + 3, static_cast<uint64_t>(person) * 4096 + k);
    for (int i = 0; i < N; ++i) {
      if (facs(k, i) > 0.f) out.true_weights(k, i) = static_cast<float>(1.0 - options.weight_jitter * rng.Uniform());
    }
    for (int u = 0; u < options.unwanted_shapes; ++u) {
      const int i = static_cast<int>(rng.UniformInt(N));
      if (facs(k, i) > 0.f) continue;
      out.true_weights(k, i) = static_cast<float>(options.unwanted_max * rng.Uniform());
    }
    out.expressions.col(k) = out.neutral + out.true_deltas * out.true_weights.row(k).transpose();
    if (options.vertex_noise_cm > 0.f) {
      for (int r = 0; r < 3 * V; ++r) out.expressions(r, k) += static_cast<float>(options.vertex_noise_cm * rng.Normal());
    }
  }
  return out;
}

}  // namespace facecap::assets
