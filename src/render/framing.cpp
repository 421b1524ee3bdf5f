#include "render/framing.h"

#include <algorithm>
#include <cmath>

namespace facecap::render {

namespace {
Eigen::Vector3f BoxCentre(const rig::Rig& rig) {
  return 0.5f * (rig.neutral.colwise().minCoeff() + rig.neutral.colwise().maxCoeff()).transpose();
}
}  // namespace

float FramingDistance(const rig::Rig& rig, const Camera& camera, float fill) {
  const Eigen::Vector3f lo = rig.neutral.colwise().minCoeff();
  const Eigen::Vector3f hi = rig.neutral.colwise().maxCoeff();
  const float extent = std::max(hi.y() - lo.y(), hi.x() - lo.x()) / std::max(1e-3f, fill);
  // Half the extent must span half the image height: extent/2 / d = (h/2) / fy.
  const float distance = 0.5f * extent * camera.fy / (0.5f * camera.height);
  return distance + 0.5f * (hi.z() - lo.z());
}

rig::RigidPose FramedPose(const rig::Rig& rig, float distance, float pitch, float yaw, float roll) {
  rig::RigidPose pose;
  pose.pitch = pitch;
  pose.yaw = yaw;
  pose.roll = roll;
  pose.translation = Eigen::Vector3f(0.f, 0.f, -distance) - pose.Rotation() * BoxCentre(rig);
  return pose;
}

}  // namespace facecap::render
