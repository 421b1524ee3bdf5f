#include "track/soft_segmentation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

#include "util/errors.h"

namespace facecap::track {

bool SoftSegmentationOptions::Check(std::string* why) const {
  if (!(edge_width_px > 0.f && edge_width_px <= 8.f)) {
    *why = "edge_width_px must be in (0, 8]";
    return false;
  }
  if (!(visibility_depth_tolerance >= 0.f && visibility_depth_tolerance < 1.f)) {
    *why = "visibility_depth_tolerance must be in [0, 1)";
    return false;
  }
  if (!((background_color.array() >= 0.f).all() && (background_color.array() <= 1.f).all())) {
    *why = "background_color must be RGB in [0, 1]";
    return false;
  }
  return true;
}

std::vector<Eigen::Vector3f> RigRegionColors(const rig::Rig& rig) {
  std::vector<Eigen::Vector3f> colors;
  colors.reserve(rig.regions.size());
  for (const auto& r : rig.regions) colors.push_back(r.color);
  return colors;
}

SoftSegmentationRenderer::SoftSegmentationRenderer(const rig::Rig& rig,
                                                   std::vector<Eigen::Vector3f> region_colors,
                                                   const SoftSegmentationOptions& options)
    : rig_(rig), region_colors_(std::move(region_colors)), options_(options) {
  std::string why;
  if (!options_.Check(&why)) throw InvalidInputError("soft segmentation: " + why);
  if (region_colors_.size() != rig_.regions.size()) {
    throw InvalidInputError("soft segmentation: " + std::to_string(region_colors_.size()) +
                            " region colours for a rig with " +
                            std::to_string(rig_.regions.size()) + " regions");
  }
  // Undirected edges with their (up to two) faces: sort (v0, v1, face) triples.
  const int num_faces = static_cast<int>(rig_.triangles.rows());
  struct HalfEdge {
    int v0, v1, face;
  };
  std::vector<HalfEdge> half;
  half.reserve(3 * static_cast<size_t>(num_faces));
  for (int f = 0; f < num_faces; ++f) {
    for (int k = 0; k < 3; ++k) {
      int a = rig_.triangles(f, k), b = rig_.triangles(f, (k + 1) % 3);
      if (a > b) std::swap(a, b);
      half.push_back({a, b, f});
    }
  }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return std::tie(x.v0, x.v1, x.face) < std::tie(y.v0, y.v1, y.face);
  });
  for (size_t i = 0; i < half.size();) {
    size_t j = i + 1;
    while (j < half.size() && half[j].v0 == half[i].v0 && half[j].v1 == half[i].v1) ++j;
    // Manifold edges have two faces; more (non-manifold) are paired with the first.
    if (j - i == 1) {
      edges_.push_back({half[i].v0, half[i].v1, half[i].face, -1});
    } else {
      for (size_t k = i + 1; k < j; ++k) {
        edges_.push_back({half[i].v0, half[i].v1, half[i].face, half[k].face});
      }
    }
    i = j;
  }
}

namespace {

// d u / d X of the pinhole projection (2 x 3), camera.h conventions.
Eigen::Matrix<float, 2, 3> ProjectionJacobian(const render::Camera& camera,
                                              const Eigen::Vector3f& x) {
  const float z = x.z();
  Eigen::Matrix<float, 2, 3> j;
  j << -camera.fx / z, 0.f, camera.fx * x.x() / (z * z),
       0.f, camera.fy / z, -camera.fy * x.y() / (z * z);
  return j;
}

float Cross(const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

void SoftSegmentationRenderer::Render(const rig::Vertices& camera_vertices,
                                      const render::Camera& camera, SoftRender* out) const {
  render::RasterizeOptions raster;
  raster.barycentrics = false;  // triangle ids and depth are all this render reads
  render::Rasterize(camera_vertices, rig_.triangles, camera, &out->gbuffer, raster);
  HardColors(out);
  ScreenAndFacing(camera_vertices, camera, out);
  BorderEdges(out);
  NearestBorderEdges(out);
  SoftColors(camera_vertices, camera, out);
}

void SoftSegmentationRenderer::HardColors(SoftRender* out) const {
  const render::GBuffer& g = out->gbuffer;
  const int num_pixels = g.NumPixels();
  out->color.resize(3 * static_cast<size_t>(num_pixels));
  for (int p = 0; p < num_pixels; ++p) {
    const int t = g.triangle[p];
    const Eigen::Vector3f c =
        t >= 0 ? region_colors_[rig_.triangle_region[t]] : options_.background_color;
    out->color[3 * p] = c.x();
    out->color[3 * p + 1] = c.y();
    out->color[3 * p + 2] = c.z();
  }
  out->hard_color = out->color;
}

void SoftSegmentationRenderer::ScreenAndFacing(const rig::Vertices& camera_vertices,
                                               const render::Camera& camera, SoftRender* out) const {
  const rig::Triangles& tris = rig_.triangles;
  const int num_vertices = static_cast<int>(camera_vertices.rows());
  out->screen.resize(num_vertices);
  for (int v = 0; v < num_vertices; ++v) {
    out->screen[v] = camera.Project(camera_vertices.row(v).transpose());
  }
  const float near_depth = render::RasterizeOptions().near_depth;
  const int num_faces = static_cast<int>(tris.rows());
  out->front.resize(num_faces);
  for (int f = 0; f < num_faces; ++f) {
    const Eigen::Vector3f& a = out->screen[tris(f, 0)];
    const Eigen::Vector3f& b = out->screen[tris(f, 1)];
    const Eigen::Vector3f& c = out->screen[tris(f, 2)];
    const bool in_front = a.z() >= near_depth && b.z() >= near_depth && c.z() >= near_depth;
    // Counter-clockwise in camera space is clockwise on the y-down screen: negative area.
    out->front[f] = in_front && Cross((b - a).head<2>(), (c - a).head<2>()) < 0.f;
  }
}

void SoftSegmentationRenderer::BorderEdges(SoftRender* out) const {
  const rig::Triangles& tris = rig_.triangles;
  const render::GBuffer& g = out->gbuffer;
  const int W = g.width, H = g.height;
  auto front_facing = [&](int f) { return f >= 0 && out->front[f] != 0; };
  auto hard_color_at = [&](const Eigen::Vector2f& uv) -> Eigen::Vector3f {
    const int x = static_cast<int>(std::floor(uv.x())), y = static_cast<int>(std::floor(uv.y()));
    if (x < 0 || y < 0 || x >= W || y >= H) return options_.background_color;
    const int t = g.triangle[g.PixelIndex(x, y)];
    return t >= 0 ? region_colors_[rig_.triangle_region[t]] : options_.background_color;
  };
  auto opposite_vertex = [&](int f, int v0, int v1) {
    for (int k = 0; k < 3; ++k) {
      if (tris(f, k) != v0 && tris(f, k) != v1) return tris(f, k);
    }
    return tris(f, 0);
  };

  // Visible border edges, their face A and side colours.
  out->border_edges.clear();
  out->edge_side_a.clear();
  out->edge_colors.clear();
  const float tol = options_.visibility_depth_tolerance;
  for (int e = 0; e < static_cast<int>(edges_.size()); ++e) {
    const MeshEdge& edge = edges_[e];
    const bool front0 = front_facing(edge.face0), front1 = front_facing(edge.face1);
    int face_a;
    bool silhouette;
    if (front0 && front1) {
      if (rig_.triangle_region[edge.face0] == rig_.triangle_region[edge.face1]) continue;
      face_a = edge.face0;
      silhouette = false;
    } else if (front0 != front1) {
      face_a = front0 ? edge.face0 : edge.face1;
      silhouette = true;
    } else {
      continue;
    }
    const Eigen::Vector3f& s0 = out->screen[edge.v0];
    const Eigen::Vector3f& s1 = out->screen[edge.v1];
    const Eigen::Vector3f mid = 0.5f * (s0 + s1);
    const int mx = static_cast<int>(std::floor(mid.x())), my = static_cast<int>(std::floor(mid.y()));
    if (mx < -1 || my < -1 || mx > W || my > H) continue;
    float farthest = 0.f;
    for (int y = my - 1; y <= my + 1; ++y) {
      for (int x = mx - 1; x <= mx + 1; ++x) {
        const float depth = (x < 0 || y < 0 || x >= W || y >= H)
                                ? std::numeric_limits<float>::infinity()
                                : g.depth[g.PixelIndex(x, y)];
        farthest = std::max(farthest, depth);
      }
    }
    if (mid.z() > farthest * (1.f + tol)) continue;  // hidden behind another surface
    const Eigen::Vector2f dir = (s1 - s0).head<2>();
    const float length = dir.norm();
    if (length < 1e-6f) continue;
    const Eigen::Vector3f& opp = out->screen[opposite_vertex(face_a, edge.v0, edge.v1)];
    const float side = Cross(dir, (opp - s0).head<2>()) >= 0.f ? 1.f : -1.f;
    const Eigen::Vector3f color_a = region_colors_[rig_.triangle_region[face_a]];
    Eigen::Vector3f color_b;
    if (silhouette) {
      // What lies behind: the hard colour 1.5 pixels across the edge on side B.
      const Eigen::Vector2f normal_a = side * Eigen::Vector2f(-dir.y(), dir.x()) / length;
      color_b = hard_color_at(mid.head<2>() - 1.5f * normal_a);
    } else {
      color_b = region_colors_[rig_.triangle_region[edge.face1]];
    }
    if ((color_a - color_b).squaredNorm() == 0.f) continue;
    out->border_edges.push_back(e);
    out->edge_side_a.push_back(side > 0.f ? 1 : -1);
    out->edge_colors.push_back(color_a);
    out->edge_colors.push_back(color_b);
  }
}

void SoftSegmentationRenderer::NearestBorderEdges(SoftRender* out) const {
  const render::GBuffer& g = out->gbuffer;
  const int W = g.width, H = g.height, num_pixels = g.NumPixels();
  const float w = options_.edge_width_px;
  // Nearest border edge of every pixel within w (segment distance), edges in ascending order
  // and ties kept by the first: the result does not depend on anything but the geometry.
  out->best_distance.assign(num_pixels, std::numeric_limits<float>::infinity());
  out->best_edge.assign(num_pixels, -1);
  for (int k = 0; k < static_cast<int>(out->border_edges.size()); ++k) {
    const MeshEdge& edge = edges_[out->border_edges[k]];
    const Eigen::Vector2f a = out->screen[edge.v0].head<2>(), b = out->screen[edge.v1].head<2>();
    const Eigen::Vector2f ab = b - a;
    const float len2 = ab.squaredNorm();
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min(a.x(), b.x()) - w - 0.5f)));
    const int x1 = std::min(W - 1, static_cast<int>(std::floor(std::max(a.x(), b.x()) + w - 0.5f)));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min(a.y(), b.y()) - w - 0.5f)));
    const int y1 = std::min(H - 1, static_cast<int>(std::floor(std::max(a.y(), b.y()) + w - 0.5f)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2f q(x + 0.5f, y + 0.5f);
        const float t = std::clamp((q - a).dot(ab) / len2, 0.f, 1.f);
        const float dist = (q - a - t * ab).norm();
        const int p = y * W + x;
        if (dist < w && dist < out->best_distance[p]) {
          out->best_distance[p] = dist;
          out->best_edge[p] = k;
        }
      }
    }
  }
}

void SoftSegmentationRenderer::SoftColors(const rig::Vertices& camera_vertices,
                                          const render::Camera& camera, SoftRender* out) const {
  const render::GBuffer& g = out->gbuffer;
  const int W = g.width, num_pixels = g.NumPixels();
  const float w = options_.edge_width_px;
  // Soft colours and their derivatives.
  out->edge_pixels.clear();
  for (int p = 0; p < num_pixels; ++p) {
    const int k = out->best_edge[p];
    if (k < 0) continue;
    const MeshEdge& edge = edges_[out->border_edges[k]];
    const float side = static_cast<float>(out->edge_side_a[k]);
    const Eigen::Vector2f a = out->screen[edge.v0].head<2>(), b = out->screen[edge.v1].head<2>();
    const Eigen::Vector2f q((p % W) + 0.5f, (p / W) + 0.5f);
    const Eigen::Vector2f e = b - a;
    const float length = e.norm();
    const float c = Cross(e, q - a);
    const float d = side * c / length;  // d_A
    const float t = std::clamp((d + w) / (2.f * w), 0.f, 1.f);
    const float s = t * t * (3.f - 2.f * t);
    const float ds = 6.f * t * (1.f - t) / (2.f * w);
    const Eigen::Vector3f& color_a = out->edge_colors[2 * k];
    const Eigen::Vector3f& color_b = out->edge_colors[2 * k + 1];
    const Eigen::Vector3f color = color_b + (color_a - color_b) * s;
    out->color[3 * p] = color.x();
    out->color[3 * p + 1] = color.y();
    out->color[3 * p + 2] = color.z();
    if (ds <= 0.f) continue;
    // d d_A / d a and d d_A / d b on the screen, then through the projection.
    const float inv_len = 1.f / length, inv_len3 = inv_len * inv_len * inv_len;
    const Eigen::Vector2f dc_da(b.y() - q.y(), q.x() - b.x());
    const Eigen::Vector2f dc_db(q.y() - a.y(), a.x() - q.x());
    const Eigen::Vector2f dd_da = side * (dc_da * inv_len + c * e * inv_len3);
    const Eigen::Vector2f dd_db = side * (dc_db * inv_len - c * e * inv_len3);
    EdgePixel ep;
    ep.pixel = p;
    ep.vertex_a = edge.v0;
    ep.vertex_b = edge.v1;
    ep.distance = d;
    ep.color_slope = (color_a - color_b) * ds;
    ep.dd_dxa = ProjectionJacobian(camera, camera_vertices.row(edge.v0).transpose()).transpose() *
                dd_da;
    ep.dd_dxb = ProjectionJacobian(camera, camera_vertices.row(edge.v1).transpose()).transpose() *
                dd_db;
    out->edge_pixels.push_back(ep);
  }
}

void SoftEdgeJacobian(const SoftRender& render, const rig::RigEvaluator& evaluator,
                      const rig::RigidPose& pose, const Eigen::VectorXf& weights,
                      const std::vector<int>& columns, Eigen::MatrixXf* rows,
                      SoftJacobianWorkspace* ws) {
  const int m = static_cast<int>(columns.size());
  const int n = static_cast<int>(render.edge_pixels.size());
  rows->resize(n, m);
  if (n == 0) return;
  if (static_cast<int>(ws->vertex_slot.size()) != evaluator.rig().NumVertices()) {
    ws->vertex_slot.assign(evaluator.rig().NumVertices(), -1);
  }
  ws->vertex_ids.clear();
  for (const EdgePixel& ep : render.edge_pixels) {
    for (int v : {ep.vertex_a, ep.vertex_b}) {
      if (ws->vertex_slot[v] < 0) {
        ws->vertex_slot[v] = static_cast<int>(ws->vertex_ids.size());
        ws->vertex_ids.push_back(v);
      }
    }
  }
  evaluator.EvaluatePosedWithJacobian(pose, weights, ws->vertex_ids, nullptr,
                                      &ws->vertex_jacobian);
  ws->block_jacobian.resize(ws->vertex_jacobian.rows(), m);
  for (int k = 0; k < m; ++k) ws->block_jacobian.col(k) = ws->vertex_jacobian.col(columns[k]);
  for (int i = 0; i < n; ++i) {
    const EdgePixel& ep = render.edge_pixels[i];
    const int sa = 3 * ws->vertex_slot[ep.vertex_a], sb = 3 * ws->vertex_slot[ep.vertex_b];
    rows->row(i) = ep.dd_dxa.transpose() * ws->block_jacobian.middleRows<3>(sa) +
                   ep.dd_dxb.transpose() * ws->block_jacobian.middleRows<3>(sb);
  }
  for (int v : ws->vertex_ids) ws->vertex_slot[v] = -1;
}

}  // namespace facecap::track
