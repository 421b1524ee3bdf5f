#include "render/camera.h"

#include <cmath>

namespace facecap::render {

Camera Camera::FromFov(int width, int height, float fov_y_deg) {
  Camera camera;
  camera.width = width;
  camera.height = height;
  const float half_fov_rad = 0.5f * fov_y_deg * static_cast<float>(M_PI) / 180.f;
  // Square pixels: the same focal length on both axes.
  camera.fy = 0.5f * static_cast<float>(height) / std::tan(half_fov_rad);
  camera.fx = camera.fy;
  camera.cx = 0.5f * static_cast<float>(width);
  camera.cy = 0.5f * static_cast<float>(height);
  return camera;
}

Eigen::Vector3f Camera::Project(const Eigen::Vector3f& p) const {
  const float depth = -p.z();
  return Eigen::Vector3f(cx + fx * p.x() / depth, cy - fy * p.y() / depth, depth);
}

Eigen::Vector3f Camera::RayDirection(float u, float v) const {
  return Eigen::Vector3f((u - cx) / fx, -(v - cy) / fy, -1.f);
}

}  // namespace facecap::render
