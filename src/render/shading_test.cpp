#include "render/shading.h"

#include <cmath>

#include <gtest/gtest.h>

#include "render/primitives.h"
#include "render/rasterizer.h"
#include "util/errors.h"

namespace facecap::render {
namespace {

Camera TestCamera() {
  Camera camera;
  camera.width = camera.height = 64;
  camera.fx = camera.fy = 50.f;
  camera.cx = camera.cy = 32.f;
  return camera;
}

// A square facing the camera at depth 2, covering the image centre, one region, UVs
// spanning [0, 1]^2 (u right, v up).
rig::Rig FrontQuadRig() {
  rig::Rig rig;
  rig.neutral.resize(4, 3);
  rig.neutral << -0.5f, -0.5f, -2.f,  //
      0.5f, -0.5f, -2.f,              //
      0.5f, 0.5f, -2.f,               //
      -0.5f, 0.5f, -2.f;
  rig.triangles.resize(2, 3);
  rig.triangles << 0, 1, 2, 0, 2, 3;  // counter-clockwise seen from +z (the camera)
  rig.uvs.resize(4, 2);
  rig.uvs << 0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f, 1.f;
  rig.uv_triangles = rig.triangles;
  rig.triangle_region = Eigen::VectorXi::Zero(2);
  rig.regions.push_back({"quad", Eigen::Vector3f(0.2f, 0.4f, 0.6f)});
  return rig;
}

Lighting SingleLight(const Eigen::Vector3f& direction) {
  Lighting lighting;
  lighting.ambient.setZero();
  lighting.directional_lights = {DirectionalLight{direction, Eigen::Vector3f(1.f, 1.f, 1.f)}};
  return lighting;
}

TEST(ShadingTest, VertexNormalsOfASpherePointOutwards) {
  rig::Vertices vertices;
  rig::Triangles triangles;
  Icosphere(3, &vertices, &triangles);
  rig::Vertices normals;
  VertexNormals(vertices, triangles, &normals);
  ASSERT_EQ(normals.rows(), vertices.rows());
  for (int i = 0; i < vertices.rows(); ++i) {
    EXPECT_NEAR(normals.row(i).norm(), 1.f, 1e-5f);
    EXPECT_GT(normals.row(i).dot(vertices.row(i)), 0.995f);
  }
}

TEST(ShadingTest, LambertFollowsTheCosineOfTheLightAngle) {
  const Camera camera = TestCamera();
  const rig::Rig rig = FrontQuadRig();
  GBuffer gbuffer;
  Rasterize(rig.neutral, rig.triangles, camera, &gbuffer);
  rig::Vertices normals;
  VertexNormals(rig.neutral, rig.triangles, &normals);
  ShadingOptions options;
  options.specular_strength = 0.f;
  options.constant_albedo = Eigen::Vector3f(0.5f, 0.6f, 0.7f);
  options.background_color = Eigen::Vector3f(0.1f, 0.2f, 0.3f);
  ImageF image;
  for (const float angle_deg : {0.f, 60.f, 100.f}) {
    const float angle = angle_deg * static_cast<float>(M_PI) / 180.f;
    RenderShaded(gbuffer, rig.neutral, normals, rig,
                 SingleLight(Eigen::Vector3f(std::sin(angle), 0.f, std::cos(angle))), options,
                 nullptr, nullptr, &image);
    const float cosine = std::max(0.f, std::cos(angle));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(image.at(32, 32, c), options.constant_albedo[c] * cosine, 1e-5f)
          << angle_deg;
      EXPECT_EQ(image.at(0, 0, c), options.background_color[c]);
    }
  }
}

TEST(ShadingTest, BlinnPhongPeaksWhenTheHalfVectorMeetsTheNormal) {
  const Camera camera = TestCamera();
  const rig::Rig rig = FrontQuadRig();
  GBuffer gbuffer;
  Rasterize(rig.neutral, rig.triangles, camera, &gbuffer);
  rig::Vertices normals;
  VertexNormals(rig.neutral, rig.triangles, &normals);
  ShadingOptions options;
  options.constant_albedo.setZero();  // specular only
  options.specular_strength = 0.5f;
  options.shininess = 16.f;
  ImageF image;
  // The light behind the camera: at the pixel whose view direction is the normal (image
  // centre) the highlight is k_s; it falls off away from the centre.
  RenderShaded(gbuffer, rig.neutral, normals, rig, SingleLight(Eigen::Vector3f::UnitZ()),
               options, nullptr, nullptr, &image);
  const int centre = 32;
  // Pixel (32, 32) has its centre half a pixel off the axis: n . h is 1 - 1e-5 there.
  EXPECT_NEAR(image.at(centre, centre, 0), 0.5f, 1e-3f);
  EXPECT_LT(image.at(centre + 20, centre, 0), image.at(centre + 5, centre, 0));
  EXPECT_LT(image.at(centre + 5, centre, 0), image.at(centre, centre, 0));
}

TEST(ShadingTest, ConstantSphericalHarmonicsEnvironmentGivesAlbedoTimesRadiance) {
  const Eigen::Vector3f radiance(0.3f, 0.5f, 0.9f);
  Eigen::Matrix<float, 9, 3> coefficients = Eigen::Matrix<float, 9, 3>::Zero();
  coefficients.row(0) = radiance.transpose() * std::sqrt(4.f * static_cast<float>(M_PI));
  for (const Eigen::Vector3f& normal :
       {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0.6f, -0.8f, 0)}) {
    EXPECT_LT((SphericalHarmonicsIrradiance(coefficients, normal) - radiance).norm(), 1e-5f);
  }
  // A pure band-1 environment L(w) = w_z gives irradiance E / pi = (2/3) n_z.
  Eigen::Matrix<float, 9, 3> linear = Eigen::Matrix<float, 9, 3>::Zero();
  linear.row(2).setConstant(std::sqrt(4.f * static_cast<float>(M_PI) / 3.f));  // Y_10 = c z
  EXPECT_NEAR(SphericalHarmonicsIrradiance(linear, Eigen::Vector3f(0, 0, 1))[0], 2.f / 3.f, 1e-4f);
  EXPECT_NEAR(SphericalHarmonicsIrradiance(linear, Eigen::Vector3f(0, 0, -1))[0], -2.f / 3.f,
              1e-4f);

  const Camera camera = TestCamera();
  const rig::Rig rig = FrontQuadRig();
  GBuffer gbuffer;
  Rasterize(rig.neutral, rig.triangles, camera, &gbuffer);
  rig::Vertices normals;
  VertexNormals(rig.neutral, rig.triangles, &normals);
  Lighting lighting;
  lighting.ambient.setZero();
  lighting.directional_lights.clear();
  lighting.spherical_harmonics = coefficients;
  ShadingOptions options;
  options.albedo_source = AlbedoSource::kPerRegion;
  ImageF image;
  RenderShaded(gbuffer, rig.neutral, normals, rig, lighting, options, nullptr, nullptr, &image);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(image.at(32, 32, c), rig.regions[0].color[c] * radiance[c], 1e-5f);
  }
}

TEST(ShadingTest, BilinearLookupUsesTheObjUvConvention) {
  ImageF texture(4, 2, 3);
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 4; ++x) {
      texture.at(x, y, 0) = static_cast<float>(x);
      texture.at(x, y, 1) = static_cast<float>(y);
      texture.at(x, y, 2) = 1.f;
    }
  }
  // Texel centres: u = (x + 0.5) / 4, v = 1 - (y + 0.5) / 2 (row 0 is the top, v = 0.75).
  EXPECT_LT((SampleBilinear(texture, 0.125f, 0.75f) - Eigen::Vector3f(0, 0, 1)).norm(), 1e-6f);
  EXPECT_LT((SampleBilinear(texture, 0.875f, 0.25f) - Eigen::Vector3f(3, 1, 1)).norm(), 1e-6f);
  // Half-way between texels, and clamped beyond the edges.
  EXPECT_LT((SampleBilinear(texture, 0.25f, 0.5f) - Eigen::Vector3f(0.5f, 0.5f, 1)).norm(), 1e-6f);
  EXPECT_LT((SampleBilinear(texture, -3.f, 7.f) - Eigen::Vector3f(0, 0, 1)).norm(), 1e-6f);
}

TEST(ShadingTest, TexturedRenderShowsTheTextureAndBackgroundImage) {
  const Camera camera = TestCamera();
  const rig::Rig rig = FrontQuadRig();
  GBuffer gbuffer;
  Rasterize(rig.neutral, rig.triangles, camera, &gbuffer);
  rig::Vertices normals;
  VertexNormals(rig.neutral, rig.triangles, &normals);
  // Left half of the texture red, right half green.
  ImageF texture(8, 8, 3);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) texture.at(x, y, x < 4 ? 0 : 1) = 1.f;
  }
  ImageF background(16, 16, 3);
  for (float& value : background.data) value = 0.25f;
  Lighting lighting = SingleLight(Eigen::Vector3f::UnitZ());
  ShadingOptions options;
  options.albedo_source = AlbedoSource::kTexture;
  options.specular_strength = 0.f;
  ImageF image;
  RenderShaded(gbuffer, rig.neutral, normals, rig, lighting, options, &texture, &background,
               &image);
  // The quad spans pixels 19.5 .. 44.5; its left part (u < 0.5) is red, right part green.
  EXPECT_NEAR(image.at(22, 32, 0), 1.f, 1e-4f);
  EXPECT_NEAR(image.at(22, 32, 1), 0.f, 1e-4f);
  EXPECT_NEAR(image.at(41, 32, 0), 0.f, 1e-4f);
  EXPECT_NEAR(image.at(41, 32, 1), 1.f, 1e-4f);
  EXPECT_NEAR(image.at(2, 2, 2), 0.25f, 1e-6f);
  // Texture albedo without a texture is an input error.
  EXPECT_THROW(RenderShaded(gbuffer, rig.neutral, normals, rig, lighting, options, nullptr,
                            nullptr, &image),
               InvalidInputError);
}

TEST(ShadingTest, LinearToImage8EncodesAndClamps) {
  ImageF linear(3, 1, 1);
  linear.data = {-0.5f, 0.5f, 2.f};
  Image8 plain, srgb;
  LinearToImage8(linear, false, &plain);
  LinearToImage8(linear, true, &srgb);
  EXPECT_EQ(plain.data, (std::vector<uint8_t>{0, 128, 255}));
  EXPECT_EQ(srgb.data, (std::vector<uint8_t>{0, 188, 255}));
}

}  // namespace
}  // namespace facecap::render
