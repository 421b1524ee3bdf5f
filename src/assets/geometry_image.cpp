#include "assets/geometry_image.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

#include "util/errors.h"

namespace facecap::assets {
namespace {

// Texture coordinate of each vertex: that of its first corner in uv_triangles.
std::vector<Eigen::Vector2f> VertexUVs(const rig::Rig& topology) {
  std::vector<Eigen::Vector2f> uv(topology.NumVertices(),
                                  Eigen::Vector2f::Constant(std::numeric_limits<float>::quiet_NaN()));
  std::vector<uint8_t> seen(topology.NumVertices(), 0);
  for (int f = 0; f < topology.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = topology.triangles(f, c);
      if (seen[v]) continue;
      seen[v] = 1;
      uv[v] = topology.uvs.row(topology.uv_triangles(f, c)).transpose();
    }
  }
  return uv;
}

}  // namespace

bool GeometryImageOptions::Check(std::string* why) const {
  if (size < 8 || size > 512) {
    *why = "geometry image size must be in [8, 512], got " + std::to_string(size);
    return false;
  }
  if (!(margin >= 0.f && margin < 0.5f)) {
    *why = "geometry image margin must be in [0, 0.5)";
    return false;
  }
  return true;
}

std::vector<int> ChartVertices(const rig::Rig& topology, const std::vector<int>& vertices,
                               float v_min) {
  const auto uv = VertexUVs(topology);
  std::vector<int> out;
  for (int v : vertices) {
    if (std::isfinite(uv[v].y()) && uv[v].y() >= v_min) out.push_back(v);
  }
  return out;
}

GeometryImageLayout::GeometryImageLayout(const rig::Rig& topology,
                                         const std::vector<int>& chart_vertices,
                                         const GeometryImageOptions& options)
    : size_(options.size), chart_vertices_(chart_vertices) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError(why);
  if (topology.uvs.rows() == 0 || topology.uv_triangles.rows() != topology.triangles.rows()) {
    throw InvalidInputError("geometry image: the mesh has no texture coordinates");
  }
  if (chart_vertices.empty()) throw InvalidInputError("geometry image: no chart vertices");
  const auto vertex_uv = VertexUVs(topology);
  Eigen::Vector2f lo = Eigen::Vector2f::Constant(1e30f), hi = Eigen::Vector2f::Constant(-1e30f);
  for (int v : chart_vertices) {
    if (!std::isfinite(vertex_uv[v].x())) {
      throw InvalidInputError("geometry image: chart vertex " + std::to_string(v) +
                              " is in no triangle");
    }
    lo = lo.cwiseMin(vertex_uv[v]);
    hi = hi.cwiseMax(vertex_uv[v]);
  }
  lo.array() -= options.margin;
  hi.array() += options.margin;
  const float n = static_cast<float>(size_);
  // Pixel coordinates (continuous, pixel centres at integer + 0.5) of a texture coordinate.
  auto to_pixel = [&](const Eigen::Vector2f& uv) {
    return Eigen::Vector2f((uv.x() - lo.x()) / (hi.x() - lo.x()) * n,
                           (hi.y() - uv.y()) / (hi.y() - lo.y()) * n);
  };
  const int P = NumPixels();
  coverage_.assign(P, 0);
  pixel_vertices_.assign(P, {0, 0, 0});
  pixel_weights_.assign(P, {0.f, 0.f, 0.f});
  for (int f = 0; f < topology.triangles.rows(); ++f) {
    Eigen::Vector2f p[3];
    bool inside = true;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector2f uv = topology.uvs.row(topology.uv_triangles(f, c)).transpose();
      if ((uv.array() < lo.array()).any() || (uv.array() > hi.array()).any()) {
        inside = false;
      }
      p[c] = to_pixel(uv);
    }
    if (!inside) continue;
    const float area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (std::abs(area) < 1e-12f) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}))));
    const int x1 = std::min(size_ - 1, static_cast<int>(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}))));
    const int y1 = std::min(size_ - 1, static_cast<int>(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2f q(x + 0.5f, y + 0.5f);
        auto edge = [&](const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
          return ((b - a).x() * (q - a).y() - (b - a).y() * (q - a).x()) / area;
        };
        const float b0 = edge(p[1], p[2]), b1 = edge(p[2], p[0]), b2 = edge(p[0], p[1]);
        const float eps = -1e-6f;
        if (b0 < eps || b1 < eps || b2 < eps) continue;
        const int pixel = y * size_ + x;
        if (coverage_[pixel]) continue;  // the first triangle wins
        coverage_[pixel] = 1;
        pixel_vertices_[pixel] = {topology.triangles(f, 0), topology.triangles(f, 1),
                                  topology.triangles(f, 2)};
        pixel_weights_[pixel] = {b0, b1, b2};
      }
    }
  }
  // Fill uncovered pixels from the nearest covered one (breadth-first, 4-neighbourhood).
  std::deque<int> queue;
  std::vector<uint8_t> filled(coverage_);
  for (int p = 0; p < P; ++p) if (coverage_[p]) queue.push_back(p);
  if (queue.empty()) throw InvalidInputError("geometry image: no triangle lies in the chart window");
  while (!queue.empty()) {
    const int p = queue.front();
    queue.pop_front();
    const int x = p % size_, y = p / size_;
    const int neighbours[4][2] = {{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}};
    for (const auto& nb : neighbours) {
      if (nb[0] < 0 || nb[1] < 0 || nb[0] >= size_ || nb[1] >= size_) continue;
      const int q = nb[1] * size_ + nb[0];
      if (filled[q]) continue;
      filled[q] = 1;
      pixel_vertices_[q] = pixel_vertices_[p];
      pixel_weights_[q] = pixel_weights_[p];
      queue.push_back(q);
    }
  }
  // Bilinear stencils of the chart vertices.
  for (int v : chart_vertices_) {
    const Eigen::Vector2f q = to_pixel(vertex_uv[v]) - Eigen::Vector2f(0.5f, 0.5f);
    const float fx = std::clamp(q.x(), 0.f, n - 1.f), fy = std::clamp(q.y(), 0.f, n - 1.f);
    const int ix = std::min(static_cast<int>(fx), size_ - 2), iy = std::min(static_cast<int>(fy), size_ - 2);
    const float tx = fx - ix, ty = fy - iy;
    sample_pixels_.push_back({iy * size_ + ix, iy * size_ + ix + 1, (iy + 1) * size_ + ix,
                              (iy + 1) * size_ + ix + 1});
    sample_weights_.push_back({(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty});
  }
}

std::vector<float> GeometryImageLayout::Render(const rig::Vertices& vertices) const {
  return RenderColumn(Eigen::Map<const Eigen::VectorXf>(vertices.data(), vertices.size()));
}

std::vector<float> GeometryImageLayout::RenderColumn(
    const Eigen::Ref<const Eigen::VectorXf>& values) const {
  std::vector<float> image(3 * static_cast<size_t>(NumPixels()));
  for (int p = 0; p < NumPixels(); ++p) {
    for (int c = 0; c < 3; ++c) {
      float value = 0.f;
      for (int k = 0; k < 3; ++k) value += pixel_weights_[p][k] * values[3 * pixel_vertices_[p][k] + c];
      image[3 * static_cast<size_t>(p) + c] = value;
    }
  }
  return image;
}

Eigen::MatrixXf GeometryImageLayout::Sample(const float* image, int channels) const {
  Eigen::MatrixXf out(static_cast<int>(chart_vertices_.size()), channels);
  for (size_t k = 0; k < chart_vertices_.size(); ++k) {
    for (int c = 0; c < channels; ++c) {
      float value = 0.f;
      for (int j = 0; j < 4; ++j) {
        value += sample_weights_[k][j] * image[static_cast<size_t>(sample_pixels_[k][j]) * channels + c];
      }
      out(static_cast<int>(k), c) = value;
    }
  }
  return out;
}

RoundTripError GeometryImageRoundTrip(const GeometryImageLayout& layout,
                                      const rig::Vertices& vertices) {
  const std::vector<float> image = layout.Render(vertices);
  const Eigen::MatrixXf sampled = layout.Sample(image.data(), 3);
  RoundTripError error;
  const auto& ids = layout.chart_vertices();
  for (size_t k = 0; k < ids.size(); ++k) {
    const double d = (sampled.row(static_cast<int>(k)) - vertices.row(ids[k])).norm();
    error.mean_cm += d;
    error.max_cm = std::max(error.max_cm, d);
  }
  error.mean_cm /= static_cast<double>(ids.size());
  return error;
}

}  // namespace facecap::assets
