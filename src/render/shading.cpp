#include "render/shading.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

#include "render/gbuffer_images.h"
#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::render {
namespace {

// Bilinear lookup at continuous pixel coordinates (centres at integers), clamp to edge.
Eigen::Vector3f SamplePixelsBilinear(const ImageF& image, float px, float py) {
  const int last_x = image.width - 1, last_y = image.height - 1;
  px = std::clamp(px, 0.f, static_cast<float>(last_x));
  py = std::clamp(py, 0.f, static_cast<float>(last_y));
  const int x0 = static_cast<int>(px), y0 = static_cast<int>(py);
  const int x1 = std::min(x0 + 1, last_x), y1 = std::min(y0 + 1, last_y);
  const float fx = px - x0, fy = py - y0;
  Eigen::Vector3f result;
  for (int c = 0; c < 3; ++c) {
    const float top = (1.f - fx) * image.at(x0, y0, c) + fx * image.at(x1, y0, c);
    const float bottom = (1.f - fx) * image.at(x0, y1, c) + fx * image.at(x1, y1, c);
    result[c] = (1.f - fy) * top + fy * bottom;
  }
  return result;
}

}  // namespace

// sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
float EncodeSrgb(float linear) {
  return linear <= 0.0031308f ? 12.92f * linear
                              : 1.055f * std::pow(linear, 1.f / 2.4f) - 0.055f;
}

// Inverse of EncodeSrgb.
float DecodeSrgb(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}


bool ShadingOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(specular_strength >= 0.f)) return fail("specular_strength must be >= 0");
  if (!(shininess > 0.f)) return fail("shininess must be > 0");
  if (!constant_albedo.allFinite() || !background_color.allFinite()) {
    return fail("constant_albedo and background_color must be finite");
  }
  return true;
}

void VertexNormals(const rig::Vertices& vertices, const rig::Triangles& triangles,
                   rig::Vertices* normals) {
  const int num_vertices = static_cast<int>(vertices.rows());
  if (normals->rows() != num_vertices) normals->resize(num_vertices, 3);
  normals->setZero();
  for (int t = 0; t < triangles.rows(); ++t) {
    const int i0 = triangles(t, 0), i1 = triangles(t, 1), i2 = triangles(t, 2);
    const Eigen::Vector3f p0 = vertices.row(i0);
    // (p1 - p0) x (p2 - p0): the unit normal scaled by twice the area.
    const Eigen::Vector3f weighted_normal =
        (Eigen::Vector3f(vertices.row(i1)) - p0).cross(Eigen::Vector3f(vertices.row(i2)) - p0);
    normals->row(i0) += weighted_normal.transpose();
    normals->row(i1) += weighted_normal.transpose();
    normals->row(i2) += weighted_normal.transpose();
  }
  for (int i = 0; i < num_vertices; ++i) {
    const float length = normals->row(i).norm();
    if (length > 0.f) normals->row(i) /= length;
  }
}

Eigen::Vector3f SampleBilinear(const ImageF& texture, float u, float v) {
  return SamplePixelsBilinear(texture, u * texture.width - 0.5f,
                              (1.f - v) * texture.height - 0.5f);
}

ImageF ResampleBilinear(const ImageF& image, int width, int height) {
  if (image.width == width && image.height == height && image.channels == 3) return image;
  ImageF out(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3f c = SampleBilinear(image, (x + 0.5f) / width, 1.f - (y + 0.5f) / height);
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = c[k];
    }
  }
  return out;
}

Eigen::Vector3f SphericalHarmonicsIrradiance(const Eigen::Matrix<float, 9, 3>& coefficients,
                                             const Eigen::Vector3f& normal) {
  const float x = normal.x(), y = normal.y(), z = normal.z();
  // Real SH basis Y_k(n), each times A_l / pi (A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4).
  constexpr float kBand0 = 1.f, kBand1 = 2.f / 3.f, kBand2 = 1.f / 4.f;
  Eigen::Matrix<float, 9, 1> basis;
  basis << kBand0 * 0.282095f,
           kBand1 * 0.488603f * y,
           kBand1 * 0.488603f * z,
           kBand1 * 0.488603f * x,
           kBand2 * 1.092548f * x * y,
           kBand2 * 1.092548f * y * z,
           kBand2 * 0.315392f * (3.f * z * z - 1.f),
           kBand2 * 1.092548f * x * z,
           kBand2 * 0.546274f * (x * x - y * y);
  return coefficients.transpose() * basis;
}

void RenderShaded(const GBuffer& gbuffer, const rig::Vertices& camera_vertices,
                  const rig::Vertices& vertex_normals, const rig::Rig& rig,
                  const Lighting& lighting,
                  const ShadingOptions& options, const ImageF* albedo_texture,
                  const ImageF* background_image, ImageF* image) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("RenderShaded: " + why);
  const rig::Triangles& triangles = rig.triangles;
  const int num_triangles = static_cast<int>(triangles.rows());
  if (vertex_normals.rows() != camera_vertices.rows()) {
    throw InvalidInputError("RenderShaded: vertex_normals and camera_vertices differ in rows");
  }
  std::vector<Eigen::Vector3f> region_albedo;
  switch (options.albedo_source) {
    case AlbedoSource::kConstant:
      break;
    case AlbedoSource::kPerRegion: {
      if (!options.region_albedo.empty()) {
        region_albedo = options.region_albedo;
      } else {
        for (const rig::Region& region : rig.regions) region_albedo.push_back(region.color);
      }
      const int num_regions = static_cast<int>(region_albedo.size());
      if (rig.triangle_region.size() != num_triangles ||
          (num_triangles > 0 && (rig.triangle_region.minCoeff() < 0 ||
                                 rig.triangle_region.maxCoeff() >= num_regions))) {
        throw InvalidInputError(
            "RenderShaded: per-region albedo needs one region index per triangle, each below "
            "the number of regions (" + std::to_string(num_regions) + ")");
      }
      break;
    }
    case AlbedoSource::kTexture:
      if (albedo_texture == nullptr || albedo_texture->empty() ||
          albedo_texture->channels < 3) {
        throw InvalidInputError("RenderShaded: texture albedo needs an RGB albedo_texture");
      }
      if (rig.uv_triangles.rows() != num_triangles || rig.uvs.rows() == 0 ||
          (num_triangles > 0 && (rig.uv_triangles.minCoeff() < 0 ||
                                 rig.uv_triangles.maxCoeff() >= rig.uvs.rows()))) {
        throw InvalidInputError(
            "RenderShaded: texture albedo needs uv_triangles with one row per triangle "
            "indexing into uvs");
      }
      break;
  }
  const bool use_background_image =
      background_image != nullptr && !background_image->empty() && background_image->channels >= 3;
  const bool use_spherical_harmonics = !lighting.spherical_harmonics.isZero(0);
  std::vector<Eigen::Vector3f> light_directions;
  for (const DirectionalLight& light : lighting.directional_lights) {
    light_directions.push_back(light.direction.normalized());
  }

  EnsureImageShape(gbuffer.width, gbuffer.height, 3, image);
  const int width = gbuffer.width;
  auto shade_row = [&](int y) {
    for (int x = 0; x < width; ++x) {
      const int pixel = y * width + x;
      float* out = image->pixel(x, y);
      const int t = gbuffer.triangle[pixel];
      Eigen::Vector3f color;
      if (t < 0) {
        color = use_background_image
                    ? SampleBilinear(*background_image, (x + 0.5f) / width,
                                     1.f - (y + 0.5f) / gbuffer.height)
                    : options.background_color;
      } else {
        const Eigen::Vector3f position =
            InterpolateAtPixel(gbuffer, triangles, camera_vertices, pixel).transpose();
        Eigen::Vector3f normal =
            InterpolateAtPixel(gbuffer, triangles, vertex_normals, pixel).transpose();
        const Eigen::Vector3f to_camera = (-position).normalized();
        const float normal_length = normal.norm();
        normal = normal_length > 0.f ? Eigen::Vector3f(normal / normal_length) : to_camera;
        if (normal.dot(to_camera) < 0.f) normal = -normal;  // inside of an open mesh

        Eigen::Vector3f albedo = options.constant_albedo;
        if (options.albedo_source == AlbedoSource::kPerRegion) {
          albedo = region_albedo[rig.triangle_region[t]];
        } else if (options.albedo_source == AlbedoSource::kTexture) {
          const float* b = &gbuffer.barycentrics[3 * static_cast<size_t>(pixel)];
          Eigen::Vector2f uv = Eigen::Vector2f::Zero();
          for (int corner = 0; corner < 3; ++corner) {
            uv += b[corner] * rig.uvs.row(rig.uv_triangles(t, corner)).transpose();
          }
          albedo = SampleBilinear(*albedo_texture, uv.x(), uv.y());
        }

        Eigen::Vector3f diffuse_light = lighting.ambient;
        if (use_spherical_harmonics) {
          diffuse_light += SphericalHarmonicsIrradiance(lighting.spherical_harmonics, normal);
        }
        Eigen::Vector3f specular_light = Eigen::Vector3f::Zero();
        for (size_t l = 0; l < light_directions.size(); ++l) {
          const Eigen::Vector3f& to_light = light_directions[l];
          const float n_dot_l = normal.dot(to_light);
          if (n_dot_l <= 0.f) continue;
          const Eigen::Vector3f& light_color = lighting.directional_lights[l].color;
          diffuse_light += n_dot_l * light_color;
          if (options.specular_strength > 0.f) {
            const Eigen::Vector3f half_vector = (to_light + to_camera).normalized();
            const float n_dot_h = std::max(0.f, normal.dot(half_vector));
            specular_light += std::pow(n_dot_h, options.shininess) * light_color;
          }
        }
        color = albedo.cwiseProduct(diffuse_light.cwiseMax(0.f)) +
                options.specular_strength * specular_light;
      }
      out[0] = color[0];
      out[1] = color[1];
      out[2] = color[2];
    }
  };
  ParallelFor(0, gbuffer.height, options.num_threads, shade_row);
}

void LinearToImage8(const ImageF& linear, bool encode_srgb, Image8* image) {
  EnsureImageShape(linear.width, linear.height, linear.channels, image);
  for (size_t i = 0; i < linear.data.size(); ++i) {
    const float raw = linear.data[i];
    float value = raw > 0.f ? std::min(raw, 1.f) : 0.f;  // NaN -> 0
    if (encode_srgb) value = EncodeSrgb(value);
    image->data[i] = static_cast<uint8_t>(value * 255.f + 0.5f);
  }
}

void Image8ToLinear(const Image8& image, bool decode_srgb, ImageF* linear) {
  float table[256];
  for (int v = 0; v < 256; ++v) {
    table[v] = decode_srgb ? DecodeSrgb(v / 255.f) : v / 255.f;
  }
  EnsureImageShape(image.width, image.height, image.channels, linear);
  for (size_t i = 0; i < image.data.size(); ++i) linear->data[i] = table[image.data[i]];
}

}  // namespace facecap::render
