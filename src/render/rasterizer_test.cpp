#include "render/rasterizer.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "render/primitives.h"
#include "util/errors.h"

namespace facecap::render {
namespace {

// 128 x 128, f = 100 px, principal point at the image centre: the point (x, y, -1)
// projects to (64 + 100 x, 64 - 100 y), so screen positions are easy to place exactly.
Camera TestCamera() {
  Camera camera;
  camera.width = 128;
  camera.height = 128;
  camera.fx = camera.fy = 100.f;
  camera.cx = camera.cy = 64.f;
  return camera;
}

// The camera-space point at depth `depth` that projects to pixel position (u, v).
Eigen::RowVector3f PointAtPixel(const Camera& camera, float u, float v, float depth) {
  return (depth * camera.RayDirection(u, v)).transpose();
}

// Twice the signed area of a screen triangle.
double SignedArea2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

rig::Triangles OneTriangle(int a, int b, int c) {
  rig::Triangles triangles(1, 3);
  triangles << a, b, c;
  return triangles;
}

// Counter-clockwise in camera space is clockwise on the y-down screen: the front-facing
// corner order for screen points listed clockwise on screen (y down).
TEST(RasterizerTest, SingleTriangleCoverageMatchesAnalyticArea) {
  const Camera camera = TestCamera();
  // Screen corners, listed so that the camera-space triangle is counter-clockwise.
  const Eigen::Vector2d screen[3] = {{20.3, 100.7}, {110.2, 90.1}, {50.6, 15.4}};
  rig::Vertices vertices(3, 3);
  const float depths[3] = {3.f, 5.f, 8.f};  // slanted: depth varies across the triangle
  for (int k = 0; k < 3; ++k) {
    vertices.row(k) = PointAtPixel(camera, screen[k].x(), screen[k].y(), depths[k]);
  }
  ASSERT_LT(SignedArea2(screen[0], screen[1], screen[2]), 0.0) << "not front-facing";
  GBuffer gbuffer;
  Rasterize(vertices, OneTriangle(0, 1, 2), camera, &gbuffer);

  // Pixel centres strictly inside (by more than 0.01 px) must be covered, strictly outside
  // must not; the covered count matches the analytic area.
  int covered = 0, disagreements = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector2d centre(x + 0.5, y + 0.5);
      double min_distance = 1e9;
      bool inside = true;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector2d& a = screen[k];
        const Eigen::Vector2d& b = screen[(k + 1) % 3];
        // Interior is on the negative side for this clockwise-on-screen order.
        const double distance = -SignedArea2(a, b, centre) / (b - a).norm();
        inside = inside && distance > 0.0;
        min_distance = std::min(min_distance, std::fabs(distance));
      }
      const bool is_covered = gbuffer.Covered(x, y);
      covered += is_covered;
      if (min_distance > 0.01 && inside != is_covered) ++disagreements;
    }
  }
  EXPECT_EQ(disagreements, 0);
  const double area = 0.5 * std::fabs(SignedArea2(screen[0], screen[1], screen[2]));
  EXPECT_NEAR(covered, area, 0.01 * area);
  EXPECT_EQ(gbuffer.NumCovered(), covered);
}

TEST(RasterizerTest, PixelAlignedQuadCoversExactlyItsPixelsOnce) {
  // Square with corners on pixel centres (32.5 .. 96.5): the top-left rule keeps the left
  // and top edges and leaves the right and bottom ones, so exactly 64 x 64 pixels, and the
  // shared diagonal through pixel centres goes to exactly one of the two triangles.
  const Camera camera = TestCamera();
  rig::Vertices vertices(4, 3);
  vertices.row(0) = PointAtPixel(camera, 32.5f, 32.5f, 2.f);  // top left
  vertices.row(1) = PointAtPixel(camera, 32.5f, 96.5f, 2.f);  // bottom left
  vertices.row(2) = PointAtPixel(camera, 96.5f, 96.5f, 2.f);  // bottom right
  vertices.row(3) = PointAtPixel(camera, 96.5f, 32.5f, 2.f);  // top right
  rig::Triangles quad(2, 3);
  quad << 0, 1, 2,  // counter-clockwise in camera space (y up)
      0, 2, 3;
  GBuffer both;
  Rasterize(vertices, quad, camera, &both);
  EXPECT_EQ(both.NumCovered(), 64 * 64);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const bool inside = x >= 32 && x < 96 && y >= 32 && y < 96;
      ASSERT_EQ(both.Covered(x, y), inside) << x << "," << y;
    }
  }
  // Each triangle alone: no pixel covered by both.
  GBuffer first, second;
  Rasterize(vertices, OneTriangle(0, 1, 2), camera, &first);
  Rasterize(vertices, OneTriangle(0, 2, 3), camera, &second);
  int overlap = 0;
  for (int i = 0; i < both.NumPixels(); ++i) {
    overlap += (first.triangle[i] >= 0) && (second.triangle[i] >= 0);
  }
  EXPECT_EQ(overlap, 0);
  EXPECT_EQ(first.NumCovered() + second.NumCovered(), 64 * 64);
}

TEST(RasterizerTest, TriangleFanIsWatertight) {
  // A fan of 24 triangles around a pixel centre, edges in all directions: every pixel of
  // the union is covered by exactly one triangle.
  const Camera camera = TestCamera();
  constexpr int kSegments = 24;
  rig::Vertices vertices(kSegments + 1, 3);
  vertices.row(0) = PointAtPixel(camera, 64.5f, 64.5f, 4.f);
  for (int i = 0; i < kSegments; ++i) {
    const float angle = 2.f * static_cast<float>(M_PI) * i / kSegments;
    // Counter-clockwise in camera space is increasing angle with y up: v decreasing.
    vertices.row(i + 1) = PointAtPixel(camera, 64.5f + 50.f * std::cos(angle),
                                       64.5f - 40.f * std::sin(angle), 4.f + 0.1f * i);
  }
  rig::Triangles fan(kSegments, 3);
  for (int i = 0; i < kSegments; ++i) fan.row(i) << 0, 1 + i, 1 + (i + 1) % kSegments;
  GBuffer whole;
  Rasterize(vertices, fan, camera, &whole);
  std::vector<int> cover_count(whole.NumPixels(), 0);
  GBuffer single;
  for (int i = 0; i < kSegments; ++i) {
    Rasterize(vertices, fan.row(i), camera, &single);
    for (int p = 0; p < single.NumPixels(); ++p) cover_count[p] += single.triangle[p] >= 0;
  }
  for (int p = 0; p < whole.NumPixels(); ++p) {
    ASSERT_LE(cover_count[p], 1) << "pixel " << p << " covered twice";
    ASSERT_EQ(cover_count[p] == 1, whole.triangle[p] >= 0) << "pixel " << p;
  }
}

TEST(RasterizerTest, SphereSilhouetteMatchesAnalyticDisc) {
  const Camera camera = TestCamera();
  const float radius = 1.f, distance = 4.f;
  rig::Vertices unit;
  rig::Triangles triangles;
  Icosphere(5, &unit, &triangles);
  rig::Vertices vertices = radius * unit;
  vertices.col(2).array() -= distance;
  GBuffer gbuffer;
  Rasterize(vertices, triangles, camera, &gbuffer);
  // A sphere seen from distance d projects to a disc of radius f r / sqrt(d^2 - r^2).
  const double disc_radius = camera.fx * radius / std::sqrt(distance * distance - radius * radius);
  const double disc_area = M_PI * disc_radius * disc_radius;
  EXPECT_NEAR(gbuffer.NumCovered(), disc_area, 0.01 * disc_area);

  // Without culling the result is the same (the front surface wins the z-test).
  GBuffer unculled;
  RasterizeOptions options;
  options.cull_back_faces = false;
  Rasterize(vertices, triangles, camera, &unculled, options);
  EXPECT_EQ(unculled.triangle, gbuffer.triangle);
}

TEST(RasterizerTest, PerspectiveCorrectBarycentricsInterpolateLinearAttributesExactly) {
  const Camera camera = TestCamera();
  // A strongly slanted triangle (depth 1.5 .. 12): affine screen-space interpolation would
  // be off by many percent here.
  rig::Vertices vertices(3, 3);
  vertices.row(0) = PointAtPixel(camera, 10.f, 110.f, 1.5f);
  vertices.row(1) = PointAtPixel(camera, 120.f, 100.f, 12.f);
  vertices.row(2) = PointAtPixel(camera, 60.f, 8.f, 4.f);
  const rig::Triangles triangles = OneTriangle(0, 1, 2);
  GBuffer gbuffer;
  Rasterize(vertices, triangles, camera, &gbuffer);
  ASSERT_GT(gbuffer.NumCovered(), 2000);

  const Eigen::Vector3d p0 = vertices.row(0).transpose().cast<double>();
  const Eigen::Vector3d normal = (vertices.row(1) - vertices.row(0))
                                     .transpose()
                                     .cast<double>()
                                     .cross((vertices.row(2) - vertices.row(0)).transpose().cast<double>());
  double max_position_error = 0.0, max_pixel_error = 0.0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      if (!gbuffer.Covered(x, y)) continue;
      const int pixel = gbuffer.PixelIndex(x, y);
      // Camera-space position is linear in 3D: its interpolation is the ray's hit point.
      const Eigen::Vector3f interpolated =
          InterpolateAtPixel(gbuffer, triangles, vertices, pixel).transpose();
      const Eigen::Vector3d ray = camera.RayDirection(x + 0.5f, y + 0.5f).cast<double>();
      const double hit_depth = normal.dot(p0) / normal.dot(ray);  // ray(d) = d * ray
      const Eigen::Vector3d hit = hit_depth * ray;
      max_position_error =
          std::max(max_position_error, (interpolated.cast<double>() - hit).norm());
      EXPECT_NEAR(gbuffer.depth[pixel], hit_depth, 1e-4 * hit_depth);
      EXPECT_NEAR(-interpolated.z(), gbuffer.depth[pixel], 1e-4 * hit_depth);
      // Re-projected, the interpolated point lands on the pixel centre.
      const Eigen::Vector3f projected = camera.Project(interpolated);
      max_pixel_error = std::max<double>(
          max_pixel_error,
          (projected.head<2>() - Eigen::Vector2f(x + 0.5f, y + 0.5f)).norm());
    }
  }
  EXPECT_LT(max_position_error, 1e-4);
  EXPECT_LT(max_pixel_error, 1e-3);
}

TEST(RasterizerTest, DepthTestKeepsTheNearerTriangleInEitherOrder) {
  const Camera camera = TestCamera();
  rig::Vertices vertices(6, 3);
  // Two overlapping front-facing triangles, far one listed first then near one.
  vertices.row(0) = PointAtPixel(camera, 10.f, 100.f, 10.f);
  vertices.row(1) = PointAtPixel(camera, 100.f, 100.f, 10.f);
  vertices.row(2) = PointAtPixel(camera, 55.f, 10.f, 10.f);
  vertices.row(3) = PointAtPixel(camera, 30.f, 110.f, 5.f);
  vertices.row(4) = PointAtPixel(camera, 120.f, 110.f, 5.f);
  vertices.row(5) = PointAtPixel(camera, 75.f, 20.f, 5.f);
  for (const bool near_first : {false, true}) {
    rig::Triangles triangles(2, 3);
    if (near_first) {
      triangles << 3, 4, 5, 0, 1, 2;
    } else {
      triangles << 0, 1, 2, 3, 4, 5;
    }
    const int near_index = near_first ? 0 : 1;
    GBuffer gbuffer;
    Rasterize(vertices, triangles, camera, &gbuffer);
    // (64, 70) is inside both.
    const int pixel = gbuffer.PixelIndex(64, 70);
    EXPECT_EQ(gbuffer.triangle[pixel], near_index) << "near_first " << near_first;
    EXPECT_NEAR(gbuffer.depth[pixel], 5.f, 1e-4f);
    // (20, 95) is inside the far triangle only.
    EXPECT_EQ(gbuffer.triangle[gbuffer.PixelIndex(20, 95)], 1 - near_index);
    EXPECT_NEAR(gbuffer.depth[gbuffer.PixelIndex(20, 95)], 10.f, 1e-4f);
  }
}

TEST(RasterizerTest, BackFacesAreCulledOnlyWhenAsked) {
  const Camera camera = TestCamera();
  rig::Vertices vertices(3, 3);
  vertices.row(0) = PointAtPixel(camera, 20.f, 100.f, 3.f);
  vertices.row(1) = PointAtPixel(camera, 100.f, 100.f, 3.f);
  vertices.row(2) = PointAtPixel(camera, 60.f, 20.f, 3.f);
  GBuffer gbuffer;
  Rasterize(vertices, OneTriangle(0, 1, 2), camera, &gbuffer);
  const int front_count = gbuffer.NumCovered();
  EXPECT_GT(front_count, 0);
  Rasterize(vertices, OneTriangle(0, 2, 1), camera, &gbuffer);  // seen from behind
  EXPECT_EQ(gbuffer.NumCovered(), 0);
  RasterizeOptions options;
  options.cull_back_faces = false;
  Rasterize(vertices, OneTriangle(0, 2, 1), camera, &gbuffer, options);
  EXPECT_EQ(gbuffer.NumCovered(), front_count);
  // Barycentrics still refer to the corners in their listed order.
  const int pixel = gbuffer.PixelIndex(60, 80);
  ASSERT_EQ(gbuffer.triangle[pixel], 0);
  const Eigen::Vector3f position =
      InterpolateAtPixel(gbuffer, OneTriangle(0, 2, 1), vertices, pixel).transpose();
  EXPECT_NEAR((camera.Project(position).head<2>() - Eigen::Vector2f(60.5f, 80.5f)).norm(), 0.f,
              1e-3f);
}

TEST(RasterizerTest, TrianglesBehindOrAcrossTheNearPlaneAreRejected) {
  const Camera camera = TestCamera();
  rig::Vertices vertices(3, 3);
  vertices << -1.f, -1.f, -3.f,  //
      1.f, -1.f, -3.f,           //
      0.f, 1.f, 2.f;             // behind the camera
  GBuffer gbuffer;
  Rasterize(vertices, OneTriangle(0, 1, 2), camera, &gbuffer);
  EXPECT_EQ(gbuffer.NumCovered(), 0);
  vertices.col(2).setConstant(3.f);  // entirely behind
  Rasterize(vertices, OneTriangle(0, 1, 2), camera, &gbuffer);
  EXPECT_EQ(gbuffer.NumCovered(), 0);
  for (int i = 0; i < gbuffer.NumPixels(); ++i) {
    ASSERT_TRUE(std::isinf(gbuffer.depth[i]));
    ASSERT_EQ(gbuffer.triangle[i], -1);
  }
}

TEST(RasterizerTest, ReusesBuffersWhenSizesMatch) {
  const Camera camera = TestCamera();
  rig::Vertices unit;
  rig::Triangles triangles;
  Icosphere(3, &unit, &triangles);
  rig::Vertices vertices = unit;
  vertices.col(2).array() -= 4.f;
  GBuffer gbuffer;
  Rasterize(vertices, triangles, camera, &gbuffer);
  const float* depth = gbuffer.depth.data();
  const int32_t* triangle = gbuffer.triangle.data();
  const float* barycentrics = gbuffer.barycentrics.data();
  const ProjectedVertex* projected = gbuffer.projected.data();
  vertices.col(0).array() += 0.3f;
  Rasterize(vertices, triangles, camera, &gbuffer);
  EXPECT_EQ(gbuffer.depth.data(), depth);
  EXPECT_EQ(gbuffer.triangle.data(), triangle);
  EXPECT_EQ(gbuffer.barycentrics.data(), barycentrics);
  EXPECT_EQ(gbuffer.projected.data(), projected);
}

TEST(RasterizerTest, ThreadCountDoesNotChangeTheResult) {
  Camera camera = TestCamera();
  camera.width = 200;
  camera.height = 150;
  rig::Vertices unit;
  rig::Triangles triangles;
  Icosphere(4, &unit, &triangles);
  rig::Vertices vertices = unit;
  vertices.col(2).array() -= 3.f;
  GBuffer serial, parallel;
  Rasterize(vertices, triangles, camera, &serial);
  RasterizeOptions options;
  options.num_threads = 3;
  Rasterize(vertices, triangles, camera, &parallel, options);
  EXPECT_EQ(serial.triangle, parallel.triangle);
  EXPECT_EQ(serial.depth, parallel.depth);
  EXPECT_EQ(serial.barycentrics, parallel.barycentrics);
}

TEST(RasterizerTest, DepthWithoutBarycentricsMatchesTheRayIntersection) {
  const Camera camera = TestCamera();
  rig::Vertices unit;
  rig::Triangles triangles;
  Icosphere(4, &unit, &triangles);
  rig::Vertices vertices = unit;
  vertices.col(0).array() += 0.3f;  // off-centre and tilted: depth varies across triangles
  vertices.col(2) = vertices.col(2) * 1.5f - Eigen::VectorXf::Constant(vertices.rows(), 3.f);
  GBuffer full, fast;
  Rasterize(vertices, triangles, camera, &full);
  RasterizeOptions options;
  options.barycentrics = false;
  Rasterize(vertices, triangles, camera, &fast, options);
  EXPECT_EQ(full.triangle, fast.triangle);
  int covered = 0;
  for (size_t p = 0; p < full.depth.size(); ++p) {
    if (full.triangle[p] < 0) {
      EXPECT_TRUE(std::isinf(fast.depth[p]));
      continue;
    }
    ++covered;
    // The interpolated 1 / depth sees the corners snapped to 1/256 pixel, the ray
    // intersection the exact triangle: they agree to ~1e-3 of the depth on this mesh.
    EXPECT_NEAR(fast.depth[p], full.depth[p], 1e-3f * full.depth[p]) << "pixel " << p;
  }
  EXPECT_GT(covered, 1000);
}

TEST(RasterizerTest, RejectsBadInput) {
  const Camera camera = TestCamera();
  rig::Vertices vertices = rig::Vertices::Zero(3, 3);
  GBuffer gbuffer;
  EXPECT_THROW(Rasterize(vertices, OneTriangle(0, 1, 3), camera, &gbuffer), InvalidInputError);
  RasterizeOptions options;
  options.near_depth = 0.f;
  EXPECT_THROW(Rasterize(vertices, OneTriangle(0, 1, 2), camera, &gbuffer, options),
               InvalidInputError);
  Camera no_focal = camera;
  no_focal.fx = 0.f;
  EXPECT_THROW(Rasterize(vertices, OneTriangle(0, 1, 2), no_focal, &gbuffer), InvalidInputError);
}

TEST(CameraTest, FromFovProjectsTheFieldOfViewEdgesToTheImageBorder) {
  const Camera camera = Camera::FromFov(160, 120, 60.f);
  const float half_fov = 30.f * static_cast<float>(M_PI) / 180.f;
  const Eigen::Vector3f top = camera.Project(Eigen::Vector3f(0.f, std::tan(half_fov), -1.f));
  EXPECT_NEAR(top.x(), 80.f, 1e-4f);
  EXPECT_NEAR(top.y(), 0.f, 1e-3f);
  EXPECT_NEAR(top.z(), 1.f, 1e-6f);
  const Eigen::Vector3f point(0.3f, -0.2f, -2.5f);
  const Eigen::Vector3f projected = camera.Project(point);
  const Eigen::Vector3f back = projected.z() * camera.RayDirection(projected.x(), projected.y());
  EXPECT_LT((back - point).norm(), 1e-5f);
}

}  // namespace
}  // namespace facecap::render
