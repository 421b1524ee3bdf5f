// Controlled geometry error: a rig whose neutral is displaced by a smooth random field, to
// measure how a stage degrades when the person's geometry is off by a known amount.
#ifndef FACECAP_RIG_PERTURB_H_
#define FACECAP_RIG_PERTURB_H_

#include <cstdint>

#include "rig/rig.h"

namespace facecap::rig {

struct PerturbOptions {
  double rms_cm = 0.3;         // RMS displacement over the vertices (cm; 0.3 is 3 mm)
  double wavelength_cm = 2.;   // spatial scale of the field: Gaussian bumps of this sigma
  int bumps = 48;              // number of bumps, centred on vertices drawn at random
  uint64_t seed = 1;           // the field is a function of the seed alone
};

// The field: sum over bumps of a random 3D vector times exp(-|x - c|^2 / (2 sigma^2)), scaled
// so that its RMS over the neutral's vertices is rms_cm. Nearby vertices (an eyelid and its
// eyeball) move alike, so the mesh stays a plausible head. Shapes are offsets and follow the
// neutral; landmarks, UVs and regions are kept. InvalidInputError for an empty rig, rms_cm
// below 0, wavelength_cm not above 0 or bumps below 1.
Rig PerturbNeutral(const Rig& rig, const PerturbOptions& options);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_PERTURB_H_
