#include "render/texel_map.h"

#include <algorithm>
#include <cmath>

namespace facecap::render {
namespace {

// Triangles whose UV edges are far longer than their surface edges warrant (rims that join a
// chart to another, e.g. a mouth or eye pocket to the lip or lid margin) would smear over the
// charts they cross: they are not baked, and show the texels their UVs pass over.
std::vector<bool> SmearingTriangles(const rig::Rig& rig) {
  const int F = static_cast<int>(rig.triangles.rows());
  std::vector<float> texel_density(F, 0.f);  // longest UV edge per unit surface length
  for (int f = 0; f < F; ++f) {
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3;
      const float uv_length = (rig.uvs.row(rig.uv_triangles(f, k1)) - rig.uvs.row(rig.uv_triangles(f, k))).norm();
      const float length = (rig.neutral.row(rig.triangles(f, k1)) - rig.neutral.row(rig.triangles(f, k))).norm();
      texel_density[f] = std::max(texel_density[f], uv_length / std::max(length, 1e-6f));
    }
  }
  std::vector<float> sorted_density = texel_density;
  std::nth_element(sorted_density.begin(), sorted_density.begin() + F / 2, sorted_density.end());
  const float max_density = 12.f * sorted_density[F / 2];
  std::vector<bool> smearing(F);
  for (int f = 0; f < F; ++f) smearing[f] = texel_density[f] > max_density;
  return smearing;
}

}  // namespace

TexelMap BakeTexelMap(const rig::Rig& rig, int N) {
  const int F = static_cast<int>(rig.triangles.rows());
  const std::vector<bool> smearing = SmearingTriangles(rig);
  TexelMap bake;
  bake.size = N;
  bake.triangle.assign(static_cast<size_t>(N) * N, -1);
  bake.position.assign(static_cast<size_t>(N) * N, Eigen::Vector3f::Zero());
  bake.barycentrics.assign(static_cast<size_t>(N) * N, Eigen::Vector3f::Zero());
  for (int f = 0; f < F; ++f) {
    if (smearing[f]) continue;
    Eigen::Vector2f t[3];
    Eigen::Vector3f p[3];
    for (int k = 0; k < 3; ++k) {
      const int uv = rig.uv_triangles(f, k);
      // Texel coordinates: texel i has its centre at u = (i + 0.5) / N, v = 1 - (j + 0.5) / N.
      t[k] = Eigen::Vector2f(rig.uvs(uv, 0) * N - 0.5f, (1.f - rig.uvs(uv, 1)) * N - 0.5f);
      p[k] = rig.neutral.row(rig.triangles(f, k)).transpose();
    }
    const float area = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x();
    if (std::abs(area) < 1e-12f) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].x(), t[1].x(), t[2].x()}))));
    const int x1 = std::min(N - 1, static_cast<int>(std::ceil(std::max({t[0].x(), t[1].x(), t[2].x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].y(), t[1].y(), t[2].y()}))));
    const int y1 = std::min(N - 1, static_cast<int>(std::ceil(std::max({t[0].y(), t[1].y(), t[2].y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2f q(static_cast<float>(x), static_cast<float>(y));
        auto edge = [&](const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
          return ((b - a).x() * (q - a).y() - (b - a).y() * (q - a).x()) / area;
        };
        const float b0 = edge(t[1], t[2]), b1 = edge(t[2], t[0]), b2 = edge(t[0], t[1]);
        constexpr float kEps = -1e-4f;
        if (b0 < kEps || b1 < kEps || b2 < kEps) continue;
        const size_t i = static_cast<size_t>(y) * N + x;
        const Eigen::Vector3f position = b0 * p[0] + b1 * p[1] + b2 * p[2];
        // Charts made by front projection (eyeballs) hold a front and a back: the front wins.
        if (bake.triangle[i] >= 0 && bake.position[i].z() >= position.z()) continue;
        bake.triangle[i] = f;
        bake.position[i] = position;
        bake.barycentrics[i] = Eigen::Vector3f(b0, b1, b2);
      }
    }
  }
  return bake;
}

}  // namespace facecap::render
