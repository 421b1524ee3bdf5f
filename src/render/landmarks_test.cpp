#include "render/landmarks.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "render/framing.h"
#include "render/primitives.h"
#include "render/rasterizer.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"
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

// The demo head's 68 landmarks (iBUG order: 0-16 the jaw line, 17-67 brows, nose, eyes and
// mouth) at frontal, yaw +-30 and pitch +-10 degrees: a visible landmark lands on a pixel of
// the head, and an inner one on a pixel of the face, not of the hair, the neck or the
// background.
TEST(LandmarksTest, DemoHeadLandmarksProjectInsideTheFace) {
  rig::DemoHeadOptions head_options;
  head_options.num_identity_modes = 0;
  const rig::Rig rig = rig::MakeDemoHead(head_options);
  ASSERT_EQ(rig.landmarks.size(), 68);
  auto region_index = [&](const std::string& name) {
    for (size_t r = 0; r < rig.regions.size(); ++r) {
      if (rig.regions[r].name == name) return static_cast<int>(r);
    }
    ADD_FAILURE() << "the demo head has no region " << name;
    return -1;
  };
  const int hair = region_index("hair"), neck = region_index("neck");
  constexpr int kFirstInner = 17;
  const float deg = static_cast<float>(M_PI / 180.0);
  const Camera camera = Camera::FromFov(256, 256, 20.f);
  const float distance = FramingDistance(rig, camera, 0.55f);

  struct View {
    float pitch_deg, yaw_deg;
    int min_visible_inner;  // of the 51 inner landmarks
  };
  for (const View& view : {View{0.f, 0.f, 51}, View{0.f, 30.f, 46}, View{0.f, -30.f, 46},
                           View{10.f, 0.f, 51}, View{-10.f, 0.f, 51}}) {
    SCOPED_TRACE("pitch " + std::to_string(view.pitch_deg) + ", yaw " +
                 std::to_string(view.yaw_deg));
    const rig::RigidPose pose =
        FramedPose(rig, distance, view.pitch_deg * deg, view.yaw_deg * deg);
    rig::Vertices posed;
    rig::EvaluatePosed(rig, pose, Eigen::VectorXf::Zero(rig.NumShapes()), &posed);
    GBuffer gbuffer;
    Rasterize(posed, rig.triangles, camera, &gbuffer);
    std::vector<Landmark2D> landmarks;
    ProjectLandmarks(posed, rig.triangles, rig.landmarks, camera, gbuffer, &landmarks);
    ASSERT_EQ(landmarks.size(), 68u);

    int visible_inner = 0;
    for (int i = 0; i < 68; ++i) {
      const Landmark2D& l = landmarks[i];
      if (!l.visible) continue;
      const int x = static_cast<int>(std::floor(l.position.x()));
      const int y = static_cast<int>(std::floor(l.position.y()));
      ASSERT_TRUE(x >= 0 && x < gbuffer.width && y >= 0 && y < gbuffer.height) << "landmark " << i;
      if (i < kFirstInner) {
        // The jaw line is the silhouette at a turned head: a covered pixel within the
        // visibility search radius (1 pixel) of the landmark.
        bool covered = false;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int px = std::clamp(x + dx, 0, gbuffer.width - 1);
            const int py = std::clamp(y + dy, 0, gbuffer.height - 1);
            covered = covered || gbuffer.Covered(px, py);
          }
        }
        EXPECT_TRUE(covered) << "jaw landmark " << i << " at " << l.position.transpose();
        continue;
      }
      ++visible_inner;
      const int triangle = gbuffer.triangle[gbuffer.PixelIndex(x, y)];
      ASSERT_GE(triangle, 0) << "landmark " << i << " at " << l.position.transpose()
                             << " is on the background";
      const int region = rig.triangle_region[triangle];
      EXPECT_TRUE(region != hair && region != neck)
          << "landmark " << i << " at " << l.position.transpose() << " is on "
          << rig.regions[region].name;
    }
    EXPECT_GE(visible_inner, view.min_visible_inner);
  }
}

}  // namespace
}  // namespace facecap::render
