// Pinhole camera at the origin looking down -z, +y up in camera space, image y down.
//   u = cx + fx * x / (-z),  v = cy - fy * y / (-z),  depth = -z
#ifndef FACECAP_RENDER_CAMERA_H_
#define FACECAP_RENDER_CAMERA_H_

#include <Eigen/Core>

namespace facecap::render {

struct Camera {
  int width = 128;
  int height = 128;
  float fx = 0.f, fy = 0.f;  // focal lengths in pixels
  float cx = 0.f, cy = 0.f;  // principal point in pixels (pixel centres at i + 0.5)

  // A camera whose vertical field of view is fov_y_deg, principal point at the centre.
  static Camera FromFov(int width, int height, float fov_y_deg);
  // (u, v, depth) of a camera-space point; depth > 0 in front of the camera.
  Eigen::Vector3f Project(const Eigen::Vector3f& p) const;
  // Camera-space direction of the ray through image point (u, v), scaled to depth 1
  // (its z is -1), so that the point at depth d on that ray is d * RayDirection(u, v).
  Eigen::Vector3f RayDirection(float u, float v) const;
};

}  // namespace facecap::render

#endif  // FACECAP_RENDER_CAMERA_H_
