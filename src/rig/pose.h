// Rigid head pose P_rigid (paper 000 Sec. 6 and 8): pitch p, yaw y, plus roll, translation and
// scale for real footage. x_camera = scale * R(pitch, yaw, roll) * x_head + translation, with
// R = Rz(roll) * Ry(yaw) * Rx(pitch). Positive yaw turns the face towards the head's left (+x),
// positive pitch tilts the face down (the nose moves towards -y).
#ifndef FACECAP_RIG_POSE_H_
#define FACECAP_RIG_POSE_H_

#include <Eigen/Core>

namespace facecap::rig {

struct RigidPose {
  float pitch = 0.f;  // rad, about +x
  float yaw = 0.f;    // rad, about +y
  float roll = 0.f;   // rad, about +z
  Eigen::Vector3f translation{0.f, 0.f, -60.f};  // cm, camera looks down -z
  float scale = 1.f;

  Eigen::Matrix3f Rotation() const;
  Eigen::Vector3f Apply(const Eigen::Vector3f& x) const;
};

// Rotation Rz(ez) * Ry(ey) * Rx(ex) from Euler angles (ex, ey, ez), radians.
Eigen::Matrix3f EulerToMatrix(const Eigen::Vector3f& euler_xyz);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_POSE_H_
