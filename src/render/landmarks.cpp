#include "render/landmarks.h"

#include <algorithm>
#include <cmath>

#include "util/errors.h"

namespace facecap::render {

bool LandmarkVisibilityOptions::Check(std::string* why) const {
  if (search_radius_pixels < 0) {
    if (why) *why = "search_radius_pixels must be >= 0";
    return false;
  }
  if (!(relative_depth_tolerance >= 0.f)) {
    if (why) *why = "relative_depth_tolerance must be >= 0";
    return false;
  }
  return true;
}

void ProjectLandmarks(const rig::Vertices& camera_vertices, const rig::Triangles& triangles,
                      const Eigen::VectorXi& landmark_vertices, const Camera& camera,
                      const GBuffer& gbuffer, std::vector<Landmark2D>* landmarks,
                      const LandmarkVisibilityOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("ProjectLandmarks: " + why);
  if (gbuffer.width != camera.width || gbuffer.height != camera.height) {
    throw InvalidInputError("ProjectLandmarks: the G-buffer is not the camera's size");
  }
  const int num_vertices = static_cast<int>(camera_vertices.rows());
  const int num_landmarks = static_cast<int>(landmark_vertices.size());
  landmarks->resize(num_landmarks);
  for (int k = 0; k < num_landmarks; ++k) {
    const int vertex = landmark_vertices[k];
    if (vertex < 0 || vertex >= num_vertices) {
      throw InvalidInputError("ProjectLandmarks: landmark " + std::to_string(k) +
                              " names vertex " + std::to_string(vertex) + " of " +
                              std::to_string(num_vertices));
    }
    Landmark2D& landmark = (*landmarks)[k];
    landmark = Landmark2D();
    const Eigen::Vector3f point = camera_vertices.row(vertex).transpose();
    landmark.depth = -point.z();
    landmark.in_front = landmark.depth > 0.f && std::isfinite(landmark.depth);
    if (!landmark.in_front) continue;
    const Eigen::Vector3f projected = camera.Project(point);
    landmark.position = projected.head<2>();
    const int pixel_x = static_cast<int>(std::floor(projected.x()));
    const int pixel_y = static_cast<int>(std::floor(projected.y()));
    landmark.inside_image =
        pixel_x >= 0 && pixel_x < camera.width && pixel_y >= 0 && pixel_y < camera.height;
    if (!landmark.inside_image) continue;

    const float depth_tolerance = options.relative_depth_tolerance * landmark.depth;
    const int radius = options.search_radius_pixels;
    for (int y = std::max(0, pixel_y - radius);
         y <= std::min(camera.height - 1, pixel_y + radius) && !landmark.visible; ++y) {
      for (int x = std::max(0, pixel_x - radius);
           x <= std::min(camera.width - 1, pixel_x + radius); ++x) {
        const int pixel = gbuffer.PixelIndex(x, y);
        const int t = gbuffer.triangle[pixel];
        if (t < 0) continue;
        const bool own_triangle =
            triangles(t, 0) == vertex || triangles(t, 1) == vertex || triangles(t, 2) == vertex;
        if (own_triangle || std::fabs(gbuffer.depth[pixel] - landmark.depth) <= depth_tolerance) {
          landmark.visible = true;
          break;
        }
      }
    }
  }
}

}  // namespace facecap::render
