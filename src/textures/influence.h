// Influence maps (paper 001 Sec. 5.1, eq. 10-11): how much the skin around each vertex is
// compressed or stretched by an expression, as per-vertex values and as per-texel UV maps.
//
// E_N(x) and E_P(x) are the mean lengths of the edges from vertex x to its one-ring
// neighbours on the neutral N and on the expression P of the same person (mesh units, cm
// here). Eq. 10 and 11:
//   I_compress(x) = E_N(x) - E_P(x)  where E_P(x) < E_N(x), else 0
//   I_stretch(x)  = E_P(x) - E_N(x)  where E_P(x) > E_N(x), else 0
// Per-texel maps interpolate the vertex values with the barycentrics of the triangle that
// covers each texel (render::TexelMap); uncovered texels are 0. Stored as R = compress,
// G = stretch, as the paper stores them.
#ifndef FACECAP_TEXTURES_INFLUENCE_H_
#define FACECAP_TEXTURES_INFLUENCE_H_

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::textures {

// The one-ring neighbours of every vertex (the other ends of its triangle edges), CSR.
struct OneRing {
  std::vector<int> offset;    // #V + 1
  std::vector<int> neighbor;  // neighbours of vertex x: neighbor[offset[x] .. offset[x + 1])
  int NumVertices() const { return static_cast<int>(offset.size()) - 1; }
};
OneRing BuildOneRing(const rig::Triangles& triangles, int num_vertices);

// E(x): mean length of the edges from x to its one-ring neighbours (0 for a vertex of no
// triangle).
Eigen::VectorXf MeanEdgeLength(const OneRing& ring, const rig::Vertices& vertices);

struct VertexInfluence {
  Eigen::VectorXf compress;  // eq. 10, >= 0
  Eigen::VectorXf stretch;   // eq. 11, >= 0
};
// Eq. 10-11 from E_N and E_P.
VertexInfluence InfluenceValues(const Eigen::VectorXf& e_neutral, const Eigen::VectorXf& e_expression);

// Per-texel barycentric interpolation of per-vertex values over a rig's UV layout.
class TexelInterpolator {
 public:
  // Bakes the rig's N x N texel map (render::BakeTexelMap; the rig needs uvs and
  // uv_triangles).
  TexelInterpolator(const rig::Rig& rig, int size);

  int size() const { return size_; }
  int NumTexels() const { return size_ * size_; }
  bool Covered(int texel) const { return vertices_[texel][0] >= 0; }
  // The three vertices and barycentric weights of texel t (vertices -1 when uncovered).
  const std::array<int, 3>& TexelVertices(int t) const { return vertices_[t]; }
  const std::array<float, 3>& TexelWeights(int t) const { return weights_[t]; }
  // The point on the rig's neutral mesh under each texel (zero when uncovered).
  const std::vector<Eigen::Vector3f>& positions() const { return positions_; }

  // values: one per vertex (InvalidInputError otherwise); out: N * N floats, row-major (y down), 0 where uncovered.
  void Interpolate(const Eigen::VectorXf& values, float* out) const;
  std::vector<float> Interpolate(const Eigen::VectorXf& values) const;

 private:
  int size_ = 0;
  int num_vertices_ = 0;
  std::vector<std::array<int, 3>> vertices_;
  std::vector<std::array<float, 3>> weights_;
  std::vector<Eigen::Vector3f> positions_;
};

// The influence of an expression as an N x N x 2 map (R = compress, G = stretch),
// interleaved, from its vertex values.
std::vector<float> InfluenceMap(const TexelInterpolator& texels, const VertexInfluence& influence);

}  // namespace facecap::textures

#endif  // FACECAP_TEXTURES_INFLUENCE_H_
