#include "render/primitives.h"

#include <cmath>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace facecap::render {
namespace {

TEST(PrimitivesTest, IcosphereIsAClosedOutwardOrientedUnitSphere) {
  for (int subdivisions : {0, 1, 3}) {
    rig::Vertices vertices;
    rig::Triangles triangles;
    Icosphere(subdivisions, &vertices, &triangles);
    const int expected_triangles = 20 * (1 << (2 * subdivisions));
    EXPECT_EQ(triangles.rows(), expected_triangles);
    EXPECT_EQ(vertices.rows(), expected_triangles / 2 + 2);  // Euler: V - E + F = 2
    double area = 0.0;
    for (int t = 0; t < triangles.rows(); ++t) {
      const Eigen::Vector3f p0 = vertices.row(triangles(t, 0));
      const Eigen::Vector3f p1 = vertices.row(triangles(t, 1));
      const Eigen::Vector3f p2 = vertices.row(triangles(t, 2));
      const Eigen::Vector3f normal = (p1 - p0).cross(p2 - p0);
      ASSERT_GT(normal.dot(p0 + p1 + p2), 0.f) << "triangle " << t << " faces inwards";
      area += 0.5 * normal.norm();
    }
    for (int i = 0; i < vertices.rows(); ++i) {
      ASSERT_NEAR(vertices.row(i).norm(), 1.f, 1e-5f);
    }
    if (subdivisions == 3) {
      EXPECT_NEAR(area, 4.0 * M_PI, 0.02 * 4.0 * M_PI);
    }
  }
}

TEST(PrimitivesTest, IcosphereRigHasConsistentAttributes) {
  const rig::Rig rig = IcosphereRig(2, 3.f, 5);
  const int num_triangles = static_cast<int>(rig.triangles.rows());
  EXPECT_NEAR(rig.neutral.row(0).norm(), 3.f, 1e-5f);
  EXPECT_EQ(rig.uv_triangles.rows(), num_triangles);
  EXPECT_EQ(rig.triangle_region.size(), num_triangles);
  EXPECT_EQ(rig.regions.size(), 5u);
  EXPECT_GE(rig.triangle_region.minCoeff(), 0);
  EXPECT_LT(rig.triangle_region.maxCoeff(), 5);
  EXPECT_GE(rig.uv_triangles.minCoeff(), 0);
  EXPECT_LT(rig.uv_triangles.maxCoeff(), rig.uvs.rows());
  // No UV triangle wraps around the seam: away from the poles each spans less than half
  // the u range.
  for (int t = 0; t < num_triangles; ++t) {
    float low = 1e9f, high = -1e9f;
    bool near_pole = false;
    for (int k = 0; k < 3; ++k) {
      near_pole = near_pole || std::fabs(rig.neutral(rig.triangles(t, k), 1)) > 0.9f * 3.f;
      low = std::min(low, rig.uvs(rig.uv_triangles(t, k), 0));
      high = std::max(high, rig.uvs(rig.uv_triangles(t, k), 0));
    }
    if (!near_pole) {
      ASSERT_LT(high - low, 0.5f) << "triangle " << t;
    }
  }
  ASSERT_EQ(rig.landmarks.size(), 3);
  EXPECT_GT(rig.neutral(rig.landmarks[0], 2), 2.9f);
  EXPECT_LT(rig.neutral(rig.landmarks[1], 2), -2.9f);
  EXPECT_NEAR(rig.neutral(rig.landmarks[2], 1), 3.f * std::sqrt(0.5f), 0.3f);
  EXPECT_NEAR(rig.neutral(rig.landmarks[2], 2), 3.f * std::sqrt(0.5f), 0.3f);
}

}  // namespace
}  // namespace facecap::render
