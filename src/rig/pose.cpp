#include "rig/pose.h"

#include <cmath>

namespace facecap::rig {

Eigen::Matrix3f EulerToMatrix(const Eigen::Vector3f& euler_xyz) {
  const float cx = std::cos(euler_xyz.x()), sx = std::sin(euler_xyz.x());
  const float cy = std::cos(euler_xyz.y()), sy = std::sin(euler_xyz.y());
  const float cz = std::cos(euler_xyz.z()), sz = std::sin(euler_xyz.z());
  // Rz(ez) * Ry(ey) * Rx(ex), written out.
  Eigen::Matrix3f r;
  r << cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
       sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
       -sy,     cy * sx,                cy * cx;
  return r;
}

Eigen::Matrix3f RigidPose::Rotation() const {
  return EulerToMatrix(Eigen::Vector3f(pitch, yaw, roll));
}

Eigen::Vector3f RigidPose::Apply(const Eigen::Vector3f& x) const {
  return scale * (Rotation() * x) + translation;
}

}  // namespace facecap::rig
