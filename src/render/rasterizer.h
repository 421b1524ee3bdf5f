// CPU z-buffer rasterizer: from posed camera-space triangles to a G-buffer of visible
// triangle, depth and perspective-correct barycentrics per pixel. Every other image of the
// render module (segmentation, U(I), depth, shaded) is a cheap pass over the G-buffer.
//
// Sampling: one sample at each pixel centre (x + 0.5, y + 0.5); edge functions are evaluated
// exactly in 24.8 fixed point with the top-left fill rule, so triangles that share an edge
// cover every pixel centre along it exactly once (no cracks, no double coverage).
// Visibility: nearest surface wins (largest 1 / depth); ties keep the lower triangle index.
#ifndef FACECAP_RENDER_RASTERIZER_H_
#define FACECAP_RENDER_RASTERIZER_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/rig.h"

namespace facecap::render {

struct RasterizeOptions {
  // Skip triangles whose front side (counter-clockwise seen from outside) faces away from
  // the camera. For closed meshes this changes nothing but speed; turn it off to see the
  // inside of open meshes (mouth bag, the back of a mask).
  bool cull_back_faces = true;
  // Triangles with a corner at depth (-z) below this are dropped whole (no clipping): the
  // renderer is meant for objects fully in front of the camera. Scene units.
  float near_depth = 1e-3f;
  // Threads for projection and rasterization (horizontal image bands; the result does not
  // depend on the count). 1 runs inline, <= 0 uses DefaultNumThreads(). Renders that are run
  // many at a time (synthetic samples) should stay at 1 and parallelize over renders.
  int num_threads = 1;
  // Fill GBuffer::barycentrics (perspective-correct, by intersecting each pixel's ray with its
  // triangle). Renders that need only triangle ids and depth (segmentation images, the soft
  // renderer's visibility) skip it; depth then comes from the interpolated 1 / depth, which
  // is exact for a planar triangle up to rounding.
  bool barycentrics = true;

  // False, with the reason in *why, when a field is out of range.
  bool Check(std::string* why) const;
};

// A screen-space vertex as the rasterizer sees it (workspace inside GBuffer).
struct ProjectedVertex {
  int32_t x_fixed = 0;        // u in 1/256 pixel
  int32_t y_fixed = 0;        // v in 1/256 pixel
  float inverse_depth = 0.f;  // 1 / (-z)
  bool usable = false;        // in front of the near plane and inside the guard band
};

// Per-pixel result of Rasterize, pixels in row-major order with y down (index y * width + x).
struct GBuffer {
  int width = 0;
  int height = 0;
  std::vector<float> depth;         // #pixels, -z of the visible surface; +inf where background
  std::vector<int32_t> triangle;    // #pixels, index of the visible triangle; -1 where background
  // 3 * #pixels, perspective-correct barycentric weights (b0, b1, b2) of the visible
  // triangle's corners in the order of its row in Triangles, exactly those of the point
  // where the ray through the pixel centre meets the triangle's plane: for any attribute a
  // that is linear over the triangle in 3D, a(pixel) = sum_i b_i a_i. They sum to 1; at
  // pixel centres on a triangle's edge a weight can dip a little below 0 (coverage is
  // decided on positions snapped to 1/256 pixel), never below -0.01. Zero where background.
  std::vector<float> barycentrics;

  // Workspace reused between renders: one entry per mesh vertex.
  std::vector<ProjectedVertex> projected;

  // Sets the size and allocates; keeps the buffers (no allocation) when the size matches.
  void Resize(int new_width, int new_height);
  int NumPixels() const { return width * height; }
  int PixelIndex(int x, int y) const { return y * width + x; }
  bool Covered(int x, int y) const { return triangle[PixelIndex(x, y)] >= 0; }
  // Number of pixels showing a triangle.
  int NumCovered() const;
};

// Rasterizes a triangle mesh already posed in camera space (see camera.h).
//
// Inputs:
//   camera_vertices  #V by 3 list of camera-space vertex positions (camera at the origin
//                    looking down -z, +y up)
//   triangles        #F by 3 list of vertex indices, counter-clockwise seen from outside
//   camera           intrinsics and image size
//   options          culling, near plane, threads
// Outputs:
//   gbuffer          resized to camera.width x camera.height (no allocation when it already
//                    has that size and as many projected entries as vertices), then filled
// Throws InvalidInputError for a triangle index out of range or bad options.
void Rasterize(const rig::Vertices& camera_vertices, const rig::Triangles& triangles,
               const Camera& camera, GBuffer* gbuffer,
               const RasterizeOptions& options = RasterizeOptions());

// Interpolates a per-vertex attribute at a covered pixel with the G-buffer's
// perspective-correct barycentrics.
//
// Inputs:
//   gbuffer      result of Rasterize
//   triangles    #F by 3 list of vertex indices (the ones rasterized)
//   attribute    #V by C list of per-vertex values (positions, normals, colours, ...)
//   pixel        pixel index (y * width + x) of a covered pixel
// Returns the C interpolated values.
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, 1, Derived::ColsAtCompileTime> InterpolateAtPixel(
    const GBuffer& gbuffer, const rig::Triangles& triangles,
    const Eigen::MatrixBase<Derived>& attribute, int pixel) {
  const int t = gbuffer.triangle[pixel];
  const float* b = &gbuffer.barycentrics[3 * static_cast<size_t>(pixel)];
  using Scalar = typename Derived::Scalar;
  return Scalar(b[0]) * attribute.row(triangles(t, 0)) +
         Scalar(b[1]) * attribute.row(triangles(t, 1)) +
         Scalar(b[2]) * attribute.row(triangles(t, 2));
}

}  // namespace facecap::render

#endif  // FACECAP_RENDER_RASTERIZER_H_
