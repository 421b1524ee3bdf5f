// Images read straight off a G-buffer: flat-colour segmentation, the UV-coordinate image
// U(I) (paper 000 Sec. 5.4), depth and triangle ids. Each output image is resized only when
// its size or channel count differs, so a loop of renders allocates nothing.
#ifndef FACECAP_RENDER_GBUFFER_IMAGES_H_
#define FACECAP_RENDER_GBUFFER_IMAGES_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "render/rasterizer.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::render {

using ImageI = Image<int32_t>;

// Converts an RGB colour in [0, 1] to 8 bits (rounded, clamped).
Eigen::Matrix<uint8_t, 3, 1> ColorToRgb8(const Eigen::Vector3f& color);

// Flat-colour segmentation render (paper 000 Sec. 4.1): every covered pixel takes the
// colour of its triangle's region, every other pixel the background colour.
//
// Inputs:
//   gbuffer           result of Rasterize
//   triangle_region   #F list of region indices into regions
//   regions           region list; Region::color is RGB in [0, 1]
//   background_color  RGB in [0, 1]
// Outputs:
//   image             width x height x 3 RGB
// Throws InvalidInputError when a visible triangle has no region (index out of range).
void RenderSegmentation(const GBuffer& gbuffer, const Eigen::VectorXi& triangle_region,
                        const std::vector<rig::Region>& regions,
                        const Eigen::Vector3f& background_color, Image8* image);

// The UV-coordinate image U(I) (paper 000 Sec. 5.4): per pixel the texture coordinate of
// the visible surface point, interpolated perspective-correctly from the triangle's corner
// UVs, and a coverage flag.
//
// Inputs:
//   gbuffer        result of Rasterize
//   uvs            #UV by 2 list of texture coordinates
//   uv_triangles   #F by 3 list of per-corner indices into uvs (OBJ style)
// Outputs:
//   image          width x height x 3: (u, v, coverage) with coverage 1 on the mesh and
//                  u = v = coverage = 0 on the background
void RenderUVImage(const GBuffer& gbuffer, const rig::UVs& uvs,
                   const rig::Triangles& uv_triangles, ImageF* image);

// Depth image: -z of the visible surface per pixel.
//
// Inputs:
//   gbuffer           result of Rasterize
//   background_depth  value written where nothing is visible (e.g. 0 or +inf)
// Outputs:
//   image             width x height x 1
void RenderDepthImage(const GBuffer& gbuffer, float background_depth, ImageF* image);

// Triangle-id image: index of the visible triangle per pixel, -1 on the background.
//
// Inputs:
//   gbuffer  result of Rasterize
// Outputs:
//   image    width x height x 1
void RenderTriangleIdImage(const GBuffer& gbuffer, ImageI* image);

// Resizes image to width x height x channels unless it already has that shape.
template <typename T>
void EnsureImageShape(int width, int height, int channels, Image<T>* image) {
  if (image->width == width && image->height == height && image->channels == channels &&
      image->data.size() == static_cast<size_t>(width) * height * channels) {
    return;
  }
  *image = Image<T>(width, height, channels);
}

}  // namespace facecap::render

#endif  // FACECAP_RENDER_GBUFFER_IMAGES_H_
