// Texture space seen from the mesh: for each texel of an N x N texture, the triangle whose UV
// image covers the texel's centre, the texel's point on the neutral mesh and its barycentric
// coordinates. Baking a procedural texture, gathering colours into a texture and measuring a
// texture by face region all start from it.
#ifndef FACECAP_RENDER_TEXEL_MAP_H_
#define FACECAP_RENDER_TEXEL_MAP_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::render {

struct TexelMap {
  int size = 0;                                 // N
  std::vector<int32_t> triangle;                // N * N, row-major (y down); -1: no triangle
  std::vector<Eigen::Vector3f> position;        // N * N, the point on the neutral mesh
  std::vector<Eigen::Vector3f> barycentrics;    // N * N, in the triangle's corner order
  bool Covered(size_t texel) const { return triangle[texel] >= 0; }
};

// Rasterizes the rig's UV layout (OBJ convention, as render::SampleBilinear: texel (x, y) has
// its centre at u = (x + 0.5) / N, v = 1 - (y + 0.5) / N) into an N x N TexelMap.
// Triangles whose UV edges are more than 12 times longer per unit of surface length than the
// median triangle's (rims that join a chart to another, e.g. a mouth or eye pocket to the lip
// or lid margin) would smear over the charts they cross: they are left out, and the texels
// they pass over keep the triangle under them. Where two triangles cover a texel (charts made
// by front projection hold a front and a back), the one with the larger neutral z wins.
// The rig needs uvs and uv_triangles with a row per triangle.
TexelMap BakeTexelMap(const rig::Rig& rig, int N);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_TEXEL_MAP_H_
