// Comparing meshes of one topology: the error of an estimated shape against the truth.
#ifndef FACECAP_RIG_COMPARE_H_
#define FACECAP_RIG_COMPARE_H_

#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::rig {

// Root mean square vertex distance (in the meshes' units) after the similarity (rotation,
// translation, uniform scale; Umeyama 1991) that maps `estimate` best onto `truth`, so that
// neither the pose nor the size of the estimate counts, only its shape. Both #V by 3.
double SimilarityAlignedRms(const Vertices& estimate, const Vertices& truth);

// The 3D distance between the outer eye corners (iBUG landmarks 36 and 45) of `vertices`,
// the normaliser of face errors; 0 when the rig has no 68 landmarks.
double InterOcularDistance(const Rig& rig, const Vertices& vertices);

// The angle of the rotation between two poses' rotations, in degrees (the pose error).
double RotationAngleDeg(const RigidPose& a, const RigidPose& b);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_COMPARE_H_
