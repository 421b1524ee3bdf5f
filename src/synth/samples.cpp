#include "synth/samples.h"

#include <algorithm>
#include <cmath>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {

namespace {
constexpr double kDegToRad = M_PI / 180.0;
}

bool SampleOptions::Check(std::string* why) const {
  if (count <= 0) { *why = "count must be positive, got " + std::to_string(count); return false; }
  if (size < 16 || size > 4096) { *why = "size must be in [16, 4096]"; return false; }
  if (!(fov_deg > 1.f && fov_deg < 120.f)) { *why = "fov_deg must be in (1, 120)"; return false; }
  if (!(fill > 0.1f && fill <= 2.f)) { *why = "fill must be in (0.1, 2]"; return false; }
  if (!(pitch_limit_deg >= 0.f && pitch_limit_deg <= 60.f)) {
    *why = "pitch_limit_deg must be in [0, 60]";
    return false;
  }
  if (!(yaw_limit_deg >= 0.f && yaw_limit_deg <= 90.f)) {
    *why = "yaw_limit_deg must be in [0, 90]";
    return false;
  }
  if (!(pitch_sigma_deg >= 0.f) || !(yaw_sigma_deg >= 0.f)) {
    *why = "pitch_sigma_deg and yaw_sigma_deg must be >= 0";
    return false;
  }
  if (!(identity_sigma >= 0.f && identity_sigma <= 3.f)) {
    *why = "identity_sigma must be in [0, 3]";
    return false;
  }
  if (sparsity_groups.size() != sparsity_max_active.size()) {
    *why = "sparsity_groups has " + std::to_string(sparsity_groups.size()) +
           " entries but sparsity_max_active has " + std::to_string(sparsity_max_active.size());
    return false;
  }
  for (size_t g = 0; g < sparsity_groups.size(); ++g) {
    if (sparsity_groups[g].empty()) { *why = "sparsity_groups has an empty prefix"; return false; }
    if (sparsity_max_active[g] < 0) {
      *why = "sparsity_max_active for '" + sparsity_groups[g] + "' is negative";
      return false;
    }
  }
  return true;
}

Sparsity ResolveSparsity(const rig::Rig& rig, const SampleOptions& options) {
  Sparsity s;
  s.group_shapes.resize(options.sparsity_groups.size());
  s.max_active = options.sparsity_max_active;
  for (int i = 0; i < rig.NumShapes(); ++i) {
    const std::string& name = rig.shapes[i].name;
    bool grouped = false;
    for (size_t g = 0; g < options.sparsity_groups.size() && !grouped; ++g) {
      if (name.rfind(options.sparsity_groups[g], 0) == 0) {
        s.group_shapes[g].push_back(i);
        grouped = true;
      }
    }
    if (!grouped) s.ungrouped.push_back(i);
  }
  for (size_t g = 0; g < s.group_shapes.size(); ++g) {
    if (s.group_shapes[g].empty()) {
      throw InvalidInputError("sparsity group '" + options.sparsity_groups[g] +
                              "' matches no shape of the rig (shape names start with e.g. '" +
                              (rig.shapes.empty() ? std::string("?") : rig.shapes[0].name) + "')");
    }
  }
  int total = 0;
  for (int m : s.max_active) total += m;
  if (total == 0) {
    throw InvalidInputError("sparsity limits allow no active shape in any sample "
                            "(every sparsity_max_active is 0)");
  }
  return s;
}

SampleParams DrawSample(const Sparsity& sparsity, const SampleOptions& options, int num_shapes,
                        int64_t index, int num_identity_modes) {
  Rng rng(static_cast<uint64_t>(options.seed), static_cast<uint64_t>(index));
  SampleParams p;
  p.pitch = static_cast<float>(kDegToRad * rng.TruncatedNormal(0.0, options.pitch_sigma_deg,
                                                               -options.pitch_limit_deg,
                                                               options.pitch_limit_deg));
  p.yaw = static_cast<float>(kDegToRad * rng.TruncatedNormal(0.0, options.yaw_sigma_deg,
                                                             -options.yaw_limit_deg,
                                                             options.yaw_limit_deg));
  p.weights = Eigen::VectorXf::Zero(num_shapes);
  for (size_t g = 0; g < sparsity.group_shapes.size(); ++g) {
    std::vector<int> shapes = sparsity.group_shapes[g];
    const int limit = std::min<int>(sparsity.max_active[g], static_cast<int>(shapes.size()));
    const int active = static_cast<int>(rng.UniformInt(limit + 1));
    // Partial Fisher-Yates: the first `active` entries are a uniform random subset.
    for (int k = 0; k < active; ++k) {
      const int j = k + static_cast<int>(rng.UniformInt(static_cast<int64_t>(shapes.size()) - k));
      std::swap(shapes[k], shapes[j]);
      p.weights[shapes[k]] = static_cast<float>(rng.Uniform());
    }
  }
  if (options.identity_sigma > 0.f && num_identity_modes > 0) {
    const double sigma = options.identity_sigma;
    p.identity.resize(num_identity_modes);
    for (int k = 0; k < num_identity_modes; ++k) {
      p.identity[k] = static_cast<float>(rng.TruncatedNormal(0.0, sigma, -2.5 * sigma, 2.5 * sigma));
    }
  }
  return p;
}

render::Camera SampleCamera(const SampleOptions& options) {
  return render::Camera::FromFov(options.size, options.size, options.fov_deg);
}

}  // namespace facecap::synth
