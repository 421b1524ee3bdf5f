#include "render/gbuffer_images.h"

#include <cmath>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "render/primitives.h"
#include "render/rasterizer.h"
#include "util/errors.h"

namespace facecap::render {
namespace {

// An icosphere rig turned so that no symmetry axis faces the camera, 4 units away.
struct SphereScene {
  rig::Rig rig;
  rig::Vertices camera_vertices;
  Camera camera = Camera::FromFov(128, 128, 40.f);
  GBuffer gbuffer;

  SphereScene() {
    rig = IcosphereRig(4, 1.f, 6);
    const Eigen::Matrix3f rotation =
        (Eigen::AngleAxisf(0.4f, Eigen::Vector3f::UnitY()) *
         Eigen::AngleAxisf(-0.2f, Eigen::Vector3f::UnitX()))
            .toRotationMatrix();
    camera_vertices = rig.neutral * rotation.transpose();
    camera_vertices.col(2).array() -= 4.f;
    Rasterize(camera_vertices, rig.triangles, camera, &gbuffer);
  }
};

TEST(GBufferImagesTest, UVImageRoundTripsToTheSurfaceAndTheTriangleUVs) {
  SphereScene scene;
  ImageF uv_image;
  RenderUVImage(scene.gbuffer, scene.rig.uvs, scene.rig.uv_triangles, &uv_image);
  ASSERT_EQ(uv_image.channels, 3);
  int checked = 0;
  for (int y = 0; y < scene.camera.height; ++y) {
    for (int x = 0; x < scene.camera.width; ++x) {
      const int pixel = scene.gbuffer.PixelIndex(x, y);
      const int t = scene.gbuffer.triangle[pixel];
      if (t < 0) {
        EXPECT_EQ(uv_image.at(x, y, 2), 0.f);
        continue;
      }
      ++checked;
      EXPECT_EQ(uv_image.at(x, y, 2), 1.f);
      // The surface point interpolated with the barycentrics re-projects to the pixel centre.
      const Eigen::Vector3f surface_point =
          InterpolateAtPixel(scene.gbuffer, scene.rig.triangles, scene.camera_vertices, pixel)
              .transpose();
      const Eigen::Vector3f projected = scene.camera.Project(surface_point);
      ASSERT_NEAR(projected.x(), x + 0.5f, 1e-3f);
      ASSERT_NEAR(projected.y(), y + 0.5f, 1e-3f);
      ASSERT_NEAR(projected.z(), scene.gbuffer.depth[pixel], 1e-4f);
      // The UV lies in the triangle's UV triangle, at the same barycentrics.
      Eigen::Vector2f corner[3];
      for (int k = 0; k < 3; ++k) {
        corner[k] = scene.rig.uvs.row(scene.rig.uv_triangles(t, k)).transpose();
      }
      const Eigen::Vector2f uv(uv_image.at(x, y, 0), uv_image.at(x, y, 1));
      Eigen::Matrix2f edges;
      edges << corner[1] - corner[0], corner[2] - corner[0];
      const Eigen::Vector2f b12 = edges.colPivHouseholderQr().solve(uv - corner[0]);
      const Eigen::Vector3f uv_barycentrics(1.f - b12.sum(), b12.x(), b12.y());
      const Eigen::Vector3f gbuffer_barycentrics(&scene.gbuffer.barycentrics[3 * pixel]);
      ASSERT_LT((uv_barycentrics - gbuffer_barycentrics).cwiseAbs().maxCoeff(), 1e-3f)
          << "pixel " << x << "," << y;
      ASSERT_GE(uv_barycentrics.minCoeff(), -0.01f);  // edge pixels: see GBuffer
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(GBufferImagesTest, SegmentationUsesOnlyRegionColoursAndBackground) {
  SphereScene scene;
  const Eigen::Vector3f background(0.f, 0.f, 0.f);
  Image8 segmentation;
  RenderSegmentation(scene.gbuffer, scene.rig.triangle_region, scene.rig.regions, background,
                     &segmentation);
  ASSERT_EQ(segmentation.width, 128);
  ASSERT_EQ(segmentation.channels, 3);
  std::set<std::tuple<int, int, int>> allowed, seen;
  for (const rig::Region& region : scene.rig.regions) {
    const auto rgb = ColorToRgb8(region.color);
    allowed.emplace(rgb[0], rgb[1], rgb[2]);
  }
  const auto background_rgb = ColorToRgb8(background);
  for (int y = 0; y < segmentation.height; ++y) {
    for (int x = 0; x < segmentation.width; ++x) {
      const std::tuple<int, int, int> rgb(segmentation.at(x, y, 0), segmentation.at(x, y, 1),
                                          segmentation.at(x, y, 2));
      const int t = scene.gbuffer.triangle[scene.gbuffer.PixelIndex(x, y)];
      if (t < 0) {
        ASSERT_EQ(rgb, std::make_tuple(int{background_rgb[0]}, int{background_rgb[1]},
                                       int{background_rgb[2]}));
      } else {
        const auto expected = ColorToRgb8(scene.rig.regions[scene.rig.triangle_region[t]].color);
        ASSERT_EQ(rgb, std::make_tuple(int{expected[0]}, int{expected[1]}, int{expected[2]}));
        seen.insert(rgb);
      }
      ASSERT_TRUE(t < 0 || allowed.count(rgb));
    }
  }
  EXPECT_GE(seen.size(), 3u);  // the visible half shows several sectors

  // A visible triangle without a region is an error, not a stray colour.
  Eigen::VectorXi bad_regions = scene.rig.triangle_region;
  bad_regions.setConstant(99);
  EXPECT_THROW(RenderSegmentation(scene.gbuffer, bad_regions, scene.rig.regions, background,
                                  &segmentation),
               InvalidInputError);
}

TEST(GBufferImagesTest, DepthAndTriangleIdImagesMirrorTheGBuffer) {
  SphereScene scene;
  ImageF depth;
  ImageI ids;
  RenderDepthImage(scene.gbuffer, 0.f, &depth);
  RenderTriangleIdImage(scene.gbuffer, &ids);
  ASSERT_EQ(depth.channels, 1);
  ASSERT_EQ(ids.channels, 1);
  for (int i = 0; i < scene.gbuffer.NumPixels(); ++i) {
    ASSERT_EQ(ids.data[i], scene.gbuffer.triangle[i]);
    if (scene.gbuffer.triangle[i] < 0) {
      ASSERT_EQ(depth.data[i], 0.f);
    } else {
      // The sphere of radius 1 at distance 4: visible depths lie in [3, 4].
      ASSERT_GE(depth.data[i], 3.f - 1e-3f);
      ASSERT_LE(depth.data[i], 4.f);
    }
  }
}

TEST(GBufferImagesTest, OutputImagesAreNotReallocatedWhenTheirShapeMatches) {
  SphereScene scene;
  Image8 segmentation;
  RenderSegmentation(scene.gbuffer, scene.rig.triangle_region, scene.rig.regions,
                     Eigen::Vector3f::Zero(), &segmentation);
  const uint8_t* data = segmentation.data.data();
  RenderSegmentation(scene.gbuffer, scene.rig.triangle_region, scene.rig.regions,
                     Eigen::Vector3f::Ones(), &segmentation);
  EXPECT_EQ(segmentation.data.data(), data);
}

}  // namespace
}  // namespace facecap::render
