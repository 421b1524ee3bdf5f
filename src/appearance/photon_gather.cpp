#include "appearance/photon_gather.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>

#include <nanoflann.hpp>

#include "render/shading.h"
#include "util/errors.h"

namespace facecap::appearance {
namespace {

// The particles of one chart in texel units, as nanoflann reads a point cloud.
struct ChartCloud {
  std::vector<Eigen::Vector2f> points;  // texel coordinates
  std::vector<int32_t> index;           // into the particle list
  size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return points[i][static_cast<int>(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox& /*bb*/) const { return false; }
};

using ChartTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, ChartCloud>, ChartCloud, 2, uint32_t>;

int FindRoot(std::vector<int>* parent, int i) {
  while ((*parent)[i] != i) {
    (*parent)[i] = (*parent)[(*parent)[i]];
    i = (*parent)[i];
  }
  return i;
}

// A UV position in texel coordinates of an N x N texture (texel (x, y) centred at (x, y)).
Eigen::Vector2f TexelCoordinates(const Eigen::Vector2f& uv, int N) {
  return Eigen::Vector2f(uv.x() * N - 0.5f, (1.f - uv.y()) * N - 0.5f);
}

}  // namespace

std::vector<int32_t> UVCharts(const rig::Rig& rig) {
  const int F = static_cast<int>(rig.uv_triangles.rows());
  std::vector<int> parent(rig.uvs.rows());
  std::iota(parent.begin(), parent.end(), 0);
  for (int f = 0; f < F; ++f) {
    const int a = FindRoot(&parent, rig.uv_triangles(f, 0));
    for (int k = 1; k < 3; ++k) {
      const int b = FindRoot(&parent, rig.uv_triangles(f, k));
      if (a != b) parent[b] = a;
    }
  }
  std::vector<int32_t> chart(F), number_of_root(parent.size(), -1);
  int32_t next = 0;
  for (int f = 0; f < F; ++f) {
    const int root = FindRoot(&parent, rig.uv_triangles(f, 0));
    if (number_of_root[root] < 0) number_of_root[root] = next++;
    chart[f] = number_of_root[root];
  }
  return chart;
}

bool GatherOptions::Check(std::string* why) const {
  if (neighbours < 1) {
    *why = "neighbours must be at least 1";
    return false;
  }
  if (!(max_radius_texels > 0.f) || !std::isfinite(max_radius_texels)) {
    *why = "max_radius_texels must be positive and finite";
    return false;
  }
  if (!(min_distance_texels > 0.f) || !std::isfinite(min_distance_texels)) {
    *why = "min_distance_texels must be positive and finite";
    return false;
  }
  return true;
}

GatheredTexture GatherParticles(const std::vector<Particle>& particles,
                                const render::TexelMap& texels,
                                const std::vector<int32_t>& charts, const GatherOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("photon gathering: " + why);
  const int N = texels.size;
  const int num_charts =
      charts.empty() ? 0 : *std::max_element(charts.begin(), charts.end()) + 1;
  // 1. The particles by chart, in texel units, and the count of each texel.
  GatheredTexture out;
  out.color = ImageF(N, N, 3);
  out.confidence = ImageF(N, N, 1);
  out.count = Image<int32_t>(N, N, 1);
  std::vector<ChartCloud> clouds(num_charts);
  for (size_t i = 0; i < particles.size(); ++i) {
    const Particle& p = particles[i];
    if (p.chart < 0 || p.chart >= num_charts) {
      throw InvalidInputError("photon gathering: particle " + std::to_string(i) + " has chart " +
                              std::to_string(p.chart) + ", the rig has " +
                              std::to_string(num_charts));
    }
    if (!p.uv.allFinite() || !p.color.allFinite()) {
      throw InvalidInputError("photon gathering: particle " + std::to_string(i) +
                              " has a value that is not finite");
    }
    const Eigen::Vector2f t = TexelCoordinates(p.uv, N);
    clouds[p.chart].points.push_back(t);
    clouds[p.chart].index.push_back(static_cast<int32_t>(i));
    const int x = static_cast<int>(std::lround(t.x())), y = static_cast<int>(std::lround(t.y()));
    if (x >= 0 && x < N && y >= 0 && y < N) ++out.count.at(x, y);
  }
  std::vector<std::unique_ptr<ChartTree>> trees(num_charts);
  for (int c = 0; c < num_charts; ++c) {
    if (clouds[c].points.size() < static_cast<size_t>(options.neighbours)) continue;
    trees[c] = std::make_unique<ChartTree>(2, clouds[c], nanoflann::KDTreeSingleIndexAdaptorParams(10));
    trees[c]->buildIndex();
  }
  // 2. Each texel of the layout gathers its k nearest particles of its chart.
  const size_t k = static_cast<size_t>(options.neighbours);
  const float full_radius = std::sqrt(static_cast<float>(options.neighbours) / 3.14159265f);
  const float max_sq = options.max_radius_texels * options.max_radius_texels;
#pragma omp parallel
  {
    std::vector<uint32_t> found(k);
    std::vector<float> dist_sq(k);
#pragma omp for schedule(dynamic, 8)
    for (int y = 0; y < N; ++y) {
      for (int x = 0; x < N; ++x) {
        const size_t texel = static_cast<size_t>(y) * N + x;
        if (!texels.Covered(texel)) continue;
        const int chart = charts[texels.triangle[texel]];
        const ChartTree* tree = trees[chart].get();
        if (tree == nullptr) continue;
        const float query[2] = {static_cast<float>(x), static_cast<float>(y)};
        const size_t n = tree->knnSearch(query, k, found.data(), dist_sq.data());
        if (n < k || dist_sq[n - 1] > max_sq) continue;
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        float weight_sum = 0.f;
        for (size_t j = 0; j < n; ++j) {
          const float w = 1.f / std::max(std::sqrt(dist_sq[j]), options.min_distance_texels);
          sum += w * particles[clouds[chart].index[found[j]]].color;
          weight_sum += w;
        }
        const Eigen::Vector3f color = sum / weight_sum;
        for (int c = 0; c < 3; ++c) out.color.at(x, y, c) = color[c];
        const float radius = std::max(std::sqrt(dist_sq[n - 1]), 1e-6f);
        out.confidence.at(x, y) = std::min(1.f, full_radius / radius);
      }
    }
  }
  return out;
}

namespace {

// One pyramid level: premultiplied colour (3 channels) and weight (1 channel).
struct Level {
  ImageF color, weight;
};

Level Halve(const Level& fine) {
  const int w = (fine.color.width + 1) / 2, h = (fine.color.height + 1) / 2;
  Level coarse{ImageF(w, h, 3), ImageF(w, h, 1)};
  for (int y = 0; y < fine.color.height; ++y) {
    for (int x = 0; x < fine.color.width; ++x) {
      coarse.weight.at(x / 2, y / 2) += fine.weight.at(x, y);
      for (int c = 0; c < 3; ++c) coarse.color.at(x / 2, y / 2, c) += fine.color.at(x, y, c);
    }
  }
  return coarse;
}

}  // namespace

void FillHoles(const ImageF& confidence, ImageF* color) {
  const int W = color->width, H = color->height;
  std::vector<Level> pyramid(1, Level{ImageF(W, H, 3), ImageF(W, H, 1)});
  bool any = false;
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const float w = confidence.at(x, y) > 0.f ? confidence.at(x, y) : 0.f;
      any = any || w > 0.f;
      pyramid[0].weight.at(x, y) = w;
      for (int c = 0; c < 3; ++c) pyramid[0].color.at(x, y, c) = w * color->at(x, y, c);
    }
  }
  if (!any) return;
  while (pyramid.back().color.width > 1 || pyramid.back().color.height > 1) {
    pyramid.push_back(Halve(pyramid.back()));
  }
  // Pull: from the coarsest level up, each level's texels become colours (normalized), and
  // texels without weight take the coarser level's value at their centre.
  std::vector<ImageF> filled(pyramid.size());
  for (size_t l = pyramid.size(); l-- > 0;) {
    const Level& level = pyramid[l];
    const int w = level.color.width, h = level.color.height;
    filled[l] = ImageF(w, h, 3);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float weight = level.weight.at(x, y);
        if (weight > 0.f) {
          for (int c = 0; c < 3; ++c) filled[l].at(x, y, c) = level.color.at(x, y, c) / weight;
          continue;
        }
        // The coarser level (it exists: the coarsest level has weight) at this texel's centre.
        const ImageF& coarse = filled[l + 1];
        const Eigen::Vector3f c = render::SampleBilinear(
            coarse, (x + 0.5f) / (2.f * coarse.width), 1.f - (y + 0.5f) / (2.f * coarse.height));
        for (int k = 0; k < 3; ++k) filled[l].at(x, y, k) = c[k];
      }
    }
  }
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      if (confidence.at(x, y) > 0.f) continue;
      for (int c = 0; c < 3; ++c) color->at(x, y, c) = filled[0].at(x, y, c);
    }
  }
}

void SilhouetteInterior(const ImageF& uv_image, int margin, ImageF* mask) {
  const int W = uv_image.width, H = uv_image.height;
  *mask = ImageF(W, H, 1);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      bool inside = true;
      for (int dy = -margin; dy <= margin && inside; ++dy) {
        for (int dx = -margin; dx <= margin && inside; ++dx) {
          const int xx = x + dx, yy = y + dy;
          inside = xx >= 0 && xx < W && yy >= 0 && yy < H && uv_image.at(xx, yy, 2) > 0.5f;
        }
      }
      mask->at(x, y) = inside ? 1.f : 0.f;
    }
  }
}

void AppendImageParticles(const ImageF& image, const ImageF& uv_image,
                          const Image<int32_t>& triangles, const std::vector<int32_t>& charts,
                          const ImageF* mask, std::vector<Particle>* particles) {
  const auto same_size = [&](int w, int h) { return w == image.width && h == image.height; };
  if (image.channels < 3 || uv_image.channels < 3 || !same_size(uv_image.width, uv_image.height) ||
      !same_size(triangles.width, triangles.height) ||
      (mask != nullptr && !same_size(mask->width, mask->height))) {
    throw InvalidInputError("photon gathering: the image, U(I), triangle and mask images differ in size");
  }
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const int32_t t = triangles.at(x, y);
      if (t < 0 || uv_image.at(x, y, 2) <= 0.5f) continue;
      if (mask != nullptr && mask->at(x, y) <= 0.5f) continue;
      if (t >= static_cast<int32_t>(charts.size())) {
        throw InvalidInputError("photon gathering: pixel (" + std::to_string(x) + ", " +
                                std::to_string(y) + ") shows triangle " + std::to_string(t) +
                                ", the rig has " + std::to_string(charts.size()));
      }
      Particle p;
      p.uv = Eigen::Vector2f(uv_image.at(x, y, 0), uv_image.at(x, y, 1));
      p.color = Eigen::Vector3f(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
      p.chart = charts[t];
      particles->push_back(p);
    }
  }
}

}  // namespace facecap::appearance
