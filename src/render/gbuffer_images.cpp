#include "render/gbuffer_images.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "util/errors.h"

namespace facecap::render {

Eigen::Matrix<uint8_t, 3, 1> ColorToRgb8(const Eigen::Vector3f& color) {
  Eigen::Matrix<uint8_t, 3, 1> rgb;
  for (int c = 0; c < 3; ++c) {
    const float clamped = color[c] > 0.f ? std::min(color[c], 1.f) : 0.f;  // NaN -> 0
    rgb[c] = static_cast<uint8_t>(clamped * 255.f + 0.5f);
  }
  return rgb;
}

void RenderSegmentation(const GBuffer& gbuffer, const Eigen::VectorXi& triangle_region,
                        const std::vector<rig::Region>& regions,
                        const Eigen::Vector3f& background_color, Image8* image) {
  EnsureImageShape(gbuffer.width, gbuffer.height, 3, image);
  // Region colours converted once; a few dozen at most.
  constexpr int kMaxStackRegions = 256;
  const int num_regions = static_cast<int>(regions.size());
  std::vector<Eigen::Matrix<uint8_t, 3, 1>> heap_colors;
  Eigen::Matrix<uint8_t, 3, 1> stack_colors[kMaxStackRegions];
  Eigen::Matrix<uint8_t, 3, 1>* region_rgb = stack_colors;
  if (num_regions > kMaxStackRegions) {
    heap_colors.resize(num_regions);
    region_rgb = heap_colors.data();
  }
  for (int r = 0; r < num_regions; ++r) region_rgb[r] = ColorToRgb8(regions[r].color);
  const Eigen::Matrix<uint8_t, 3, 1> background_rgb = ColorToRgb8(background_color);

  const int num_pixels = gbuffer.NumPixels();
  const int num_triangles = static_cast<int>(triangle_region.size());
  uint8_t* out = image->data.data();
  for (int pixel = 0; pixel < num_pixels; ++pixel, out += 3) {
    const int t = gbuffer.triangle[pixel];
    const Eigen::Matrix<uint8_t, 3, 1>* rgb = &background_rgb;
    if (t >= 0) {
      const int region = t < num_triangles ? triangle_region[t] : -1;
      if (region < 0 || region >= num_regions) {
        std::ostringstream message;
        message << "RenderSegmentation: triangle " << t << " has region " << region
                << " but there are " << num_regions << " regions and " << num_triangles
                << " triangle_region entries";
        throw InvalidInputError(message.str());
      }
      rgb = &region_rgb[region];
    }
    out[0] = (*rgb)[0];
    out[1] = (*rgb)[1];
    out[2] = (*rgb)[2];
  }
}

void RenderUVImage(const GBuffer& gbuffer, const rig::UVs& uvs,
                   const rig::Triangles& uv_triangles, ImageF* image) {
  EnsureImageShape(gbuffer.width, gbuffer.height, 3, image);
  const int num_pixels = gbuffer.NumPixels();
  const int num_uvs = static_cast<int>(uvs.rows());
  float* out = image->data.data();
  for (int pixel = 0; pixel < num_pixels; ++pixel, out += 3) {
    const int t = gbuffer.triangle[pixel];
    if (t < 0) {
      out[0] = out[1] = out[2] = 0.f;
      continue;
    }
    if (t >= uv_triangles.rows()) {
      throw InvalidInputError("RenderUVImage: visible triangle " + std::to_string(t) +
                              " has no row in uv_triangles");
    }
    const float* b = &gbuffer.barycentrics[3 * static_cast<size_t>(pixel)];
    float u = 0.f, v = 0.f;
    for (int corner = 0; corner < 3; ++corner) {
      const int uv_index = uv_triangles(t, corner);
      if (uv_index < 0 || uv_index >= num_uvs) {
        throw InvalidInputError("RenderUVImage: uv index " + std::to_string(uv_index) +
                                " out of range [0, " + std::to_string(num_uvs) + ")");
      }
      u += b[corner] * uvs(uv_index, 0);
      v += b[corner] * uvs(uv_index, 1);
    }
    out[0] = u;
    out[1] = v;
    out[2] = 1.f;
  }
}

void RenderDepthImage(const GBuffer& gbuffer, float background_depth, ImageF* image) {
  EnsureImageShape(gbuffer.width, gbuffer.height, 1, image);
  const int num_pixels = gbuffer.NumPixels();
  for (int pixel = 0; pixel < num_pixels; ++pixel) {
    image->data[pixel] = gbuffer.triangle[pixel] >= 0 ? gbuffer.depth[pixel] : background_depth;
  }
}

void RenderTriangleIdImage(const GBuffer& gbuffer, ImageI* image) {
  EnsureImageShape(gbuffer.width, gbuffer.height, 1, image);
  std::copy(gbuffer.triangle.begin(), gbuffer.triangle.end(), image->data.begin());
}

}  // namespace facecap::render
