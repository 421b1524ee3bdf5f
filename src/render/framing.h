// Camera placement that frames a rig's head in the image.
#ifndef FACECAP_RENDER_FRAMING_H_
#define FACECAP_RENDER_FRAMING_H_

#include "render/camera.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::render {

// The part of the head that framing centres and sizes: the bounding box of the 68 landmarks
// (brows to chin, ear to ear along the jaw) when the rig has them, else of the whole neutral.
// Framing the landmarks gives face crops like those of aligned real footage.
//
// Distance (cm) from the camera at which that box, scaled by 1 / `fill` (fill 1: the larger
// of its width and height spans the image height), fits the camera's vertical field of view.
float FramingDistance(const rig::Rig& rig, const Camera& camera, float fill = 0.7f);

// A pose with the given angles (rad) that puts the centre of the framed box on the optical
// axis at `distance` cm.
rig::RigidPose FramedPose(const rig::Rig& rig, float distance, float pitch, float yaw,
                          float roll = 0.f);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_FRAMING_H_
