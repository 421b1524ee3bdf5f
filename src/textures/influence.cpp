#include "textures/influence.h"

#include <algorithm>

#include "render/texel_map.h"
#include "util/errors.h"

namespace facecap::textures {

OneRing BuildOneRing(const rig::Triangles& triangles, int num_vertices) {
  std::vector<std::vector<int>> lists(num_vertices);
  for (int f = 0; f < triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = triangles(f, c), b = triangles(f, (c + 1) % 3);
      if (a < 0 || b < 0 || a >= num_vertices || b >= num_vertices) {
        throw InvalidInputError("triangle " + std::to_string(f) + " names a vertex outside [0, " +
                                std::to_string(num_vertices) + ")");
      }
      lists[a].push_back(b);
      lists[b].push_back(a);
    }
  }
  OneRing ring;
  ring.offset.assign(num_vertices + 1, 0);
  for (int v = 0; v < num_vertices; ++v) {
    std::sort(lists[v].begin(), lists[v].end());
    lists[v].erase(std::unique(lists[v].begin(), lists[v].end()), lists[v].end());
    ring.offset[v + 1] = ring.offset[v] + static_cast<int>(lists[v].size());
  }
  ring.neighbor.reserve(ring.offset.back());
  for (const auto& l : lists) ring.neighbor.insert(ring.neighbor.end(), l.begin(), l.end());
  return ring;
}

Eigen::VectorXf MeanEdgeLength(const OneRing& ring, const rig::Vertices& vertices) {
  const int V = ring.NumVertices();
  if (vertices.rows() != V) {
    throw InvalidInputError("mesh has " + std::to_string(vertices.rows()) + " vertices, the topology " +
                            std::to_string(V));
  }
  Eigen::VectorXf e = Eigen::VectorXf::Zero(V);
  for (int v = 0; v < V; ++v) {
    const int begin = ring.offset[v], end = ring.offset[v + 1];
    if (begin == end) continue;
    double sum = 0;
    for (int k = begin; k < end; ++k) sum += (vertices.row(ring.neighbor[k]) - vertices.row(v)).norm();
    e[v] = static_cast<float>(sum / (end - begin));
  }
  return e;
}

VertexInfluence InfluenceValues(const Eigen::VectorXf& e_neutral, const Eigen::VectorXf& e_expression) {
  if (e_neutral.size() != e_expression.size()) throw InvalidInputError("influence: edge lengths of different meshes");
  VertexInfluence out;
  out.compress = (e_neutral - e_expression).cwiseMax(0.f);
  out.stretch = (e_expression - e_neutral).cwiseMax(0.f);
  return out;
}

TexelInterpolator::TexelInterpolator(const rig::Rig& rig, int size)
    : size_(size), num_vertices_(rig.NumVertices()) {
  const render::TexelMap map = render::BakeTexelMap(rig, size);
  const int n = size * size;
  vertices_.assign(n, {-1, -1, -1});
  weights_.assign(n, {0.f, 0.f, 0.f});
  positions_.assign(n, Eigen::Vector3f::Zero());
  for (int t = 0; t < n; ++t) {
    if (!map.Covered(t)) continue;
    const int f = map.triangle[t];
    for (int c = 0; c < 3; ++c) {
      vertices_[t][c] = rig.triangles(f, c);
      weights_[t][c] = map.barycentrics[t][c];
    }
    positions_[t] = map.position[t];
  }
}

void TexelInterpolator::Interpolate(const Eigen::VectorXf& values, float* out) const {
  if (values.size() != num_vertices_) {
    throw InvalidInputError("texel interpolation: " + std::to_string(values.size()) + " values for " +
                            std::to_string(num_vertices_) + " vertices");
  }
  for (int t = 0; t < NumTexels(); ++t) {
    const auto& v = vertices_[t];
    if (v[0] < 0) {
      out[t] = 0.f;
      continue;
    }
    const auto& w = weights_[t];
    out[t] = w[0] * values[v[0]] + w[1] * values[v[1]] + w[2] * values[v[2]];
  }
}

std::vector<float> TexelInterpolator::Interpolate(const Eigen::VectorXf& values) const {
  std::vector<float> out(NumTexels());
  Interpolate(values, out.data());
  return out;
}

std::vector<float> InfluenceMap(const TexelInterpolator& texels, const VertexInfluence& influence) {
  const std::vector<float> c = texels.Interpolate(influence.compress);
  const std::vector<float> s = texels.Interpolate(influence.stretch);
  std::vector<float> out(2 * c.size());
  for (size_t t = 0; t < c.size(); ++t) {
    out[2 * t] = c[t];
    out[2 * t + 1] = s[t];
  }
  return out;
}

}  // namespace facecap::textures
