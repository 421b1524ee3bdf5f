// Camera placement that frames a rig's head in the image.
#ifndef FACECAP_RENDER_FRAMING_H_
#define FACECAP_RENDER_FRAMING_H_

#include "render/camera.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::render {

// Distance (cm) from the camera at which the neutral head's bounding box, scaled by
// `fill` (1: the larger of its width and height spans the image height), fits the camera's
// vertical field of view.
float FramingDistance(const rig::Rig& rig, const Camera& camera, float fill = 0.86f);

// A pose with the given angles (rad) that puts the centre of the neutral's bounding box on the
// optical axis at `distance` cm.
rig::RigidPose FramedPose(const rig::Rig& rig, float distance, float pitch, float yaw,
                          float roll = 0.f);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_FRAMING_H_
