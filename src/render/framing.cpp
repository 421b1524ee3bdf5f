#include "render/framing.h"

#include <algorithm>
#include <cmath>

namespace facecap::render {

namespace {

void FramedBox(const rig::Rig& rig, Eigen::Vector3f* lo, Eigen::Vector3f* hi) {
  if (rig.landmarks.size() > 0) {
    *lo = Eigen::Vector3f::Constant(1e30f);
    *hi = Eigen::Vector3f::Constant(-1e30f);
    for (int i = 0; i < rig.landmarks.size(); ++i) {
      const Eigen::Vector3f p = rig.neutral.row(rig.landmarks[i]).transpose();
      *lo = lo->cwiseMin(p);
      *hi = hi->cwiseMax(p);
    }
    return;
  }
  *lo = rig.neutral.colwise().minCoeff().transpose();
  *hi = rig.neutral.colwise().maxCoeff().transpose();
}

Eigen::Vector3f BoxCentre(const rig::Rig& rig) {
  Eigen::Vector3f lo, hi;
  FramedBox(rig, &lo, &hi);
  return 0.5f * (lo + hi);
}

}  // namespace

float FramingDistance(const rig::Rig& rig, const Camera& camera, float fill) {
  Eigen::Vector3f lo, hi;
  FramedBox(rig, &lo, &hi);
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
