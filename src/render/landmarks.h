// 2D landmarks of a posed mesh with visibility from the z-buffer.
#ifndef FACECAP_RENDER_LANDMARKS_H_
#define FACECAP_RENDER_LANDMARKS_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "render/rasterizer.h"
#include "rig/rig.h"

namespace facecap::render {

struct LandmarkVisibilityOptions {
  // A landmark is visible when some G-buffer pixel within search_radius_pixels of its
  // projection (Chebyshev distance) shows either a triangle that has the landmark vertex as
  // a corner, or a surface whose depth differs from the landmark's by at most
  // relative_depth_tolerance * landmark depth. The radius lets silhouette landmarks (jaw
  // line) whose projection falls a hair outside the covered pixels count as visible.
  int search_radius_pixels = 1;
  float relative_depth_tolerance = 0.01f;

  // False, with the reason in *why, when a field is out of range.
  bool Check(std::string* why) const;
};

struct Landmark2D {
  Eigen::Vector2f position = Eigen::Vector2f::Zero();  // (u, v) in pixels, y down
  float depth = 0.f;                                   // -z of the landmark vertex
  bool in_front = false;  // depth above the rasterizer's near plane: position is meaningful
  bool inside_image = false;  // 0 <= u < width and 0 <= v < height
  bool visible = false;       // in front, inside the image and not hidden (see options)
};

// Projects landmark vertices and decides their visibility against a G-buffer of the same
// mesh and camera.
//
// Inputs:
//   camera_vertices   #V by 3 posed camera-space positions (as rasterized)
//   triangles         #F by 3 list of vertex indices (as rasterized)
//   landmark_vertices #L list of vertex indices (e.g. Rig::landmarks, 68 in iBUG order)
//   camera            the camera used by Rasterize
//   gbuffer           result of Rasterize(camera_vertices, triangles, camera, ...)
//   options           visibility tolerances
// Outputs:
//   landmarks         #L projected landmarks (resized to #L)
// Throws InvalidInputError for a landmark index out of range or a G-buffer of another size.
void ProjectLandmarks(const rig::Vertices& camera_vertices, const rig::Triangles& triangles,
                      const Eigen::VectorXi& landmark_vertices, const Camera& camera,
                      const GBuffer& gbuffer, std::vector<Landmark2D>* landmarks,
                      const LandmarkVisibilityOptions& options = LandmarkVisibilityOptions());

}  // namespace facecap::render

#endif  // FACECAP_RENDER_LANDMARKS_H_
