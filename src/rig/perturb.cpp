#include "rig/perturb.h"

#include <cmath>
#include <string>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::rig {

Rig PerturbNeutral(const Rig& rig, const PerturbOptions& o) {
  const int n = rig.NumVertices();
  if (n == 0) throw InvalidInputError("PerturbNeutral: the rig has no vertices");
  if (!(o.rms_cm >= 0.) || !(o.wavelength_cm > 0.) || o.bumps < 1) {
    throw InvalidInputError("PerturbNeutral: need rms_cm >= 0, wavelength_cm > 0 and bumps >= 1");
  }
  Vertices field = Vertices::Zero(n, 3);
  const double inv_two_sigma2 = 1. / (2. * o.wavelength_cm * o.wavelength_cm);
  for (int b = 0; b < o.bumps; ++b) {
    Rng rng(o.seed, static_cast<uint64_t>(b));
    const int centre = static_cast<int>(rng.UniformInt(n));
    const Eigen::Vector3f direction(static_cast<float>(rng.Normal()), static_cast<float>(rng.Normal()),
                                    static_cast<float>(rng.Normal()));
    for (int v = 0; v < n; ++v) {
      const double d2 = (rig.neutral.row(v) - rig.neutral.row(centre)).squaredNorm();
      field.row(v) += static_cast<float>(std::exp(-d2 * inv_two_sigma2)) * direction.transpose();
    }
  }
  const double rms = std::sqrt(field.squaredNorm() / n);
  Rig out = rig;
  if (rms > 0.) out.neutral += field * static_cast<float>(o.rms_cm / rms);
  return out;
}

}  // namespace facecap::rig
