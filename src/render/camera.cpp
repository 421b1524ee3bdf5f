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

CropView CameraOfCrop(const Camera& source, const Eigen::Matrix<float, 2, 3>& crop_transform,
                      int crop_size, int out_size) {
  const Eigen::Matrix2f a = crop_transform.leftCols<2>();
  const Eigen::Vector2f t = crop_transform.col(2);
  const float scale = std::sqrt(std::abs(a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)));
  const float theta = std::atan2(a(1, 0), a(0, 0));
  // Source and crop pixel centres sit at i + 0.5 in camera coordinates and at i in the
  // transform's: q + 0.5 = A (p + 0.5 - 0.5) + t + 0.5.
  const Eigen::Vector2f half(0.5f, 0.5f);
  const Eigen::Vector2f centre = a * (Eigen::Vector2f(source.cx, source.cy) - half) + t + half;
  const float k = static_cast<float>(out_size) / static_cast<float>(crop_size);
  CropView view;
  view.camera.width = out_size;
  view.camera.height = out_size;
  view.camera.fx = k * scale * source.fx;
  view.camera.fy = k * scale * source.fy;
  view.camera.cx = k * centre.x();
  view.camera.cy = k * centre.y();
  // Image y points down and camera y up: a turn by theta in the image is one by -theta about
  // the camera's +z.
  view.roll = -theta;
  return view;
}

}  // namespace facecap::render
