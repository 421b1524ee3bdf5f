// A person's rig from a generic rig and the person's neutral: the neutral replaced, every
// shape moved onto the person by deformation transfer (its de-skinned delta D_i transferred,
// the jaw angles and translations kept), the jaw pivot moved with the vertices around it;
// regions, UVs, landmarks, jaw weights and identity modes carried over.
#ifndef FACECAP_ASSETS_PERSON_RIG_H_
#define FACECAP_ASSETS_PERSON_RIG_H_

#include "rig/rig.h"

namespace facecap::assets {

// `neutral`: #V by 3, the person's neutral in the generic rig's topology. InvalidInputError
// when the vertex count differs.
rig::Rig PersonRig(const rig::Rig& generic, const rig::Vertices& neutral);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_PERSON_RIG_H_
