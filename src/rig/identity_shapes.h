// A rig whose identity modes are blendshapes: the person's head and expression in one weight
// vector, for solvers and renderers that vary the identity per frame or per sample.
#ifndef FACECAP_RIG_IDENTITY_SHAPES_H_
#define FACECAP_RIG_IDENTITY_SHAPES_H_

#include "rig/rig.h"

namespace facecap::rig {

// `rig` with its identity modes appended as shapes named identity_0, identity_1, ... (dense
// deltas, no jaw part): weights [w, alpha] evaluate the head N(alpha) with the expression w.
Rig WithIdentityShapes(const Rig& rig);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_IDENTITY_SHAPES_H_
