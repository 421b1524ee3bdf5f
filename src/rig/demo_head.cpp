// The demo head's public API (rig/demo_head.h): option checks, MakeDemoHead, which assembles
// the parts of demo_head_internal.h, and the identity sampling.
#include "rig/demo_head.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rig/demo_head_internal.h"

namespace facecap::rig {

using demo_head_internal::HeadBuilder;
using demo_head_internal::HeadParams;
using demo_head_internal::IdentityModeDef;
using demo_head_internal::IdentityModeDefs;
using demo_head_internal::JawPivot;
using demo_head_internal::Layout;
using demo_head_internal::MakeFacts;
using demo_head_internal::MakeJawWeights;
using demo_head_internal::MakeLandmarks;
using demo_head_internal::MakeLayout;
using demo_head_internal::MakeRegions;
using demo_head_internal::MakeTopology;
using demo_head_internal::MeshTopology;
using demo_head_internal::ShapeMaker;
using demo_head_internal::VertexFacts;

bool DemoHeadOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (resolution < 60 || resolution > 300) {
    return fail("resolution must be in [60, 300], got " + std::to_string(resolution));
  }
  if (num_identity_modes < 0 || num_identity_modes > MaxDemoIdentityModes()) {
    return fail("num_identity_modes must be in [0, " + std::to_string(MaxDemoIdentityModes()) +
                "], got " + std::to_string(num_identity_modes));
  }
  if (eyeball_segments < 8 || eyeball_segments > 64) {
    return fail("eyeball_segments must be in [8, 64], got " + std::to_string(eyeball_segments));
  }
  if (!(jaw_open_degrees > 0.f && jaw_open_degrees <= 40.f)) {
    return fail("jaw_open_degrees must be in (0, 40], got " + std::to_string(jaw_open_degrees));
  }
  if (!(eye_look_degrees > 0.f && eye_look_degrees <= 45.f)) {
    return fail("eye_look_degrees must be in (0, 45], got " + std::to_string(eye_look_degrees));
  }
  if (!(identity_mode_scale > 0.f && identity_mode_scale <= 3.f)) {
    return fail("identity_mode_scale must be in (0, 3], got " + std::to_string(identity_mode_scale));
  }
  return true;
}

int MaxDemoIdentityModes() { return static_cast<int>(IdentityModeDefs().size()); }

const std::vector<std::string>& DemoIdentityModeNames() {
  static const std::vector<std::string> kNames = [] {
    std::vector<std::string> names;
    for (const IdentityModeDef& def : IdentityModeDefs()) names.push_back(def.name);
    return names;
  }();
  return kNames;
}

Rig MakeDemoHead(const DemoHeadOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("DemoHeadOptions: " + why);
  const Layout layout = MakeLayout(options);
  const HeadParams mean;
  const HeadBuilder builder(mean, layout);

  Rig rig;
  rig.neutral = builder.BuildNeutral();
  MeshTopology topology = MakeTopology(builder, rig.neutral);
  rig.triangles = std::move(topology.triangles);
  rig.uvs = std::move(topology.uvs);
  rig.uv_triangles = std::move(topology.uv_triangles);
  rig.triangle_region = std::move(topology.triangle_region);
  rig.regions = MakeRegions();
  const std::vector<VertexFacts> facts = MakeFacts(layout);
  rig.jaw_pivot = JawPivot(builder.Surface());
  rig.jaw_weights = MakeJawWeights(builder.Surface(), layout, rig.neutral, facts);
  rig.landmarks = MakeLandmarks(builder, rig.neutral);
  rig.shapes = ShapeMaker(builder, rig.neutral, facts, rig.jaw_weights, options).MakeAll();

  // Identity modes: finite differences of the builder, one standard deviation per parameter.
  const std::vector<IdentityModeDef>& defs = IdentityModeDefs();
  rig.identity_modes.assign(options.num_identity_modes, Vertices());
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < options.num_identity_modes; ++k) {
    HeadParams varied = mean;
    varied.*(defs[k].member) += options.identity_mode_scale * defs[k].std_dev;
    rig.identity_modes[k] = HeadBuilder(varied, layout).BuildNeutral() - rig.neutral;
  }
  return rig;
}

std::vector<float> DemoIdentityCoefficients(int identity_seed, int num_modes) {
  std::vector<float> alpha(std::max(0, num_modes), 0.f);
  if (identity_seed == 0) return alpha;
  std::mt19937 generator(static_cast<std::uint32_t>(identity_seed));
  for (int k = 0; k < num_modes; ++k) {
    // Box-Muller on two 32-bit draws; u1 in (0, 1] so the logarithm is finite.
    const double u1 = (static_cast<double>(generator()) + 1.0) / 4294967296.0;
    const double u2 = static_cast<double>(generator()) / 4294967296.0;
    const double normal = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
    alpha[k] = static_cast<float>(std::min(2.5, std::max(-2.5, normal)));
  }
  return alpha;
}

Rig WithIdentity(const Rig& rig, int identity_seed, float magnitude) {
  Rig out = rig;
  const std::vector<float> alpha =
      DemoIdentityCoefficients(identity_seed, static_cast<int>(rig.identity_modes.size()));
  for (size_t k = 0; k < alpha.size(); ++k) {
    if (alpha[k] != 0.f) out.neutral += (magnitude * alpha[k]) * rig.identity_modes[k];
  }
  return out;
}

}  // namespace facecap::rig
