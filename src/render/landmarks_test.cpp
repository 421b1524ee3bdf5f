#include "render/landmarks.h"

#include <gtest/gtest.h>

#include "render/primitives.h"
#include "render/rasterizer.h"
#include "util/errors.h"

namespace facecap::render {
namespace {

TEST(LandmarksTest, FrontLandmarksAreVisibleAndBackLandmarksHidden) {
  // IcosphereRig's landmarks: front pole, back pole, upper front (45 degrees up).
  const rig::Rig rig = IcosphereRig(4, 1.f, 4);
  rig::Vertices camera_vertices = rig.neutral;
  camera_vertices.col(2).array() -= 5.f;
  const Camera camera = Camera::FromFov(96, 96, 40.f);
  GBuffer gbuffer;
  Rasterize(camera_vertices, rig.triangles, camera, &gbuffer);
  std::vector<Landmark2D> landmarks;
  ProjectLandmarks(camera_vertices, rig.triangles, rig.landmarks, camera, gbuffer, &landmarks);
  ASSERT_EQ(landmarks.size(), 3u);
  const Landmark2D& front = landmarks[0];
  const Landmark2D& back = landmarks[1];
  const Landmark2D& upper_front = landmarks[2];
  EXPECT_TRUE(front.inside_image);
  EXPECT_TRUE(front.visible);
  EXPECT_NEAR(front.position.x(), 48.f, 0.5f);
  EXPECT_NEAR(front.position.y(), 48.f, 0.5f);
  EXPECT_NEAR(front.depth, 4.f, 1e-3f);
  // The back pole projects onto the same pixel but lies behind the front surface.
  EXPECT_TRUE(back.inside_image);
  EXPECT_FALSE(back.visible);
  EXPECT_NEAR(back.depth, 6.f, 1e-3f);
  EXPECT_TRUE(upper_front.inside_image);
  EXPECT_TRUE(upper_front.visible);
  EXPECT_LT(upper_front.position.y(), 40.f);  // above the centre (y down)
}

TEST(LandmarksTest, AnOccluderHidesALandmarkAndOutOfImageLandmarksAreFlagged) {
  const rig::Rig rig = IcosphereRig(3, 1.f, 1);
  rig::Vertices camera_vertices = rig.neutral;
  camera_vertices.col(2).array() -= 5.f;
  // A small square in front of the front pole.
  rig::Vertices scene(camera_vertices.rows() + 4, 3);
  scene.topRows(camera_vertices.rows()) = camera_vertices;
  const int first = static_cast<int>(camera_vertices.rows());
  scene.bottomRows(4) << -0.2f, -0.2f, -3.f, 0.2f, -0.2f, -3.f, 0.2f, 0.2f, -3.f, -0.2f, 0.2f,
      -3.f;
  rig::Triangles triangles(rig.triangles.rows() + 2, 3);
  triangles.topRows(rig.triangles.rows()) = rig.triangles;
  triangles.bottomRows(2) << first, first + 1, first + 2, first, first + 2, first + 3;
  const Camera camera = Camera::FromFov(96, 96, 40.f);
  GBuffer gbuffer;
  Rasterize(scene, triangles, camera, &gbuffer);
  std::vector<Landmark2D> landmarks;
  ProjectLandmarks(scene, triangles, rig.landmarks, camera, gbuffer, &landmarks);
  EXPECT_FALSE(landmarks[0].visible);  // front pole behind the square
  EXPECT_TRUE(landmarks[2].visible);   // upper front not behind the square

  // Shift the sphere out of the field of view.
  rig::Vertices shifted = camera_vertices;
  shifted.col(0).array() += 20.f;
  Rasterize(shifted, rig.triangles, camera, &gbuffer);
  ProjectLandmarks(shifted, rig.triangles, rig.landmarks, camera, gbuffer, &landmarks);
  for (const Landmark2D& landmark : landmarks) {
    EXPECT_TRUE(landmark.in_front);
    EXPECT_FALSE(landmark.inside_image);
    EXPECT_FALSE(landmark.visible);
  }

  Eigen::VectorXi bad(1);
  bad << static_cast<int>(shifted.rows());
  EXPECT_THROW(ProjectLandmarks(shifted, rig.triangles, bad, camera, gbuffer, &landmarks),
               InvalidInputError);
}

}  // namespace
}  // namespace facecap::render
