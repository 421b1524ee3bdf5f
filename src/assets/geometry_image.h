// Geometry images (paper 001 Sec. 4.1, Sec. 7): a mesh of fixed topology stored as an image in
// UV space whose pixels hold x, y, z of the surface. Rasterized once for the topology (which
// triangle and barycentrics cover each pixel), so that a mesh becomes an image by barycentric
// interpolation of its vertices and an image goes back to the vertices by bilinear sampling
// at each vertex's texture coordinate (precompute / apply split).
#ifndef FACECAP_ASSETS_GEOMETRY_IMAGE_H_
#define FACECAP_ASSETS_GEOMETRY_IMAGE_H_

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::assets {

struct GeometryImageOptions {
  int size = 64;                    // width = height of the image (pixels)
  float margin = 0.02f;             // UV margin added around the chart window on every side

  bool Check(std::string* why) const;
};

// The UV layout of one topology over a window [u0, u1] x [v0, v1] of its texture space that
// covers `vertices` (the face chart: the moving vertices of the head's UV chart). Pixel
// (x, y) has its centre at u = u0 + (x + 0.5) / size * (u1 - u0) and v = v1 - (y + 0.5) /
// size * (v1 - v0) (row 0 at the top). Pixels no triangle of the window covers take the
// value of the nearest covered pixel, so bilinear sampling near the chart border is sound.
class GeometryImageLayout {
 public:
  // topology: triangles, uvs and uv_triangles of the rig; chart_vertices: the vertices the
  // image must carry. A vertex's texture coordinate is that of its first corner in
  // uv_triangles. Triangles whose three UVs are not inside the window are not drawn.
  GeometryImageLayout(const rig::Rig& topology, const std::vector<int>& chart_vertices,
                      const GeometryImageOptions& options);

  int size() const { return size_; }
  int NumPixels() const { return size_ * size_; }
  const std::vector<int>& chart_vertices() const { return chart_vertices_; }
  // Covered pixels (1) and filled pixels (0), row-major.
  const std::vector<uint8_t>& coverage() const { return coverage_; }

  // The image of a mesh: size x size x 3 floats, row-major, channels x, y, z.
  // vertices: #V by 3 (the topology's vertex count).
  std::vector<float> Render(const rig::Vertices& vertices) const;
  // The same for per-vertex offsets given as a 3#V column (x0, y0, z0, x1, ...).
  std::vector<float> RenderColumn(const Eigen::Ref<const Eigen::VectorXf>& values) const;
  // Bilinear samples of a size x size x C image (row-major, channels last) at each chart
  // vertex: |chart_vertices| by C.
  Eigen::MatrixXf Sample(const float* image, int channels) const;

  // The bilinear sampling stencil of chart vertex k: 4 pixel indices and weights.
  const std::vector<std::array<int, 4>>& sample_pixels() const { return sample_pixels_; }
  const std::vector<std::array<float, 4>>& sample_weights() const { return sample_weights_; }

 private:
  int size_;
  std::vector<int> chart_vertices_;
  std::vector<uint8_t> coverage_;
  // Per pixel: three vertex ids and barycentric weights (of the nearest covered pixel when
  // the pixel is not covered).
  std::vector<std::array<int, 3>> pixel_vertices_;
  std::vector<std::array<float, 3>> pixel_weights_;
  std::vector<std::array<int, 4>> sample_pixels_;
  std::vector<std::array<float, 4>> sample_weights_;
};

// Vertices of `vertices` whose texture coordinate lies in the head's UV chart (v >= v_min):
// on the demo head the skin, not the eyeballs or pockets packed below it.
std::vector<int> ChartVertices(const rig::Rig& topology, const std::vector<int>& vertices,
                               float v_min = 0.2f);

// Round trip of a mesh through its geometry image: mean and largest distance (cm) between
// the chart vertices and their samples of Render(vertices).
struct RoundTripError {
  double mean_cm = 0;
  double max_cm = 0;
};
RoundTripError GeometryImageRoundTrip(const GeometryImageLayout& layout,
                                      const rig::Vertices& vertices);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_GEOMETRY_IMAGE_H_
