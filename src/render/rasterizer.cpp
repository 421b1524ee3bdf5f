#include "render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Geometry>

#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::render {
namespace {

constexpr int kSubpixelBits = 8;                       // 24.8 fixed point
constexpr int kSubpixelScale = 1 << kSubpixelBits;     // 256 units per pixel
constexpr int kHalfPixel = kSubpixelScale / 2;         // offset of a pixel centre
// Projected coordinates beyond +-2^20 pixels are not representable without overflow of the
// 64-bit edge functions; triangles reaching that far are dropped (they only occur for
// corners a hair in front of the near plane).
constexpr float kGuardBandPixels = static_cast<float>(1 << 20);
// Barycentric weights below -kMaxBarycentricOvershoot are clamped (see ResolveRows).
constexpr float kMaxBarycentricOvershoot = 0.01f;

// Floor and ceiling of a / 256 for possibly negative a.
inline int FloorDivSubpixel(int64_t a) { return static_cast<int>(a >> kSubpixelBits); }
inline int CeilDivSubpixel(int64_t a) {
  return static_cast<int>((a + kSubpixelScale - 1) >> kSubpixelBits);
}

// Fills gbuffer->projected from camera-space vertices (u, v snapped to 1/256 pixel).
void ProjectVertices(const rig::Vertices& vertices, const Camera& camera, float near_depth,
                     int num_threads, std::vector<ProjectedVertex>* projected) {
  const int num_vertices = static_cast<int>(vertices.rows());
  const float scaled_fx = camera.fx * kSubpixelScale;
  const float scaled_fy = camera.fy * kSubpixelScale;
  const float scaled_cx = camera.cx * kSubpixelScale;
  const float scaled_cy = camera.cy * kSubpixelScale;
  const float guard = kGuardBandPixels * kSubpixelScale;
  auto project_range = [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      ProjectedVertex& p = (*projected)[i];
      const float depth = -vertices(i, 2);
      p.usable = false;
      if (!(depth >= near_depth) || !std::isfinite(depth)) continue;
      const float inverse_depth = 1.f / depth;
      // u = cx + fx x / depth, v = cy - fy y / depth (camera.h), in 1/256 pixel.
      const float u = scaled_cx + scaled_fx * vertices(i, 0) * inverse_depth;
      const float v = scaled_cy - scaled_fy * vertices(i, 1) * inverse_depth;
      if (!(std::fabs(u) < guard && std::fabs(v) < guard)) continue;  // also rejects NaN
      p.x_fixed = static_cast<int32_t>(std::lrint(u));
      p.y_fixed = static_cast<int32_t>(std::lrint(v));
      p.inverse_depth = inverse_depth;
      p.usable = true;
    }
  };
  constexpr int kChunk = 4096;
  const int num_chunks = (num_vertices + kChunk - 1) / kChunk;
  if (num_threads == 1 || num_chunks <= 1) {
    project_range(0, num_vertices);
  } else {
    ParallelFor(0, num_chunks, num_threads, [&](int chunk) {
      project_range(chunk * kChunk, std::min(num_vertices, (chunk + 1) * kChunk));
    });
  }
}

// Edge function E_ab(p) = (b - a) x (p - a) in fixed point; positive inside a triangle whose
// signed area (b - a) x (c - a) is positive (clockwise on the y-down screen).
struct Edge {
  int64_t step_x;   // change of E per pixel to the right
  int64_t step_y;   // change of E per pixel down
  int64_t value;    // E at the first pixel centre of the bounding box, fill-rule bias included
};

inline Edge SetupEdge(const ProjectedVertex& a, const ProjectedVertex& b, int64_t first_x,
                      int64_t first_y) {
  const int64_t dx = static_cast<int64_t>(b.x_fixed) - a.x_fixed;
  const int64_t dy = static_cast<int64_t>(b.y_fixed) - a.y_fixed;
  Edge edge;
  edge.step_x = -dy * kSubpixelScale;
  edge.step_y = dx * kSubpixelScale;
  edge.value = dx * (first_y - a.y_fixed) - dy * (first_x - a.x_fixed);
  // Top-left rule (y down, interior where E > 0): a left edge has the interior at larger x
  // (dy < 0), a top edge is horizontal with the interior below it (dy == 0, dx > 0). Pixel
  // centres exactly on other edges are left to the neighbouring triangle.
  const bool top_left = dy < 0 || (dy == 0 && dx > 0);
  if (!top_left) edge.value -= 1;
  return edge;
}

// Rasterizes every triangle into the rows [row_begin, row_end): writes the visible
// triangle and its 1 / depth into gbuffer->depth (final depth comes in ResolveRows).
void RasterizeRows(const rig::Triangles& triangles, bool cull_back_faces, int row_begin,
                   int row_end, GBuffer* gbuffer) {
  const int width = gbuffer->width;
  const ProjectedVertex* projected = gbuffer->projected.data();
  float* inverse_depth_buffer = gbuffer->depth.data();
  int32_t* triangle_buffer = gbuffer->triangle.data();
  const int num_triangles = static_cast<int>(triangles.rows());
  const int* corners = triangles.data();  // row-major #F x 3

  for (int t = 0; t < num_triangles; ++t) {
    const ProjectedVertex* a = &projected[corners[3 * t + 0]];
    const ProjectedVertex* b = &projected[corners[3 * t + 1]];
    const ProjectedVertex* c = &projected[corners[3 * t + 2]];
    if (!(a->usable && b->usable && c->usable)) continue;

    // Bounding box of pixel centres first: most triangles of a dense mesh at low resolution
    // contain no pixel centre at all.
    const int32_t min_x = std::min({a->x_fixed, b->x_fixed, c->x_fixed});
    const int32_t max_x = std::max({a->x_fixed, b->x_fixed, c->x_fixed});
    const int32_t min_y = std::min({a->y_fixed, b->y_fixed, c->y_fixed});
    const int32_t max_y = std::max({a->y_fixed, b->y_fixed, c->y_fixed});
    const int x_begin = std::max(0, CeilDivSubpixel(int64_t{min_x} - kHalfPixel));
    const int x_last = std::min(width - 1, FloorDivSubpixel(int64_t{max_x} - kHalfPixel));
    const int y_begin = std::max(row_begin, CeilDivSubpixel(int64_t{min_y} - kHalfPixel));
    const int y_last = std::min(row_end - 1, FloorDivSubpixel(int64_t{max_y} - kHalfPixel));
    if (x_begin > x_last || y_begin > y_last) continue;

    // Twice the signed screen area; counter-clockwise in camera space (y up) is clockwise
    // on the y-down screen, i.e. a negative area for a front face.
    int64_t area2 =
        (int64_t{b->x_fixed} - a->x_fixed) * (int64_t{c->y_fixed} - a->y_fixed) -
        (int64_t{b->y_fixed} - a->y_fixed) * (int64_t{c->x_fixed} - a->x_fixed);
    if (area2 == 0) continue;
    if (area2 < 0) {
      std::swap(b, c);  // front face: reorder so that the interior has E > 0
      area2 = -area2;
    } else if (cull_back_faces) {
      continue;
    }

    const int64_t first_x = int64_t{x_begin} * kSubpixelScale + kHalfPixel;
    const int64_t first_y = int64_t{y_begin} * kSubpixelScale + kHalfPixel;
    // E_bc weighs corner a, E_ca corner b, E_ab corner c (screen-space barycentrics).
    Edge edge_a = SetupEdge(*b, *c, first_x, first_y);
    Edge edge_b = SetupEdge(*c, *a, first_x, first_y);
    Edge edge_c = SetupEdge(*a, *b, first_x, first_y);
    // 1 / depth is affine in screen space: sum_i lambda_i / depth_i.
    const float inverse_area2 = 1.f / static_cast<float>(area2);
    const float weight_a = a->inverse_depth * inverse_area2;
    const float weight_b = b->inverse_depth * inverse_area2;
    const float weight_c = c->inverse_depth * inverse_area2;

    for (int y = y_begin; y <= y_last; ++y) {
      int64_t e_a = edge_a.value, e_b = edge_b.value, e_c = edge_c.value;
      float* inverse_depth_row = inverse_depth_buffer + static_cast<size_t>(y) * width;
      int32_t* triangle_row = triangle_buffer + static_cast<size_t>(y) * width;
      for (int x = x_begin; x <= x_last; ++x) {
        if ((e_a | e_b | e_c) >= 0) {  // all three edge functions non-negative
          const float inverse_depth = static_cast<float>(e_a) * weight_a +
                                      static_cast<float>(e_b) * weight_b +
                                      static_cast<float>(e_c) * weight_c;
          if (inverse_depth > inverse_depth_row[x]) {
            inverse_depth_row[x] = inverse_depth;
            triangle_row[x] = t;
          }
        }
        e_a += edge_a.step_x;
        e_b += edge_b.step_x;
        e_c += edge_c.step_x;
      }
      edge_a.value += edge_a.step_y;
      edge_b.value += edge_b.step_y;
      edge_c.value += edge_c.step_y;
    }
  }
}

// Replaces 1 / depth by the exact depth and fills the perspective-correct barycentrics of
// the rows [row_begin, row_end), intersecting each pixel's ray with its triangle's plane.
void ResolveRows(const rig::Vertices& vertices, const rig::Triangles& triangles,
                 const Camera& camera, int row_begin, int row_end, GBuffer* gbuffer) {
  const int width = gbuffer->width;
  const float infinity = std::numeric_limits<float>::infinity();
  // Camera::RayDirection(u, v) = ((u - cx) / fx, -(v - cy) / fy, -1), split per row.
  const float ray_x_scale = 1.f / camera.fx;
  const float ray_x_offset = -camera.cx / camera.fx;
  for (int y = row_begin; y < row_end; ++y) {
    const float ray_y = -((y + 0.5f) - camera.cy) / camera.fy;
    for (int x = 0; x < width; ++x) {
      const int pixel = y * width + x;
      float* barycentric = &gbuffer->barycentrics[3 * static_cast<size_t>(pixel)];
      const int t = gbuffer->triangle[pixel];
      if (t < 0) {
        gbuffer->depth[pixel] = infinity;
        barycentric[0] = barycentric[1] = barycentric[2] = 0.f;
        continue;
      }
      // Intersect the ray from the camera centre through the pixel centre with the
      // triangle (Moller-Trumbore, origin 0): hit = p0 + b1 (p1 - p0) + b2 (p2 - p0). The
      // (b0, b1, b2) of the 3D hit point are the perspective-correct barycentrics. Single
      // precision suffices: for a 3 mm triangle 60 cm away the weights are good to ~1e-5.
      const Eigen::Vector3f ray(ray_x_scale * (x + 0.5f) + ray_x_offset, ray_y, -1.f);
      const Eigen::Vector3f p0 = vertices.row(triangles(t, 0)).transpose();
      const Eigen::Vector3f e1 = vertices.row(triangles(t, 1)).transpose() - p0;
      const Eigen::Vector3f e2 = vertices.row(triangles(t, 2)).transpose() - p0;
      const Eigen::Vector3f ray_cross_e2 = ray.cross(e2);
      const Eigen::Vector3f p0_cross_e1 = p0.cross(e1);
      const float inverse_determinant = 1.f / e1.dot(ray_cross_e2);
      float b1 = -p0.dot(ray_cross_e2) * inverse_determinant;
      float b2 = -ray.dot(p0_cross_e1) * inverse_determinant;
      if (!std::isfinite(b1) || !std::isfinite(b2)) b1 = b2 = 1.f / 3.f;  // seen edge-on
      float b0 = 1.f - b1 - b2;
      // Coverage is decided on the snapped screen positions, so a pixel centre on an edge
      // can lie a hair outside the exact triangle: its weights then dip slightly below 0
      // and the interpolated point stays exactly on the pixel's ray. Only clearly wrong
      // weights (near edge-on slivers) are clamped into the triangle.
      if (std::min({b0, b1, b2}) < -kMaxBarycentricOvershoot) {
        b0 = std::max(b0, 0.f);
        b1 = std::max(b1, 0.f);
        b2 = std::max(b2, 0.f);
        const float inverse_sum = 1.f / (b0 + b1 + b2);
        b0 *= inverse_sum;
        b1 *= inverse_sum;
        b2 *= inverse_sum;
      }
      barycentric[0] = b0;
      barycentric[1] = b1;
      barycentric[2] = b2;
      // depth = -z of the hit point p0 + b1 e1 + b2 e2.
      gbuffer->depth[pixel] = -(p0.z() + b1 * e1.z() + b2 * e2.z());
    }
  }
}

// Replaces 1 / depth by depth in the rows [row_begin, row_end); barycentrics are left as they
// are (RasterizeOptions::barycentrics false).
void ResolveDepthRows(int row_begin, int row_end, GBuffer* gbuffer) {
  const float infinity = std::numeric_limits<float>::infinity();
  const size_t begin = static_cast<size_t>(row_begin) * gbuffer->width;
  const size_t end = static_cast<size_t>(row_end) * gbuffer->width;
  for (size_t pixel = begin; pixel < end; ++pixel) {
    float& depth = gbuffer->depth[pixel];
    depth = gbuffer->triangle[pixel] < 0 ? infinity : 1.f / depth;
  }
}

}  // namespace

bool RasterizeOptions::Check(std::string* why) const {
  if (!(near_depth > 0.f) || !std::isfinite(near_depth)) {
    if (why) *why = "near_depth must be a positive finite number";
    return false;
  }
  return true;
}

void GBuffer::Resize(int new_width, int new_height) {
  width = new_width;
  height = new_height;
  const size_t num_pixels = static_cast<size_t>(new_width) * new_height;
  if (depth.size() != num_pixels) depth.resize(num_pixels);
  if (triangle.size() != num_pixels) triangle.resize(num_pixels);
  if (barycentrics.size() != 3 * num_pixels) barycentrics.resize(3 * num_pixels);
}

int GBuffer::NumCovered() const {
  return static_cast<int>(
      std::count_if(triangle.begin(), triangle.end(), [](int32_t t) { return t >= 0; }));
}

void Rasterize(const rig::Vertices& camera_vertices, const rig::Triangles& triangles,
               const Camera& camera, GBuffer* gbuffer, const RasterizeOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("Rasterize: " + why);
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0.f) || !(camera.fy > 0.f)) {
    std::ostringstream message;
    message << "Rasterize: camera needs a positive size and focal lengths, got "
            << camera.width << "x" << camera.height << " fx " << camera.fx << " fy "
            << camera.fy;
    throw InvalidInputError(message.str());
  }
  const int num_vertices = static_cast<int>(camera_vertices.rows());
  if (triangles.rows() > 0 &&
      (triangles.minCoeff() < 0 || triangles.maxCoeff() >= num_vertices)) {
    std::ostringstream message;
    message << "Rasterize: triangle corner indices must lie in [0, " << num_vertices
            << "), found [" << triangles.minCoeff() << ", " << triangles.maxCoeff() << "]";
    throw InvalidInputError(message.str());
  }

  gbuffer->Resize(camera.width, camera.height);
  if (gbuffer->projected.size() != static_cast<size_t>(num_vertices)) {
    gbuffer->projected.resize(num_vertices);
  }
  const int num_threads = options.num_threads > 0 ? options.num_threads : DefaultNumThreads();
  ProjectVertices(camera_vertices, camera, options.near_depth, num_threads,
                  &gbuffer->projected);

  // The depth buffer holds 1 / depth while rasterizing: 0 is "infinitely far".
  std::fill(gbuffer->depth.begin(), gbuffer->depth.end(), 0.f);
  std::fill(gbuffer->triangle.begin(), gbuffer->triangle.end(), -1);

  const int height = camera.height;
  const int num_bands = num_threads == 1 ? 1 : std::min(height, 4 * num_threads);
  auto band_rows = [&](int band, int* begin, int* end) {
    *begin = static_cast<int>(static_cast<int64_t>(height) * band / num_bands);
    *end = static_cast<int>(static_cast<int64_t>(height) * (band + 1) / num_bands);
  };
  ParallelFor(0, num_bands, num_threads, [&](int band) {
    int row_begin, row_end;
    band_rows(band, &row_begin, &row_end);
    RasterizeRows(triangles, options.cull_back_faces, row_begin, row_end, gbuffer);
    if (options.barycentrics) {
      ResolveRows(camera_vertices, triangles, camera, row_begin, row_end, gbuffer);
    } else {
      ResolveDepthRows(row_begin, row_end, gbuffer);
    }
  });
}

}  // namespace facecap::render
