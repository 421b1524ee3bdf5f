// Textured and lit renders over a G-buffer: area-weighted vertex normals, albedo from a
// texture (bilinear in UV), a constant or per-region colour, Lambert diffuse plus
// Blinn-Phong specular from directional lights, order-2 spherical-harmonics environment
// light, ambient light, and a constant or image background. All colours are linear RGB;
// LinearToImage8 encodes for display.
#ifndef FACECAP_RENDER_SHADING_H_
#define FACECAP_RENDER_SHADING_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/rasterizer.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::render {

// A light infinitely far away.
struct DirectionalLight {
  // Camera-space direction from the surface towards the light (normalized when used).
  // The default comes from above-right of the camera.
  Eigen::Vector3f direction{0.4f, 0.5f, 1.f};
  Eigen::Vector3f color{0.8f, 0.8f, 0.8f};  // linear RGB radiance scale
};

struct Lighting {
  // Light reaching every point from every direction: adds albedo * ambient.
  Eigen::Vector3f ambient{0.2f, 0.2f, 0.2f};
  // Directional lights: Lambert diffuse and Blinn-Phong specular each.
  std::vector<DirectionalLight> directional_lights{DirectionalLight()};
  // Order-2 spherical-harmonics environment (9 real SH basis functions Y_0..Y_8 in the order
  // (l,m) = (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2), evaluated at
  // the camera-space normal (x, y, z)). Row k holds the RGB radiance coefficients L_k of the
  // environment; the diffuse irradiance is E(n) = sum_k A_l(k) L_k Y_k(n) (Ramamoorthi and
  // Hanrahan 2001, A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4), which adds albedo * E(n) / pi.
  // A constant environment of radiance L is L_0 = L * sqrt(4 pi). Zero: no SH light.
  Eigen::Matrix<float, 9, 3> spherical_harmonics = Eigen::Matrix<float, 9, 3>::Zero();
};

// Where the diffuse albedo of a pixel comes from.
enum class AlbedoSource {
  kConstant,   // ShadingOptions::constant_albedo everywhere
  kPerRegion,  // ShadingOptions::region_albedo[triangle_region[t]], or the rig's region colours
  kTexture,    // bilinear lookup of the albedo texture at the pixel's interpolated UV
};

struct ShadingOptions {
  AlbedoSource albedo_source = AlbedoSource::kConstant;
  Eigen::Vector3f constant_albedo{0.75f, 0.57f, 0.48f};  // a skin-like linear RGB
  // Albedo per region for kPerRegion; empty uses Rig::regions[r].color.
  std::vector<Eigen::Vector3f> region_albedo;
  // Blinn-Phong specular k_s (n . h)^shininess per directional light; 0 turns it off.
  float specular_strength = 0.15f;
  float shininess = 24.f;
  // Background where nothing is visible: this colour, or the background image when one is
  // passed to RenderShaded (stretched bilinearly when its size differs).
  Eigen::Vector3f background_color{0.f, 0.f, 0.f};
  // Threads over image rows; 1 runs inline, <= 0 uses DefaultNumThreads().
  int num_threads = 1;

  // False, with the reason in *why, when a field is out of range.
  bool Check(std::string* why) const;
};

// Area-weighted per-vertex normals: each vertex gets the normalized sum of its incident
// triangles' (p1 - p0) x (p2 - p0) (twice the area times the unit normal). Vertices with
// no triangle get (0, 0, 0).
//
// Inputs:
//   vertices   #V by 3 list of vertex positions (any frame; normals come in the same frame)
//   triangles  #F by 3 list of vertex indices, counter-clockwise seen from outside
// Outputs:
//   normals    #V by 3 list of unit outward normals (resized only when #V differs)
void VertexNormals(const rig::Vertices& vertices, const rig::Triangles& triangles,
                   rig::Vertices* normals);

// Bilinear texture lookup with clamp-to-edge, in the OBJ convention: u to the right, v up,
// (0, 0) the bottom-left corner of the image and (1, 1) the top-right one; texel (i, j)
// has its centre at u = (i + 0.5) / width, v = 1 - (j + 0.5) / height.
//
// Inputs:
//   texture  image with at least 3 channels
//   u, v     texture coordinates
// Returns the first three channels.
Eigen::Vector3f SampleBilinear(const ImageF& texture, float u, float v);

// The first three channels of `image` resampled to width x height by SampleBilinear (texel
// centres onto texel centres, clamped at the edges); a copy when the size is already that.
ImageF ResampleBilinear(const ImageF& image, int width, int height);

// Irradiance E(n) / pi of an order-2 spherical-harmonics environment at unit normal n
// (see Lighting::spherical_harmonics).
Eigen::Vector3f SphericalHarmonicsIrradiance(const Eigen::Matrix<float, 9, 3>& coefficients,
                                             const Eigen::Vector3f& normal);

// Shaded render: per covered pixel, with n the interpolated (renormalized) vertex normal,
// v the direction to the camera, and per light l and h = normalize(l + v):
//   colour = albedo * (ambient + E_SH(n) / pi + sum_lights c_l max(0, n . l))
//          + k_s sum_lights c_l max(0, n . h)^shininess [n . l > 0]
// and the background elsewhere.
//
// Inputs:
//   gbuffer           result of Rasterize on camera_vertices and rig.triangles
//   camera_vertices   #V by 3 posed camera-space positions (as rasterized)
//   vertex_normals    #V by 3 camera-space unit normals (VertexNormals of camera_vertices)
//   rig               topology and attributes: triangles, uvs / uv_triangles (kTexture),
//                     triangle_region / regions (kPerRegion)
//   lighting          lights in camera space
//   options           albedo source, specular, background
//   albedo_texture    linear RGB texture for kTexture (ignored otherwise; may be null then)
//   background_image  RGB image behind the mesh, or null for options.background_color
// Outputs:
//   image             width x height x 3 linear RGB (resized only when its shape differs)
// Throws InvalidInputError on bad options or missing attributes for the albedo source.
void RenderShaded(const GBuffer& gbuffer, const rig::Vertices& camera_vertices,
                  const rig::Vertices& vertex_normals, const rig::Rig& rig,
                  const Lighting& lighting,
                  const ShadingOptions& options, const ImageF* albedo_texture,
                  const ImageF* background_image, ImageF* image);

// Converts a linear RGB(A) float image to 8 bits: optional sRGB transfer curve, clamp to
// [0, 1], round.
//
// Inputs:
//   linear       float image (any channel count)
//   encode_srgb  apply the sRGB transfer function before quantizing
// Outputs:
//   image        same shape, 8 bits per channel
void LinearToImage8(const ImageF& linear, bool encode_srgb, Image8* image);

// The inverse of LinearToImage8: 8-bit values to [0, 1], through the inverse sRGB transfer
// curve when decode_srgb.
//
// Inputs:
//   image        8-bit image (any channel count)
//   decode_srgb  undo the sRGB transfer function
// Outputs:
//   linear       same shape, float
void Image8ToLinear(const Image8& image, bool decode_srgb, ImageF* linear);

// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1], and its inverse.
float EncodeSrgb(float linear);
float DecodeSrgb(float encoded);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_SHADING_H_
