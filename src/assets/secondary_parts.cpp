#include "assets/secondary_parts.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "assets/bounded_least_squares.h"
#include "render/shading.h"
#include "rig/pose.h"
#include "util/errors.h"

namespace facecap::assets {
namespace {

constexpr float kPi = 3.14159265358979323846f;
// The eyeball parts sit this far outside the face mesh's own eyeballs, hiding them.
constexpr float kEyeballClearanceCm = 0.01f;
constexpr float kIrisRadius = 0.5f;   // iris radius over the eyeball radius (front projection)
constexpr float kPupilRadius = 0.2f;

using Vec3 = Eigen::Vector3f;

Vec3 Row(const rig::Vertices& v, int i) { return v.row(i).transpose(); }
Vec3 DeltaOf(const Eigen::MatrixXf& deltas, int vertex, int shape) {
  return deltas.block<3, 1>(3 * vertex, shape);
}

int RegionIndex(const rig::Rig& rig, const std::string& name) {
  for (size_t r = 0; r < rig.regions.size(); ++r) {
    if (rig.regions[r].name == name) return static_cast<int>(r);
  }
  throw InvalidInputError("assembly: the face rig has no region '" + name +
                          "' (secondary parts need the demo head's topology)");
}

std::vector<int> Sorted(const std::set<int>& s) { return std::vector<int>(s.begin(), s.end()); }

// Least-squares sphere through points: |x|^2 = 2 c.x + (r^2 - |c|^2).
void FitSphere(const std::vector<Vec3>& points, Vec3* centre, float* radius) {
  const int n = static_cast<int>(points.size());
  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd b(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d p = points[k].cast<double>();
    a.row(k) << 2.0 * p.x(), 2.0 * p.y(), 2.0 * p.z(), 1.0;
    b[k] = p.squaredNorm();
  }
  const Eigen::Vector4d s = a.colPivHouseholderQr().solve(b);
  *centre = s.head<3>().cast<float>();
  *radius = static_cast<float>(std::sqrt(std::max(0.0, s[3] + s.head<3>().squaredNorm())));
}

std::vector<Vec3> Gather(const rig::Vertices& v, const std::vector<int>& idx) {
  std::vector<Vec3> out;
  out.reserve(idx.size());
  for (int i : idx) out.push_back(Row(v, i));
  return out;
}

// Best rigid transform (rotation R, translation t) with dst ~ R src + t.
void RigidFit(const std::vector<Vec3>& src, const std::vector<Vec3>& dst, Eigen::Matrix3f* r,
              Vec3* t) {
  Eigen::Matrix3Xf a(3, src.size()), b(3, dst.size());
  for (size_t k = 0; k < src.size(); ++k) {
    a.col(k) = src[k];
    b.col(k) = dst[k];
  }
  const Eigen::Matrix4f m = Eigen::umeyama(a, b, false);
  *r = m.topLeftCorner<3, 3>();
  *t = m.topRightCorner<3, 1>();
}

// The rotation taking direction a to direction b by the shortest arc.
Eigen::Matrix3f ArcRotation(const Vec3& a, const Vec3& b) {
  return Eigen::Quaternionf::FromTwoVectors(a, b).toRotationMatrix();
}

float RotationAngleDeg(const Eigen::Matrix3f& r) {
  const float c = std::clamp(0.5f * (r.trace() - 1.f), -1.f, 1.f);
  return std::acos(c) * 180.f / kPi;
}

// ---- mesh building ------------------------------------------------------------------------

struct MeshBuilder {
  std::vector<Vec3> v;
  std::vector<Eigen::Vector2f> uv;
  std::vector<Eigen::Vector3i> f;
  std::vector<int> follow;

  int Add(const Vec3& p, float u, float w, int follow_vertex = -1) {
    v.push_back(p);
    uv.emplace_back(std::clamp(u, 0.f, 1.f), std::clamp(w, 0.f, 1.f));
    follow.push_back(follow_vertex);
    return static_cast<int>(v.size()) - 1;
  }
  void Quad(int a, int b, int c, int d) {  // counter-clockwise a, b, c, d
    f.emplace_back(a, b, c);
    f.emplace_back(a, c, d);
  }
  SecondaryPart Finish(const std::string& name, const std::string& material, int group,
                       int num_shapes) const {
    SecondaryPart p;
    p.name = name;
    p.material = material;
    p.group = group;
    const int n = static_cast<int>(v.size());
    p.neutral.resize(n, 3);
    p.uvs.resize(n, 2);
    for (int k = 0; k < n; ++k) {
      p.neutral.row(k) = v[k].transpose();
      p.uvs.row(k) = uv[k].transpose();
    }
    p.triangles.resize(static_cast<int>(f.size()), 3);
    for (size_t k = 0; k < f.size(); ++k) p.triangles.row(static_cast<int>(k)) = f[k].transpose();
    p.deltas.setZero(3 * n, num_shapes);
    p.follow = follow;
    return p;
  }
};

// A UV sphere (ellipsoid with radii `radii`) about `centre` with its pole on +z; uv from the
// front projection (x, y) / radius, so that an eyeball's front carries the iris texture.
void AddEllipsoid(MeshBuilder* m, const Vec3& centre, const Vec3& radii, int segments, int bands) {
  const int first = static_cast<int>(m->v.size());
  auto point = [&](float polar, float phi) {
    const Vec3 unit(std::sin(polar) * std::cos(phi), std::sin(polar) * std::sin(phi), std::cos(polar));
    return Vec3(centre + radii.cwiseProduct(unit));
  };
  auto add = [&](float polar, float phi) {
    const Vec3 p = point(polar, phi);
    const Vec3 q = (p - centre).cwiseQuotient(radii);
    return m->Add(p, 0.5f + 0.5f * q.x(), 0.5f + 0.5f * q.y());
  };
  const int front = add(0.f, 0.f);
  for (int b = 1; b < bands; ++b) {
    for (int s = 0; s < segments; ++s) add(kPi * b / bands, 2.f * kPi * s / segments);
  }
  const int back = add(kPi, 0.f);
  auto ring = [&](int b, int s) { return first + 1 + (b - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) {
    m->f.emplace_back(front, ring(1, s), ring(1, s + 1));
    m->f.emplace_back(back, ring(bands - 1, s + 1), ring(bands - 1, s));
    for (int b = 1; b + 1 < bands; ++b) m->Quad(ring(b, s), ring(b + 1, s), ring(b + 1, s + 1), ring(b, s + 1));
  }
}

// A box section swept along a dental arch: the arch point at s in [-1, 1] is
// (W sin(phi), y, z0 - D (1 - cos(phi))) with phi = 1.35 s; the section spans [y_lo, y_hi] and
// `thickness` inwards from the arch. Ends capped.
void AddArch(MeshBuilder* m, float half_width, float depth, float z0, float y_lo, float y_hi,
             float thickness, int samples) {
  const int first = static_cast<int>(m->v.size());
  for (int k = 0; k < samples; ++k) {
    const float s = -1.f + 2.f * k / (samples - 1), phi = 1.35f * s;
    const Vec3 front(half_width * std::sin(phi), 0.f, z0 - depth * (1.f - std::cos(phi)));
    const Vec3 tangent(half_width * std::cos(phi), 0.f, -depth * std::sin(phi));
    const Vec3 inward = Vec3(0.f, 1.f, 0.f).cross(tangent).normalized() * -1.f;
    const Vec3 back = front + thickness * inward;
    const float u = static_cast<float>(k) / (samples - 1);
    m->Add(Vec3(front.x(), y_hi, front.z()), u, 1.f);
    m->Add(Vec3(front.x(), y_lo, front.z()), u, 0.5f);
    m->Add(Vec3(back.x(), y_lo, back.z()), u, 0.25f);
    m->Add(Vec3(back.x(), y_hi, back.z()), u, 0.f);
  }
  auto at = [&](int k, int c) { return first + 4 * k + c; };
  for (int k = 0; k + 1 < samples; ++k) {
    for (int c = 0; c < 4; ++c) {
      const int cn = (c + 1) % 4;
      m->Quad(at(k, c), at(k, cn), at(k + 1, cn), at(k + 1, c));
    }
  }
  m->Quad(at(0, 3), at(0, 2), at(0, 1), at(0, 0));
  const int e = samples - 1;
  m->Quad(at(e, 0), at(e, 1), at(e, 2), at(e, 3));
}

// Connected components (by shared vertices) of the triangles in `tris`.
std::vector<std::vector<int>> VertexComponents(const rig::Triangles& t, const std::vector<int>& tris,
                                               int num_vertices) {
  std::vector<int> parent(num_vertices);
  for (int i = 0; i < num_vertices; ++i) parent[i] = i;
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::set<int> used;
  for (int f : tris) {
    for (int c = 0; c < 3; ++c) used.insert(t(f, c));
    parent[find(t(f, 0))] = find(t(f, 1));
    parent[find(t(f, 1))] = find(t(f, 2));
  }
  std::map<int, std::vector<int>> groups;
  for (int v : used) groups[find(v)].push_back(v);
  std::vector<std::vector<int>> out;
  for (auto& [root, vs] : groups) out.push_back(vs);
  return out;
}

// Per-shape deltas of a part group that turns with a rigid motion per shape:
// x -> R_j (x - c) + c + t_j.
void RigidDeltas(SecondaryPart* p, int shape, const Eigen::Matrix3f& r, const Vec3& centre,
                 const Vec3& t) {
  for (int k = 0; k < p->NumVertices(); ++k) {
    const Vec3 x = Row(p->neutral, k);
    p->deltas.block<3, 1>(3 * k, shape) = r * (x - centre) + centre + t - x;
  }
}

// Every shape at weight 1, then `combinations` random weight vectors: 8 shapes drawn with
// weights uniform in [0, 1].
std::vector<Eigen::VectorXf> CheckPoses(int n, int combinations, unsigned seed) {
  std::vector<Eigen::VectorXf> poses;
  for (int i = 0; i < n; ++i) poses.push_back(Eigen::VectorXf::Unit(n, i));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int k = 0; k < combinations && n > 0; ++k) {
    Eigen::VectorXf w = Eigen::VectorXf::Zero(n);
    for (int m = 0; m < std::min(8, n); ++m) w[pick(rng)] = uni(rng);
    poses.push_back(w);
  }
  return poses;
}

// How far (cm) the deepest of `lid` (face vertices at weights w, `face_flat` = the posed face
// as 3V floats) lies inside the sphere of the posed eyeball part; negative when all clear it.
float LidPenetration(const SecondaryPart& eyeball, const Eigen::VectorXf& w, const Eigen::VectorXf& face_flat,
                     const std::vector<int>& lid) {
  const rig::Vertices ball = eyeball.Evaluate(w);
  std::vector<Vec3> pts(ball.rows());
  for (int k = 0; k < ball.rows(); ++k) pts[k] = Row(ball, k);
  Vec3 c;
  float r;
  FitSphere(pts, &c, &r);
  float worst = -1e9f;
  for (int v : lid) worst = std::max(worst, r - (Vec3(face_flat.segment<3>(3 * v)) - c).norm());
  return worst;
}

// Weights in [0, 1] on at most `max_shapes` columns of b that bring a + b w closest to the
// origin, chosen greedily: each step adds the column whose bounded least-squares solution
// with the columns chosen so far comes closest.
Eigen::VectorXf ClosestSparsePose(const Vec3& a, const Eigen::MatrixXf& b, int max_shapes) {
  const int n = static_cast<int>(b.cols());
  Eigen::VectorXf best_w = Eigen::VectorXf::Zero(n);
  float best = a.norm();
  std::vector<int> chosen;
  for (int step = 0; step < max_shapes && step < n; ++step) {
    int pick = -1;
    Eigen::VectorXf pick_x;
    for (int i = 0; i < n; ++i) {
      if (std::find(chosen.begin(), chosen.end(), i) != chosen.end()) continue;
      std::vector<int> cols = chosen;
      cols.push_back(i);
      Eigen::MatrixXf sub(3, cols.size());
      for (size_t k = 0; k < cols.size(); ++k) sub.col(k) = b.col(cols[k]);
      const BoundedLeastSquares solver(sub, BoundedLeastSquaresOptions());
      Eigen::VectorXf x;
      solver.Solve(-a, Eigen::VectorXf(), &x);
      const float dist = (a + sub * x).norm();
      if (dist < best - 1e-7f) best = dist, pick = i, pick_x = x;
    }
    if (pick < 0) break;
    chosen.push_back(pick);
    best_w.setZero();
    for (size_t k = 0; k < chosen.size(); ++k) best_w[chosen[k]] = pick_x[k];
  }
  return best_w;
}

}  // namespace

Sphere FitSphere(const rig::Vertices& points, const std::vector<int>& rows) {
  Sphere s;
  FitSphere(Gather(points, rows), &s.centre, &s.radius);
  return s;
}

bool AssemblyOptions::Check(std::string* why) const {
  if (!(regularization >= 0.f && regularization <= 1e3f)) {
    *why = "regularization must be in [0, 1000]";
    return false;
  }
  if (clearance_shapes < 0) {
    *why = "clearance_shapes must be >= 0";
    return false;
  }
  return true;
}

FaceParts FindFaceParts(const rig::Rig& head) {
  FaceParts out;
  const int V = head.NumVertices();
  const int sclera = RegionIndex(head, "sclera"), iris = RegionIndex(head, "iris");
  const int pupil = RegionIndex(head, "pupil");
  const char* upper_names[2] = {"left_upper_eyelid", "right_upper_eyelid"};
  const char* lower_names[2] = {"left_lower_eyelid", "right_lower_eyelid"};
  // Eyeballs: the components of the sclera/iris/pupil triangles that hold an iris triangle
  // (the eye pockets are sclera too but share vertices with the lids and carry no iris).
  std::vector<int> eye_tris;
  for (int f = 0; f < head.triangles.rows(); ++f) {
    const int r = head.triangle_region(f);
    if (r == sclera || r == iris || r == pupil) eye_tris.push_back(f);
  }
  std::set<int> iris_vertices;
  for (int f : eye_tris) {
    if (head.triangle_region(f) == iris) {
      for (int c = 0; c < 3; ++c) iris_vertices.insert(head.triangles(f, c));
    }
  }
  for (const auto& comp : VertexComponents(head.triangles, eye_tris, V)) {
    if (!iris_vertices.count(comp.front()) &&
        std::none_of(comp.begin(), comp.end(), [&](int v) { return iris_vertices.count(v) > 0; })) {
      continue;
    }
    double x = 0;
    for (int v : comp) x += head.neutral(v, 0);
    out.eyeball[x > 0 ? 0 : 1] = comp;
  }
  std::set<int> pocket;  // sclera vertices outside the eyeballs: the pockets and the slit loops
  for (int f : eye_tris) {
    for (int c = 0; c < 3; ++c) pocket.insert(head.triangles(f, c));
  }
  for (int side = 0; side < 2; ++side) {
    for (int v : out.eyeball[side]) pocket.erase(v);
  }
  for (int side = 0; side < 2; ++side) {
    if (out.eyeball[side].empty()) {
      throw InvalidInputError(std::string("assembly: the face rig has no ") +
                              (side == 0 ? "left" : "right") + " eyeball (sclera/iris component)");
    }
    const int up = RegionIndex(head, upper_names[side]), low = RegionIndex(head, lower_names[side]);
    std::set<int> up_v, low_v, lid_v;
    for (int f = 0; f < head.triangles.rows(); ++f) {
      const int r = head.triangle_region(f);
      if (r != up && r != low) continue;
      out.lid_triangles[side].push_back(f);
      for (int c = 0; c < 3; ++c) {
        const int v = head.triangles(f, c);
        lid_v.insert(v);
        (r == up ? up_v : low_v).insert(v);
      }
    }
    out.lid_vertices[side] = Sorted(lid_v);
    auto margin = [&](const std::set<int>& lid) {
      std::vector<int> m;
      for (int v : lid) {
        if (pocket.count(v)) m.push_back(v);
      }
      std::sort(m.begin(), m.end(), [&](int a, int b) { return head.neutral(a, 0) < head.neutral(b, 0); });
      return m;
    };
    out.upper_margin[side] = margin(up_v);
    out.lower_margin[side] = margin(low_v);
    if (out.upper_margin[side].size() < 3 || out.lower_margin[side].size() < 3) {
      throw InvalidInputError(std::string("assembly: the face rig's ") + (side == 0 ? "left" : "right") +
                              " eye slit has no lid margin (lid regions do not meet an eye pocket)");
    }
  }
  if (head.jaw_weights.size() == V) {
    for (int v = 0; v < V; ++v) {
      if (head.jaw_weights[v] >= 0.999f) out.jaw.push_back(v);
    }
  }
  return out;
}

namespace {

// The lip slit (the vertices shared by the lips and the mouth interior) and the mouth's vertices.
struct MouthFrame {
  std::vector<int> vertices;  // lips and mouth interior
  float slit_y = 0.f, front_z = 0.f, half_width = 0.f;
};

MouthFrame FindMouth(const rig::Rig& head) {
  const rig::Vertices& neutral = head.neutral;
  const int upper_lip = RegionIndex(head, "upper_lip"), lower_lip = RegionIndex(head, "lower_lip");
  const int interior = RegionIndex(head, "mouth_interior");
  std::set<int> lips, inside, mouth_all;
  for (int f = 0; f < head.triangles.rows(); ++f) {
    const int r = head.triangle_region(f);
    for (int c = 0; c < 3; ++c) {
      const int v = head.triangles(f, c);
      if (r == upper_lip || r == lower_lip) lips.insert(v);
      if (r == interior) inside.insert(v);
      if (r == upper_lip || r == lower_lip || r == interior) mouth_all.insert(v);
    }
  }
  std::vector<int> slit;
  for (int v : lips) {
    if (inside.count(v)) slit.push_back(v);
  }
  if (slit.empty()) throw InvalidInputError("assembly: the face rig's lips do not meet its mouth interior");
  float y_m = 0.f, z_front = -1e9f, mouth_half = 0.f;
  for (int v : slit) {
    y_m += neutral(v, 1) / slit.size();
    z_front = std::max(z_front, neutral(v, 2));
    mouth_half = std::max(mouth_half, std::abs(neutral(v, 0)));
  }

  MouthFrame mouth;
  mouth.vertices = Sorted(mouth_all);
  mouth.slit_y = y_m;
  mouth.front_z = z_front;
  mouth.half_width = mouth_half;
  return mouth;
}

// The groups that place and drive the parts: each eye, the mouth, the jaw and each eyeball.
void AddGroups(const rig::Rig& head, const LinearShapes& shapes, const FaceParts& where,
               const std::vector<int>& mouth_vertices, PartSet* out_set) {
  PartSet& out = *out_set;
  const int N = shapes.NumShapes();
  for (int side = 0; side < 2; ++side) {
    PartGroup g;
    g.name = side == 0 ? "left_eye" : "right_eye";
    g.placement = where.eyeball[side];
    std::set<int> fit(where.lid_vertices[side].begin(), where.lid_vertices[side].end());
    fit.insert(where.eyeball[side].begin(), where.eyeball[side].end());
    g.fit = Sorted(fit);
    out.groups.push_back(g);
  }
  {
    PartGroup g;
    g.name = "mouth";
    g.placement = mouth_vertices;
    std::set<int> fit(mouth_vertices.begin(), mouth_vertices.end());
    fit.insert(where.jaw.begin(), where.jaw.end());
    g.fit = Sorted(fit);
    out.groups.push_back(g);
    // The jaw: the quarter of the skin that follows the jaw fully which other shapes move least.
    PartGroup jaw;
    jaw.name = "jaw";
    jaw.placement = g.placement;
    jaw.rigid = true;
    std::vector<float> other(where.jaw.size(), 0.f);
    for (size_t k = 0; k < where.jaw.size(); ++k) {
      for (int j = 0; j < N; ++j) {
        const int s = head.ShapeIndex(shapes.names[j]);
        if (s < 0 || !head.shapes[s].UsesJaw()) other[k] = std::max(other[k], DeltaOf(shapes.deltas, where.jaw[k], j).norm());
      }
    }
    std::vector<float> sorted = other;
    std::sort(sorted.begin(), sorted.end());
    const float limit = sorted.empty() ? 0.f : sorted[sorted.size() / 4];
    for (size_t k = 0; k < where.jaw.size(); ++k) {
      if (other[k] <= limit) jaw.fit.push_back(where.jaw[k]);
    }
    if (jaw.fit.size() < 12) {
      throw InvalidInputError("assembly: the face rig has no skin that only its jaw moves (jaw weights missing?)");
    }
    out.groups.push_back(jaw);
  }
  // The eyeballs turn rigidly with the face's own eyeball spheres (groups 4 and 5) and stay
  // behind the lids.
  for (int side = 0; side < 2; ++side) {
    PartGroup g;
    g.name = side == 0 ? "left_eyeball" : "right_eyeball";
    g.placement = where.eyeball[side];
    g.fit = where.eyeball[side];
    g.rigid = true;
    g.clear = where.lid_vertices[side];
    out.groups.push_back(g);
  }
}

// A lash card strip along one lid margin, rooted on the margin vertices and curling outwards (up
// for the upper lid, down for the lower); every card vertex turns with its root about the eyeball
// centre c.
SecondaryPart MakeLashes(const rig::Vertices& neutral, const LinearShapes& shapes,
                         const std::vector<int>& margin, const Vec3& c, int lid, int side,
                         const std::string& prefix) {
  const int N = shapes.NumShapes();
  const float up = lid == 0 ? 1.f : -1.f, length = lid == 0 ? 0.85f : 0.4f;
  MeshBuilder m;
  const int n = static_cast<int>(margin.size());
  for (int k = 0; k < n; ++k) {
    const Vec3 root = Row(neutral, margin[k]);
    const Vec3 out_dir = (root - c).normalized();
    const float along = n > 1 ? static_cast<float>(k) / (n - 1) : 0.5f;
    const float len = length * (0.45f + 0.55f * std::sin(kPi * along));
    const Vec3 mid = root + 0.5f * len * (out_dir + Vec3(0, 0.25f * up, 0)).normalized();
    const Vec3 tip = mid + 0.5f * len * (out_dir + Vec3(0, 1.2f * up, 0)).normalized();
    m.Add(root, along, 0.f, margin[k]);
    m.Add(mid, along, 0.5f, margin[k]);
    m.Add(tip, along, 1.f, margin[k]);
  }
  for (int k = 0; k + 1 < n; ++k) {
    if (lid == 0) m.Quad(3 * k, 3 * (k + 1), 3 * (k + 1) + 1, 3 * k + 1), m.Quad(3 * k + 1, 3 * (k + 1) + 1, 3 * (k + 1) + 2, 3 * k + 2);
    else m.Quad(3 * k, 3 * k + 1, 3 * (k + 1) + 1, 3 * (k + 1)), m.Quad(3 * k + 1, 3 * k + 2, 3 * (k + 1) + 2, 3 * (k + 1) + 1);
  }
  SecondaryPart p = m.Finish(prefix + (lid == 0 ? "upper_lashes" : "lower_lashes"), "lashes", side, N);
  for (int j = 0; j < N; ++j) {
    for (int k = 0; k < n; ++k) {
      const Vec3 q = Row(neutral, margin[k]) - c;
      const Vec3 q1 = q + DeltaOf(shapes.deltas, margin[k], j);
      const Eigen::Matrix3f rr = ArcRotation(q, q1);
      const Vec3 radial = q1 - rr * q;
      for (int row = 0; row < 3; ++row) {
        const Vec3 x = Row(p.neutral, 3 * k + row);
        p.deltas.block<3, 1>(3 * (3 * k + row), j) = c + rr * (x - c) + radial - x;
      }
    }
  }
  return p;
}

// Lacrimal fluid: a strip from the lower lid margin to the eyeball part's surface (radius re
// about c), its inner edge moving with the margin, its outer edge with the eyeball.
SecondaryPart MakeLacrimal(const rig::Vertices& neutral, const LinearShapes& shapes,
                           const std::vector<int>& margin, const Vec3& c, float re,
                           const std::vector<Vec3>& trans, int side, const std::string& prefix) {
  const int N = shapes.NumShapes();
  MeshBuilder m;
  const int n = static_cast<int>(margin.size());
  for (int k = 0; k < n; ++k) {
    const Vec3 p0 = Row(neutral, margin[k]);
    const float along = n > 1 ? static_cast<float>(k) / (n - 1) : 0.5f;
    m.Add(p0, along, 0.f, margin[k]);
    m.Add(c + (re + 0.003f) * (p0 - c).normalized(), along, 1.f);
  }
  for (int k = 0; k + 1 < n; ++k) m.Quad(2 * k, 2 * (k + 1), 2 * (k + 1) + 1, 2 * k + 1);
  SecondaryPart p = m.Finish(prefix + "lacrimal", "lacrimal", side, N);
  for (int j = 0; j < N; ++j) {
    for (int k = 0; k < n; ++k) {
      const Vec3 q = Row(neutral, margin[k]) - c;
      const Vec3 q1 = q + DeltaOf(shapes.deltas, margin[k], j);
      const Eigen::Matrix3f rr = ArcRotation(q, q1);
      p.deltas.block<3, 1>(6 * k, j) = DeltaOf(shapes.deltas, margin[k], j);
      const Vec3 x = Row(p.neutral, 2 * k + 1);
      p.deltas.block<3, 1>(3 * (2 * k + 1), j) = c + rr * (x - c) + trans[j] - x;
    }
  }
  return p;
}

// One eye's parts: eyeball with iris texture, cornea, lashes, lacrimal strip.
void AddEyeParts(const rig::Rig& head, const LinearShapes& shapes, const FaceParts& where, int side,
                 PartSet* out_set) {
  PartSet& out = *out_set;
  const int N = shapes.NumShapes();
  const rig::Vertices& neutral = head.neutral;
  const std::string prefix = side == 0 ? "left_" : "right_";
  Vec3 c;
  float r;
  FitSphere(Gather(neutral, where.eyeball[side]), &c, &r);
  const float re = r + kEyeballClearanceCm;
  // Per-shape rigid motion of the face's eyeball.
  std::vector<Eigen::Matrix3f> rot(N);
  std::vector<Vec3> trans(N);
  const std::vector<Vec3> eye0 = Gather(neutral, where.eyeball[side]);
  for (int j = 0; j < N; ++j) {
    std::vector<Vec3> eye1 = eye0;
    for (size_t k = 0; k < eye1.size(); ++k) eye1[k] += DeltaOf(shapes.deltas, where.eyeball[side][k], j);
    Eigen::Matrix3f rr;
    Vec3 tt;
    RigidFit(eye0, eye1, &rr, &tt);
    rot[j] = rr;
    trans[j] = rr * c + tt - c;  // motion of the centre
  }
  {
    MeshBuilder m;
    AddEllipsoid(&m, c, Vec3::Constant(re), 24, 12);
    SecondaryPart p = m.Finish(prefix + "eyeball", "eye", 4 + side, N);
    for (int j = 0; j < N; ++j) RigidDeltas(&p, j, rot[j], c, trans[j]);
    out.parts.push_back(std::move(p));
  }
  {
    // Cornea: a cap over the iris bulging 0.6 mm in front of the eyeball part.
    MeshBuilder m;
    const int segments = 24, bands = 6;
    const float cap = std::asin(kIrisRadius) * 1.15f;
    auto add = [&](float polar, float phi) {
      const float bulge = 0.06f * std::pow(std::cos(0.5f * kPi * polar / cap), 2.f);
      const Vec3 unit(std::sin(polar) * std::cos(phi), std::sin(polar) * std::sin(phi), std::cos(polar));
      return m.Add(c + (re + 0.002f + bulge) * unit, 0.5f + 0.5f * unit.x(), 0.5f + 0.5f * unit.y());
    };
    const int front = add(0.f, 0.f);
    for (int b = 1; b <= bands; ++b) {
      for (int s = 0; s < segments; ++s) add(cap * b / bands, 2.f * kPi * s / segments);
    }
    auto ring = [&](int b, int s) { return front + 1 + (b - 1) * segments + (s % segments); };
    for (int s = 0; s < segments; ++s) {
      m.f.emplace_back(front, ring(1, s), ring(1, s + 1));
      for (int b = 1; b < bands; ++b) m.Quad(ring(b, s), ring(b + 1, s), ring(b + 1, s + 1), ring(b, s + 1));
    }
    SecondaryPart p = m.Finish(prefix + "cornea", "cornea", 4 + side, N);
    for (int j = 0; j < N; ++j) RigidDeltas(&p, j, rot[j], c, trans[j]);
    out.parts.push_back(std::move(p));
  }
  for (int lid = 0; lid < 2; ++lid) {
    const std::vector<int>& margin = lid == 0 ? where.upper_margin[side] : where.lower_margin[side];
    out.parts.push_back(MakeLashes(neutral, shapes, margin, c, lid, side, prefix));
  }
  out.parts.push_back(MakeLacrimal(neutral, shapes, where.lower_margin[side], c, re, trans, side, prefix));
}

// The mouth's parts: teeth and gums on two arches behind the lip slit, a tongue on the floor.
void AddMouthParts(const rig::Rig& head, const LinearShapes& shapes, const MouthFrame& mouth,
                   PartSet* out_set) {
  PartSet& out = *out_set;
  const int N = shapes.NumShapes();
  const float y_m = mouth.slit_y, z_front = mouth.front_z, mouth_half = mouth.half_width;
  const float w = std::min(1.75f, 0.72f * mouth_half), depth = 2.0f, z0 = z_front - 1.15f;
  const int samples = 25;
  struct ArchDef {
    const char* name;
    const char* material;
    float scale, y_lo, y_hi, thickness, forward;
    bool jaw;
  };
  const ArchDef arches[] = {
      {"upper_teeth", "teeth", 1.f, y_m - 0.12f, y_m + 0.6f, 0.55f, 0.f, false},
      {"upper_gums", "gums", 1.f, y_m + 0.5f, y_m + 0.95f, 0.65f, 0.04f, false},
      {"lower_teeth", "teeth", 0.93f, y_m - 0.65f, y_m - 0.06f, 0.5f, -0.08f, true},
      {"lower_gums", "gums", 0.93f, y_m - 1.05f, y_m - 0.55f, 0.6f, -0.04f, true},
  };
  // Jaw motion of each shape: the head's jaw angles and translation (none for other shapes).
  std::vector<Eigen::Matrix3f> jaw_r(N, Eigen::Matrix3f::Identity());
  std::vector<Vec3> jaw_t(N, Vec3::Zero());
  for (int j = 0; j < N; ++j) {
    const int s = head.ShapeIndex(shapes.names[j]);
    if (s < 0) continue;
    jaw_r[j] = rig::EulerToMatrix(head.shapes[s].jaw_euler);
    jaw_t[j] = head.shapes[s].jaw_translation;
  }
  auto jaw_deltas = [&](SecondaryPart* p) {
    for (int j = 0; j < N; ++j) {
      RigidDeltas(p, j, jaw_r[j], head.jaw_pivot, jaw_t[j]);
    }
  };
  for (const ArchDef& a : arches) {
    MeshBuilder m;
    AddArch(&m, w * a.scale, depth * a.scale, z0 + a.forward, a.y_lo, a.y_hi, a.thickness, samples);
    SecondaryPart p = m.Finish(a.name, a.material, a.jaw ? 3 : 2, N);
    if (a.jaw) jaw_deltas(&p);
    out.parts.push_back(std::move(p));
  }
  {
    MeshBuilder m;
    AddEllipsoid(&m, Vec3(0.f, y_m - 0.5f, z0 - 1.35f), Vec3(0.85f * w * 0.93f, 0.3f, 1.2f), 20, 10);
    SecondaryPart p = m.Finish("tongue", "tongue", 3, N);
    jaw_deltas(&p);
    const int out_shape = shapes.ShapeIndex("tongueOut");
    if (out_shape >= 0) {
      for (int k = 0; k < p.NumVertices(); ++k) {
        p.deltas.block<3, 1>(3 * k, out_shape) += Vec3(0.f, -0.15f, 1.6f);
      }
    }
    out.parts.push_back(std::move(p));
  }
}

}  // namespace

PartSet MakeGenericParts(const rig::Rig& head, const LinearShapes& shapes) {
  if (shapes.NumVertices() != head.NumVertices()) {
    throw InvalidInputError("assembly: the template shapes and the head differ in vertex count");
  }
  const FaceParts where = FindFaceParts(head);
  const MouthFrame mouth = FindMouth(head);
  PartSet out;
  out.shape_names = shapes.names;
  AddGroups(head, shapes, where, mouth.vertices, &out);
  for (int side = 0; side < 2; ++side) AddEyeParts(head, shapes, where, side, &out);
  AddMouthParts(head, shapes, mouth, &out);
  return out;
}

namespace {

// Eyeballs behind the lids: for each lid vertex, the pose of at most `clearance_shapes`
// shapes at weights in [0, 1] that brings it closest to the eyeball's centre,
// min |a + sum_i w_i b_i| (a: the vertex from the centre, b_i: its delta less the centre's;
// ClosestSparsePose), then the setback that keeps every such pose outside the eyeball.
void SetEyeballsBehindLids(const LinearShapes& person, int clearance_shapes, PartSet* parts,
                           AssemblyReport* report) {
  PartSet& out = *parts;
  const int S = person.NumShapes();
  for (size_t gi = 0; gi < out.groups.size(); ++gi) {
    const PartGroup& group = out.groups[gi];
    int ball = -1;
    for (size_t pi = 0; pi < out.parts.size(); ++pi) {
      if (out.parts[pi].group == static_cast<int>(gi) && out.parts[pi].material == "eye") ball = static_cast<int>(pi);
    }
    if (group.clear.empty() || ball < 0) continue;
    const SecondaryPart& eye = out.parts[ball];
    std::vector<Vec3> points(eye.NumVertices());
    for (int k = 0; k < eye.NumVertices(); ++k) points[k] = Row(eye.neutral, k);
    Vec3 centre;
    float radius;
    FitSphere(points, &centre, &radius);
    std::vector<Vec3> centre_motion(S);
    for (int i = 0; i < S; ++i) {
      const rig::Vertices posed = eye.Evaluate(Eigen::VectorXf::Unit(S, i));
      for (int k = 0; k < eye.NumVertices(); ++k) points[k] = Row(posed, k);
      Vec3 c;
      float r;
      FitSphere(points, &c, &r);
      centre_motion[i] = c - centre;
    }
    // The closest pose of every lid vertex (it does not depend on a setback along `back`
    // much; it is found once at the eyeball's placed centre).
    struct Closest {
      int vertex;
      Eigen::VectorXf weights;  // S
    };
    std::vector<Closest> closest;
    for (int v : group.clear) {
      std::vector<int> moving;
      for (int i = 0; i < S; ++i) {
        if ((DeltaOf(person.deltas, v, i) - centre_motion[i]).squaredNorm() > 1e-10f) moving.push_back(i);
      }
      const Vec3 a = Row(person.neutral, v) - centre;
      Eigen::MatrixXf b(3, moving.size());
      for (size_t k = 0; k < moving.size(); ++k) b.col(k) = DeltaOf(person.deltas, v, moving[k]) - centre_motion[moving[k]];
      const Eigen::VectorXf x = ClosestSparsePose(a, b, clearance_shapes);
      Eigen::VectorXf w = Eigen::VectorXf::Zero(S);
      for (size_t k = 0; k < moving.size(); ++k) w[moving[k]] = x[k];
      closest.push_back({v, w});
    }
    Vec3 lid_mean = Vec3::Zero();
    for (int v : group.clear) lid_mean += Row(person.neutral, v) / group.clear.size();
    const Vec3 back = (centre - lid_mean).normalized();
    float setback = 0.f;
    for (int iteration = 0; iteration < 20; ++iteration) {
      const Vec3 c = centre + setback * back;
      float worst = -1e9f;
      for (const Closest& k : closest) {
        Vec3 p = Row(person.neutral, k.vertex) - c;
        for (int i = 0; i < S; ++i) {
          if (k.weights[i] != 0.f) p += k.weights[i] * (DeltaOf(person.deltas, k.vertex, i) - centre_motion[i]);
        }
        worst = std::max(worst, radius - p.norm());
      }
      if (worst <= 0.f) break;
      setback += worst + 1e-4f;
    }
    if (setback > 0.f) {
      const std::string side = group.name.substr(0, group.name.find('_') + 1);  // "left_"
      for (SecondaryPart& p : out.parts) {
        const bool lacrimal = p.name == side + "lacrimal";
        if (p.group != static_cast<int>(gi) && !lacrimal) continue;
        for (int k = 0; k < p.NumVertices(); ++k) {
          if (p.follow[k] < 0) p.neutral.row(k) += setback * back.transpose();
        }
      }
    }
    if (report) report->eyeball_setback_cm[group.name == "right_eyeball" ? 1 : 0] = setback;
  }
}

}  // namespace

PartSet AssembleParts(const PartSet& generic, const LinearShapes& generic_shapes,
                      const LinearShapes& person, const AssemblyOptions& options,
                      AssemblyReport* report) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("assembly: " + why);
  const int V = generic_shapes.NumVertices();
  if (person.NumVertices() != V) {
    throw InvalidInputError("assembly: the face has " + std::to_string(person.NumVertices()) +
                            " vertices, the generic parts' template " + std::to_string(V) +
                            " (the parts need the template's topology)");
  }
  if (generic.NumShapes() != generic_shapes.NumShapes()) {
    throw InvalidInputError("assembly: the generic parts have another shape count than their shapes");
  }
  const int N = generic.NumShapes(), S = person.NumShapes();
  PartSet out;
  out.shape_names = person.names;
  out.groups = generic.groups;
  out.iris = generic.iris;
  for (const SecondaryPart& g : generic.parts) {
    SecondaryPart p = g;
    p.deltas.setZero(3 * g.NumVertices(), S);
    out.parts.push_back(std::move(p));
  }
  if (report) report->fit_rms_cm.assign(S, 0.f);
  std::vector<int> prior(S, -1);
  for (int i = 0; i < S; ++i) prior[i] = generic_shapes.ShapeIndex(person.names[i]);
  double placement_sq = 0.0;
  int placement_n = 0;
  std::vector<double> fit_sq(S, 0.0);
  int fit_n = 0;

  for (size_t gi = 0; gi < generic.groups.size(); ++gi) {
    const PartGroup& group = generic.groups[gi];
    // 1. Placement: similarity from the generic neutral to the person's.
    const std::vector<Vec3> src = Gather(generic_shapes.neutral, group.placement);
    const std::vector<Vec3> dst = Gather(person.neutral, group.placement);
    Eigen::Matrix3Xf a(3, src.size()), b(3, dst.size());
    for (size_t k = 0; k < src.size(); ++k) a.col(k) = src[k], b.col(k) = dst[k];
    const Eigen::Matrix4f sim = Eigen::umeyama(a, b, true);
    const Eigen::Matrix3f sr = sim.topLeftCorner<3, 3>();  // s R
    const Vec3 st = sim.topRightCorner<3, 1>();
    const float s = std::cbrt(sr.determinant());
    const Eigen::Matrix3f r_inv = (sr / s).transpose();
    for (size_t k = 0; k < src.size(); ++k) placement_sq += (sr * src[k] + st - dst[k]).squaredNorm();
    placement_n += static_cast<int>(src.size());

    std::vector<Eigen::VectorXf> coeffs(S);
    std::vector<Eigen::Matrix3f> jaw_r(S);
    std::vector<Vec3> jaw_t(S);
    const int F = static_cast<int>(group.fit.size());
    if (group.rigid) {
      // 2'. The rigid motion of the fit vertices in each person shape (in the person's frame).
      const std::vector<Vec3> rest = Gather(person.neutral, group.fit);
      for (int i = 0; i < S; ++i) {
        std::vector<Vec3> moved = rest;
        for (int k = 0; k < F; ++k) moved[k] += DeltaOf(person.deltas, group.fit[k], i);
        RigidFit(rest, moved, &jaw_r[i], &jaw_t[i]);
      }
    } else {
      // 2. Linear fit of each person shape over the group's fit vertices, in the generic frame.
      Eigen::MatrixXf A(3 * F, N);
      for (int k = 0; k < F; ++k) A.middleRows<3>(3 * k) = generic_shapes.deltas.middleRows<3>(3 * group.fit[k]);
      Eigen::MatrixXf ata = A.transpose() * A;
      const float lambda = options.regularization * static_cast<float>(ata.diagonal().mean());
      ata.diagonal().array() += lambda;
      const Eigen::LDLT<Eigen::MatrixXf> solver(ata);
      for (int i = 0; i < S; ++i) {
        Eigen::VectorXf d(3 * F);
        for (int k = 0; k < F; ++k) d.segment<3>(3 * k) = r_inv * DeltaOf(person.deltas, group.fit[k], i) / s;
        Eigen::VectorXf rhs = A.transpose() * d;
        if (prior[i] >= 0) rhs[prior[i]] += lambda;
        coeffs[i] = solver.solve(rhs);
        fit_sq[i] += s * s * (A * coeffs[i] - d).squaredNorm();
      }
    }
    if (!group.rigid) fit_n += F;
    // A rigid group's generic motion of each generic shape, to separate what parts do beyond it.
    std::vector<Eigen::Matrix3f> generic_r(N);
    std::vector<Vec3> generic_t(N);
    if (group.rigid) {
      const std::vector<Vec3> rest = Gather(generic_shapes.neutral, group.fit);
      for (int j = 0; j < N; ++j) {
        std::vector<Vec3> moved = rest;
        for (int k = 0; k < F; ++k) moved[k] += DeltaOf(generic_shapes.deltas, group.fit[k], j);
        RigidFit(rest, moved, &generic_r[j], &generic_t[j]);
      }
    }

    // 3. The parts: placed, driven by the coefficients, bound vertices following the face.
    for (size_t pi = 0; pi < out.parts.size(); ++pi) {
      if (generic.parts[pi].group != static_cast<int>(gi)) continue;
      const SecondaryPart& g = generic.parts[pi];
      SecondaryPart& p = out.parts[pi];
      for (int k = 0; k < g.NumVertices(); ++k) {
        Vec3 x = sr * Row(g.neutral, k) + st;
        const int f = g.follow[k];
        if (f >= 0) x += Row(person.neutral, f) - (sr * Row(generic_shapes.neutral, f) + st);
        p.neutral.row(k) = x.transpose();
      }
      for (int i = 0; i < S; ++i) {
        if (group.rigid) {
          for (int k = 0; k < g.NumVertices(); ++k) {
            const Vec3 x = Row(p.neutral, k);
            Vec3 d = jaw_r[i] * x + jaw_t[i] - x;
            if (prior[i] >= 0) {
              const Vec3 xg = Row(g.neutral, k);
              const Vec3 extra = DeltaOf(g.deltas, k, prior[i]) -
                                 (generic_r[prior[i]] * xg + generic_t[prior[i]] - xg);
              d += sr * extra;
            }
            p.deltas.block<3, 1>(3 * k, i) = d;
          }
          continue;
        }
        const Eigen::VectorXf moved = g.deltas * coeffs[i];
        for (int k = 0; k < g.NumVertices(); ++k) {
          Vec3 d = sr * moved.segment<3>(3 * k);
          const int f = g.follow[k];
          if (f >= 0 && options.follow_residual) {
            const Vec3 face_fit = sr * (generic_shapes.deltas.middleRows<3>(3 * f) * coeffs[i]);
            d += DeltaOf(person.deltas, f, i) - face_fit;
          }
          p.deltas.block<3, 1>(3 * k, i) = d;
        }
      }
    }
  }
  // 4. Eyeballs behind the lids.
  if (options.clearance_shapes > 0) {
    SetEyeballsBehindLids(person, options.clearance_shapes, &out, report);
  }
  if (report) {
    report->placement_rms_cm = placement_n ? static_cast<float>(std::sqrt(placement_sq / placement_n)) : 0.f;
    for (int i = 0; i < S; ++i) report->fit_rms_cm[i] = fit_n ? static_cast<float>(std::sqrt(fit_sq[i] / fit_n)) : 0.f;
  }
  return out;
}

// ---- irises ---------------------------------------------------------------------------------

const std::vector<Eigen::Vector3f>& IrisColors() {
  // Linear RGB: dark brown, brown, light brown, hazel, amber, green, grey-green, grey, blue-grey,
  // blue, light blue, violet-grey.
  static const std::vector<Eigen::Vector3f> colors = {
      {0.045f, 0.022f, 0.010f}, {0.090f, 0.045f, 0.018f}, {0.160f, 0.085f, 0.035f},
      {0.150f, 0.120f, 0.045f}, {0.220f, 0.130f, 0.030f}, {0.080f, 0.130f, 0.060f},
      {0.120f, 0.150f, 0.120f}, {0.170f, 0.180f, 0.185f}, {0.130f, 0.160f, 0.200f},
      {0.070f, 0.130f, 0.240f}, {0.180f, 0.260f, 0.380f}, {0.160f, 0.140f, 0.200f}};
  return colors;
}

ImageF IrisTexture(int k, int size) {
  const auto& colors = IrisColors();
  if (k < 0 || k >= static_cast<int>(colors.size())) {
    throw InvalidInputError("iris index " + std::to_string(k) + " is not in [0, " +
                            std::to_string(colors.size()) + ")");
  }
  if (size < 8) throw InvalidInputError("iris texture size must be at least 8");
  ImageF img(size, size, 3);
  const Vec3 base = colors[k], sclera(0.78f, 0.74f, 0.70f);
  std::mt19937 rng(1234u + static_cast<unsigned>(k));
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  float fibre_phase[7];
  for (float& f : fibre_phase) f = 2.f * kPi * uni(rng);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float u = (x + 0.5f) / size * 2.f - 1.f, v = 1.f - (y + 0.5f) / size * 2.f;
      const float rad = std::sqrt(u * u + v * v), ang = std::atan2(v, u);
      Vec3 col;
      if (rad < kPupilRadius) {
        col = Vec3::Constant(0.01f);
      } else if (rad < kIrisRadius) {
        const float t = (rad - kPupilRadius) / (kIrisRadius - kPupilRadius);
        float fibre = 0.f;
        for (int h = 0; h < 7; ++h) fibre += std::sin((13 + 11 * h) * ang + fibre_phase[h] + 3.f * t);
        const float shade = 1.f + 0.12f * fibre / 7.f * 3.f;
        const float collarette = 1.f + 0.35f * std::exp(-std::pow((t - 0.25f) / 0.08f, 2.f));
        const float limbus = 1.f - 0.6f * std::exp(-std::pow((t - 1.f) / 0.08f, 2.f));
        col = base * shade * collarette * limbus;
      } else {
        col = sclera;
      }
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = col[c];
    }
  }
  return img;
}

bool AlbedoIrisColor(const rig::Rig& face, const ImageF& albedo, Eigen::Vector3f* color) {
  if (albedo.empty() || face.uv_triangles.rows() != face.triangles.rows()) return false;
  int iris = -1;
  for (size_t r = 0; r < face.regions.size(); ++r) {
    if (face.regions[r].name == "iris") iris = static_cast<int>(r);
  }
  if (iris < 0) return false;
  Vec3 sum = Vec3::Zero();
  int n = 0;
  for (int f = 0; f < face.triangles.rows(); ++f) {
    if (face.triangle_region(f) != iris) continue;
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();
    for (int c = 0; c < 3; ++c) uv += face.uvs.row(face.uv_triangles(f, c)).transpose() / 3.f;
    sum += render::SampleBilinear(albedo, uv.x(), uv.y());
    ++n;
  }
  if (n == 0) return false;
  *color = sum / n;
  return true;
}

int MatchIris(const rig::Rig& face, const ImageF& albedo) {
  Vec3 mean;
  if (!AlbedoIrisColor(face, albedo, &mean)) return 0;
  const auto& colors = IrisColors();
  int best = 0;
  for (size_t k = 1; k < colors.size(); ++k) {
    if ((colors[k] - mean).squaredNorm() < (colors[best] - mean).squaredNorm()) best = static_cast<int>(k);
  }
  return best;
}

std::vector<int> JawShapes(const rig::Rig& head, const LinearShapes& shapes) {
  std::vector<int> out;
  for (int j = 0; j < shapes.NumShapes(); ++j) {
    const int s = head.ShapeIndex(shapes.names[j]);
    if (s >= 0 && head.shapes[s].UsesJaw()) out.push_back(j);
  }
  return out;
}

// ---- checks ---------------------------------------------------------------------------------

namespace {

float PointTriangleDistance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Ericson, Real-Time Collision Detection, closest point on a triangle.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const Vec3 bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Vec3 cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  }
  const float denom = 1.f / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

}  // namespace

AssemblyChecks CheckAssembly(const PartSet& parts, const LinearShapes& face, const FaceParts& where,
                             const rig::Triangles& triangles, int combinations, unsigned seed,
                             const std::vector<int>& jaw_shapes, const LinearShapes* jaw_truth) {
  const int N = face.NumShapes();
  if (parts.NumShapes() != N) throw InvalidInputError("assembly check: parts and face differ in shape count");
  const std::vector<Eigen::VectorXf> poses = CheckPoses(N, combinations, seed);
  AssemblyChecks out;
  out.poses = static_cast<int>(poses.size());
  double root_sum = 0.0;
  long root_n = 0;
  const Eigen::Map<const Eigen::VectorXf> neutral_flat(face.neutral.data(), face.neutral.size());
  for (const Eigen::VectorXf& w : poses) {
    const Eigen::VectorXf flat = neutral_flat + face.deltas * w;
    auto vert = [&](int v) { return Vec3(flat.segment<3>(3 * v)); };
    for (int side = 0; side < 2; ++side) {
      const std::string prefix = side == 0 ? "left_" : "right_";
      // Lash roots (row 0 of each card) to the nearest lid triangle.
      for (const char* lid : {"upper_lashes", "lower_lashes"}) {
        const int pi = parts.PartIndex(prefix + lid);
        if (pi < 0) continue;
        const rig::Vertices lash = parts.parts[pi].Evaluate(w);
        for (int k = 0; k < lash.rows(); k += 3) {
          const Vec3 p = Row(lash, k);
          float best = 1e9f;
          for (int f : where.lid_triangles[side]) {
            best = std::min(best, PointTriangleDistance(p, vert(triangles(f, 0)), vert(triangles(f, 1)),
                                                        vert(triangles(f, 2))));
          }
          root_sum += best;
          ++root_n;
          out.lash_root_max_mm = std::max(out.lash_root_max_mm, 10.f * best);
        }
      }
      // Lid vertices inside the eyeball part (its posed sphere).
      const int ei = parts.PartIndex(prefix + "eyeball");
      if (ei >= 0) {
        out.penetration_max_mm = std::max(out.penetration_max_mm,
                                          10.f * LidPenetration(parts.parts[ei], w, flat, where.lid_vertices[side]));
      }
    }
  }
  out.lash_root_mean_mm = root_n ? static_cast<float>(10.0 * root_sum / root_n) : 0.f;
  // Lower teeth against the jaw, single shapes only.
  const int ti = parts.PartIndex("lower_teeth");
  const LinearShapes& truth = jaw_truth ? *jaw_truth : face;
  std::vector<int> jaw_vertices;
  for (const PartGroup& g : parts.groups) {
    if (g.name == "jaw") jaw_vertices = g.fit;
  }
  if (truth.NumShapes() != N || truth.NumVertices() != face.NumVertices()) {
    throw InvalidInputError("assembly check: the jaw truth differs from the face in shapes or vertices");
  }
  if (ti >= 0 && !jaw_vertices.empty()) {
    const std::vector<Vec3> jaw0 = Gather(truth.neutral, jaw_vertices);
    const SecondaryPart& teeth = parts.parts[ti];
    std::vector<Vec3> teeth0(teeth.NumVertices());
    for (int k = 0; k < teeth.NumVertices(); ++k) teeth0[k] = Row(teeth.neutral, k);
    double sum = 0.0;
    for (int i : jaw_shapes) {
      if (i < 0 || i >= N) throw InvalidInputError("assembly check: jaw shape index out of range");
      std::vector<Vec3> jaw1 = jaw0;
      for (size_t k = 0; k < jaw1.size(); ++k) jaw1[k] += DeltaOf(truth.deltas, jaw_vertices[k], i);
      Eigen::Matrix3f rj, rt;
      Vec3 tj, tt;
      RigidFit(jaw0, jaw1, &rj, &tj);
      const rig::Vertices posed = teeth.Evaluate(Eigen::VectorXf::Unit(N, i));
      std::vector<Vec3> teeth1(posed.rows());
      for (int k = 0; k < posed.rows(); ++k) teeth1[k] = Row(posed, k);
      RigidFit(teeth0, teeth1, &rt, &tt);
      const float err = RotationAngleDeg(rt * rj.transpose());
      sum += err;
      out.teeth_jaw_max_deg = std::max(out.teeth_jaw_max_deg, err);
      ++out.jaw_shapes;
    }
    out.teeth_jaw_mean_deg = out.jaw_shapes ? static_cast<float>(sum / out.jaw_shapes) : 0.f;
  }
  return out;
}

}  // namespace facecap::assets
