#include "render/primitives.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "util/errors.h"

namespace facecap::render {

void Icosphere(int subdivisions, rig::Vertices* vertices, rig::Triangles* triangles) {
  if (subdivisions < 0) throw InvalidInputError("Icosphere: subdivisions must be >= 0");
  const float phi = (1.f + std::sqrt(5.f)) / 2.f;  // golden ratio
  std::vector<Eigen::Vector3f> points = {
      {-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
      {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
      {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  for (Eigen::Vector3f& p : points) p.normalize();
  std::vector<Eigen::Vector3i> faces = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
      {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
      {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
      {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<int, int>, int> midpoint_of_edge;
    auto midpoint = [&](int a, int b) {
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      auto found = midpoint_of_edge.find(key);
      if (found != midpoint_of_edge.end()) return found->second;
      points.push_back((points[a] + points[b]).normalized());
      const int index = static_cast<int>(points.size()) - 1;
      midpoint_of_edge.emplace(key, index);
      return index;
    };
    std::vector<Eigen::Vector3i> finer;
    finer.reserve(4 * faces.size());
    for (const Eigen::Vector3i& f : faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.emplace_back(f[0], ab, ca);
      finer.emplace_back(f[1], bc, ab);
      finer.emplace_back(f[2], ca, bc);
      finer.emplace_back(ab, bc, ca);
    }
    faces.swap(finer);
  }
  vertices->resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t i = 0; i < points.size(); ++i) vertices->row(i) = points[i].transpose();
  triangles->resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t t = 0; t < faces.size(); ++t) triangles->row(t) = faces[t].transpose();
}

rig::Rig IcosphereRig(int subdivisions, float radius, int num_regions) {
  if (num_regions < 1) throw InvalidInputError("IcosphereRig: num_regions must be >= 1");
  rig::Rig rig;
  rig::Vertices unit;
  Icosphere(subdivisions, &unit, &rig.triangles);
  rig.neutral = radius * unit;
  const int num_vertices = static_cast<int>(unit.rows());
  const int num_triangles = static_cast<int>(rig.triangles.rows());

  // Longitude around +y measured from +z (the front), latitude from the south pole.
  auto longitude_latitude = [](const Eigen::Vector3f& p) {
    const float u = 0.5f + std::atan2(p.x(), p.z()) / (2.f * static_cast<float>(M_PI));
    const float v = 0.5f + std::asin(std::clamp(p.y(), -1.f, 1.f)) / static_cast<float>(M_PI);
    return Eigen::Vector2f(u, v);
  };
  rig.uvs.resize(3 * num_triangles, 2);
  rig.uv_triangles.resize(num_triangles, 3);
  rig.triangle_region.resize(num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    Eigen::Vector2f corner_uv[3];
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f p = unit.row(rig.triangles(t, k)).transpose();
      corner_uv[k] = longitude_latitude(p);
      centroid += p / 3.f;
    }
    // Across the seam some corners sit near u = 1 and others near u = 0: unwrap.
    const float max_u = std::max({corner_uv[0].x(), corner_uv[1].x(), corner_uv[2].x()});
    for (int k = 0; k < 3; ++k) {
      if (max_u - corner_uv[k].x() > 0.5f) corner_uv[k].x() += 1.f;
      rig.uvs.row(3 * t + k) = corner_uv[k].transpose();
      rig.uv_triangles(t, k) = 3 * t + k;
    }
    const float centroid_u = longitude_latitude(centroid.normalized()).x();
    rig.triangle_region[t] =
        std::min(num_regions - 1, static_cast<int>(centroid_u * static_cast<float>(num_regions)));
  }
  for (int r = 0; r < num_regions; ++r) {
    // Distinct colours around the hue circle.
    const float hue = static_cast<float>(r) / static_cast<float>(num_regions);
    Eigen::Vector3f color;
    for (int c = 0; c < 3; ++c) {
      color[c] = 0.5f + 0.5f * std::cos(2.f * static_cast<float>(M_PI) * (hue + c / 3.f));
    }
    rig.regions.push_back({"sector_" + std::to_string(r), color});
  }
  // Landmarks: the vertices closest to the front pole, the back pole and the upper front.
  auto closest_vertex = [&](const Eigen::Vector3f& direction) {
    int best = 0;
    (unit * direction).maxCoeff(&best);
    return best;
  };
  rig.landmarks.resize(3);
  rig.landmarks << closest_vertex(Eigen::Vector3f::UnitZ()),
      closest_vertex(-Eigen::Vector3f::UnitZ()),
      closest_vertex(Eigen::Vector3f(0.f, 1.f, 1.f).normalized());
  rig.jaw_weights = Eigen::VectorXf::Zero(num_vertices);
  return rig;
}

}  // namespace facecap::render
