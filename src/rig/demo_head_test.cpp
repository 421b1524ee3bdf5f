#include "rig/demo_head.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "rig/arkit.h"

namespace facecap::rig {
namespace {

// One rig for the whole suite; building it is deterministic.
const Rig& Head() {
  static const Rig rig = MakeDemoHead();
  return rig;
}

int ShapeByName(const Rig& rig, const std::string& name) {
  for (int i = 0; i < rig.NumShapes(); ++i) {
    if (rig.shapes[i].name == name) return i;
  }
  return -1;
}

int RegionByName(const Rig& rig, const std::string& name) {
  for (int i = 0; i < static_cast<int>(rig.regions.size()); ++i) {
    if (rig.regions[i].name == name) return i;
  }
  return -1;
}

// The rig equation of paper 000 Sec. 6, written out here so that this test does not depend on
// rig/evaluate: S(w) = (M R(w) + (1 - M) I)(N + sum_i w_i D_i) + M T(w), rotation about the pivot,
// R(w) = Rz Ry Rx of sum_i w_i theta_i.
Vertices EvaluateRig(const Rig& rig, const std::map<std::string, float>& weights) {
  Vertices linear = rig.neutral;
  Eigen::Vector3f euler = Eigen::Vector3f::Zero(), translation = Eigen::Vector3f::Zero();
  for (const auto& [name, w] : weights) {
    const int i = ShapeByName(rig, name);
    EXPECT_GE(i, 0) << name;
    if (i < 0) continue;
    const Shape& s = rig.shapes[i];
    for (size_t k = 0; k < s.delta.vertex.size(); ++k) {
      linear.row(s.delta.vertex[k]) += w * s.delta.offset[k].transpose();
    }
    euler += w * s.jaw_euler;
    translation += w * s.jaw_translation;
  }
  const Eigen::Matrix3f rotation = (Eigen::AngleAxisf(euler.z(), Eigen::Vector3f::UnitZ()) *
                                    Eigen::AngleAxisf(euler.y(), Eigen::Vector3f::UnitY()) *
                                    Eigen::AngleAxisf(euler.x(), Eigen::Vector3f::UnitX()))
                                       .toRotationMatrix();
  Vertices out = linear;
  for (int v = 0; v < linear.rows(); ++v) {
    const float m = rig.jaw_weights(v);
    const Eigen::Vector3f p = linear.row(v).transpose();
    const Eigen::Vector3f jaw = rotation * (p - rig.jaw_pivot) + rig.jaw_pivot + translation;
    out.row(v) = (m * jaw + (1.f - m) * p).transpose();
  }
  return out;
}

Eigen::Vector3f Landmark(const Rig& rig, const Vertices& v, int k) {
  return v.row(rig.landmarks(k)).transpose();
}

// True when every directed edge occurs once and its reverse occurs once (closed, manifold and
// consistently oriented); otherwise says which edge fails.
bool ClosedAndConsistent(const Triangles& triangles, std::string* why) {
  std::map<std::pair<int, int>, int> directed;
  for (int f = 0; f < triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) ++directed[{triangles(f, c), triangles(f, (c + 1) % 3)}];
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) {
      *why = "directed edge " + std::to_string(edge.first) + "->" + std::to_string(edge.second) +
             " occurs " + std::to_string(count) + " times";
      return false;
    }
    if (!directed.count({edge.second, edge.first})) {
      *why = "edge " + std::to_string(edge.first) + "->" + std::to_string(edge.second) +
             " has no reverse (open boundary or flipped triangle)";
      return false;
    }
  }
  return true;
}

// Connected components of the vertices through triangles.
std::vector<int> Components(int num_vertices, const Triangles& triangles) {
  std::vector<int> parent(num_vertices);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int f = 0; f < triangles.rows(); ++f) {
    parent[find(triangles(f, 1))] = find(triangles(f, 0));
    parent[find(triangles(f, 2))] = find(triangles(f, 0));
  }
  std::vector<int> component(num_vertices);
  for (int v = 0; v < num_vertices; ++v) component[v] = find(v);
  return component;
}

// Signed volume enclosed by the triangles of component `c`.
double SignedVolume(const Vertices& v, const Triangles& triangles, const std::vector<int>& component,
                    int c) {
  double volume = 0.0;
  for (int f = 0; f < triangles.rows(); ++f) {
    if (component[triangles(f, 0)] != c) continue;
    const Eigen::Vector3d a = v.row(triangles(f, 0)).cast<double>().transpose();
    const Eigen::Vector3d b = v.row(triangles(f, 1)).cast<double>().transpose();
    const Eigen::Vector3d d = v.row(triangles(f, 2)).cast<double>().transpose();
    volume += a.dot(b.cross(d)) / 6.0;
  }
  return volume;
}

// Centre of the eyeball whose pupil is on side sign(x) == sign.
Eigen::Vector3f EyeballCentre(const Rig& rig, const Vertices& v, float sign) {
  const std::vector<int> component = Components(rig.NumVertices(), rig.triangles);
  const int pupil = RegionByName(rig, "pupil");
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    if (rig.triangle_region(f) != pupil || v(rig.triangles(f, 0), 0) * sign <= 0.f) continue;
    const int c = component[rig.triangles(f, 0)];
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    int count = 0;
    for (int k = 0; k < rig.NumVertices(); ++k) {
      if (component[k] == c) {
        sum += v.row(k).transpose();
        ++count;
      }
    }
    return sum / static_cast<float>(count);
  }
  ADD_FAILURE() << "no pupil on side " << sign;
  return Eigen::Vector3f::Zero();
}

TEST(DemoHeadOptions, CheckRejectsOutOfRangeFields) {
  std::string why;
  EXPECT_TRUE(DemoHeadOptions().Check(&why)) << why;
  DemoHeadOptions bad;
  bad.resolution = 10;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("resolution"), std::string::npos);
  bad = DemoHeadOptions();
  bad.num_identity_modes = MaxDemoIdentityModes() + 1;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("num_identity_modes"), std::string::npos);
  EXPECT_THROW(MakeDemoHead(bad), std::invalid_argument);
}

TEST(DemoHead, HasEnoughVerticesAndConsistentSizes) {
  const Rig& rig = Head();
  EXPECT_GE(rig.NumVertices(), 5000);
  EXPECT_LE(rig.NumVertices(), 12000);
  EXPECT_EQ(rig.uv_triangles.rows(), rig.triangles.rows());
  EXPECT_EQ(rig.triangle_region.size(), rig.triangles.rows());
  EXPECT_EQ(rig.jaw_weights.size(), rig.NumVertices());
  EXPECT_EQ(rig.triangles.minCoeff(), 0);
  EXPECT_LT(rig.triangles.maxCoeff(), rig.NumVertices());
  EXPECT_GE(rig.uv_triangles.minCoeff(), 0);
  EXPECT_LT(rig.uv_triangles.maxCoeff(), rig.uvs.rows());
  EXPECT_TRUE(rig.neutral.allFinite());
  EXPECT_GE(rig.uvs.minCoeff(), 0.f);
  EXPECT_LE(rig.uvs.maxCoeff(), 1.f);
}

TEST(DemoHead, PassesRigCheck) {
  std::string why;
  EXPECT_TRUE(Head().Check(&why)) << why;
  EXPECT_TRUE(WithIdentity(Head(), 3).Check(&why)) << why;
}

TEST(DemoHead, MeshIsClosedAndConsistentlyOriented) {
  const Rig& rig = Head();
  std::string why;
  EXPECT_TRUE(ClosedAndConsistent(rig.triangles, &why)) << why;
  // The checker itself catches a flipped triangle.
  Triangles flipped = rig.triangles;
  std::swap(flipped(100, 1), flipped(100, 2));
  EXPECT_FALSE(ClosedAndConsistent(flipped, &why));
}

TEST(DemoHead, EveryComponentEnclosesPositiveVolume) {
  // Counter-clockwise seen from outside means outward normals: positive enclosed volume.
  const Rig& rig = Head();
  const std::vector<int> component = Components(rig.NumVertices(), rig.triangles);
  std::set<int> roots(component.begin(), component.end());
  EXPECT_EQ(roots.size(), 3u) << "head and two eyeballs";
  for (int c : roots) {
    const double volume = SignedVolume(rig.neutral, rig.triangles, component, c);
    EXPECT_GT(volume, 5.0) << "component " << c;  // an eyeball is about 7 cm^3
  }
}

TEST(DemoHead, NoDegenerateTriangles) {
  const Rig& rig = Head();
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    const int a = rig.triangles(f, 0), b = rig.triangles(f, 1), c = rig.triangles(f, 2);
    ASSERT_TRUE(a != b && b != c && a != c) << "triangle " << f;
    const Eigen::Vector3f pa = rig.neutral.row(a), pb = rig.neutral.row(b), pc = rig.neutral.row(c);
    ASSERT_GT((pb - pa).cross(pc - pa).norm(), 1e-6f) << "triangle " << f;
  }
}

TEST(DemoHead, RegionsAreDistinctAndAllUsed) {
  const Rig& rig = Head();
  ASSERT_GE(rig.regions.size(), 12u);
  std::vector<int> used(rig.regions.size(), 0);
  for (int f = 0; f < rig.triangle_region.size(); ++f) {
    ASSERT_GE(rig.triangle_region(f), 0);
    ASSERT_LT(rig.triangle_region(f), static_cast<int>(rig.regions.size()));
    ++used[rig.triangle_region(f)];
  }
  for (size_t r = 0; r < rig.regions.size(); ++r) {
    EXPECT_GT(used[r], 0) << rig.regions[r].name;
    for (size_t s = r + 1; s < rig.regions.size(); ++s) {
      EXPECT_GT((rig.regions[r].color - rig.regions[s].color).norm(), 0.2f)
          << rig.regions[r].name << " vs " << rig.regions[s].name;
    }
  }
  for (const char* name : {"left_upper_eyelid", "left_lower_eyelid", "right_upper_eyelid",
                           "right_lower_eyelid", "upper_lip", "lower_lip", "mouth_interior",
                           "left_brow", "right_brow", "nose", "neck", "skin", "sclera", "iris"}) {
    EXPECT_GE(RegionByName(rig, name), 0) << name;
  }
}

TEST(DemoHead, RegionsFollowLandmarks) {
  // The lid and lip borders are what the tracker matches: the margin landmarks sit on triangles
  // of the matching regions.
  const Rig& rig = Head();
  auto touches = [&](int landmark, const std::string& region) {
    const int r = RegionByName(rig, region), v = rig.landmarks(landmark);
    for (int f = 0; f < rig.triangles.rows(); ++f) {
      if (rig.triangle_region(f) == r && (rig.triangles.row(f).array() == v).any()) return true;
    }
    return false;
  };
  EXPECT_TRUE(touches(43, "left_upper_eyelid"));
  EXPECT_TRUE(touches(47, "left_lower_eyelid"));
  EXPECT_TRUE(touches(37, "right_upper_eyelid"));
  EXPECT_TRUE(touches(41, "right_lower_eyelid"));
  EXPECT_TRUE(touches(62, "upper_lip"));
  EXPECT_TRUE(touches(66, "lower_lip"));
  EXPECT_TRUE(touches(62, "mouth_interior"));
  EXPECT_TRUE(touches(66, "mouth_interior"));
  EXPECT_TRUE(touches(19, "right_brow"));
  EXPECT_TRUE(touches(24, "left_brow"));
  EXPECT_TRUE(touches(30, "nose"));
}

TEST(DemoHead, LandmarksAreDistinctAndPlausible) {
  const Rig& rig = Head();
  ASSERT_EQ(rig.landmarks.size(), 68);
  std::set<int> distinct(rig.landmarks.data(), rig.landmarks.data() + 68);
  EXPECT_EQ(distinct.size(), 68u);
  const Vertices& n = rig.neutral;
  auto p = [&](int k) { return Landmark(rig, n, k); };
  // Subject's left (+x) and right (-x).
  for (int k = 36; k <= 41; ++k) EXPECT_LT(p(k).x(), 0.f) << k;
  for (int k = 42; k <= 47; ++k) EXPECT_GT(p(k).x(), 0.f) << k;
  for (int k = 17; k <= 21; ++k) EXPECT_LT(p(k).x(), 0.f) << k;
  for (int k = 22; k <= 26; ++k) EXPECT_GT(p(k).x(), 0.f) << k;
  EXPECT_LT(p(0).x(), p(8).x());
  EXPECT_GT(p(16).x(), p(8).x());
  EXPECT_LT(p(36).x(), p(39).x());  // right eye: outer corner further out than inner
  EXPECT_GT(p(45).x(), p(42).x());
  EXPECT_LT(p(48).x(), p(54).x());
  // Nose tip is the most forward landmark.
  for (int k = 0; k < 68; ++k) {
    if (k != 30) {
      EXPECT_LT(p(k).z(), p(30).z()) << k;
    }
  }
  // Vertical order: brows above eyes above nose tip above mouth above chin.
  const float eye_y = 0.5f * (p(39).y() + p(42).y());
  for (int k = 17; k <= 26; ++k) EXPECT_GT(p(k).y(), eye_y + 0.5f) << k;
  for (int k = 0; k <= 16; ++k) EXPECT_LT(p(k).y(), eye_y - 1.f) << k;
  EXPECT_LT(p(30).y(), eye_y);
  EXPECT_LT(p(51).y(), p(33).y());
  EXPECT_LT(p(57).y(), p(51).y());
  EXPECT_LT(p(8).y(), p(57).y());
  // Upper lid above lower lid, upper lip above lower lip (outer and inner).
  EXPECT_GT(p(43).y(), p(47).y() + 0.5f);
  EXPECT_GT(p(38).y(), p(40).y() + 0.5f);
  EXPECT_GT(p(51).y(), p(57).y() + 1.f);
  // Inner lip landmarks sit on the slit: closed in the neutral, but distinct vertices.
  EXPECT_LT((p(62) - p(66)).norm(), 0.05f);
  EXPECT_NE(rig.landmarks(62), rig.landmarks(66));
  // Mirror symmetry of the mean face.
  const std::pair<int, int> mirror[] = {{0, 16}, {4, 12}, {17, 26}, {21, 22}, {36, 45},
                                        {39, 42}, {31, 35}, {48, 54}, {60, 64}};
  for (const auto& [a, b] : mirror) {
    EXPECT_NEAR(p(a).x(), -p(b).x(), 0.05f) << a << " " << b;
    EXPECT_NEAR(p(a).y(), p(b).y(), 0.05f) << a << " " << b;
  }
}

TEST(DemoHead, HasAllArkitShapesInOrder) {
  const Rig& rig = Head();
  const std::vector<std::string>& names = ArkitShapeNames();
  ASSERT_EQ(names.size(), 52u);
  EXPECT_EQ(names.front(), "eyeBlinkLeft");
  EXPECT_EQ(names.back(), "tongueOut");
  EXPECT_EQ(ArkitIndex("jawOpen"), 17);
  EXPECT_EQ(ArkitIndex("notAShape"), -1);
  ASSERT_EQ(rig.NumShapes(), 52);
  for (int i = 0; i < 52; ++i) {
    EXPECT_EQ(rig.shapes[i].name, names[i]);
    const Shape& s = rig.shapes[i];
    EXPECT_TRUE(s.UsesJaw() || !s.delta.vertex.empty()) << s.name << " does nothing";
    EXPECT_TRUE(std::is_sorted(s.delta.vertex.begin(), s.delta.vertex.end())) << s.name;
    EXPECT_EQ(s.delta.vertex.size(), s.delta.offset.size()) << s.name;
  }
}

TEST(DemoHead, JawShapesUseJawSkinning) {
  const Rig& rig = Head();
  for (const char* name : {"jawOpen", "jawLeft", "jawRight", "jawForward"}) {
    const Shape& s = rig.shapes[ShapeByName(rig, name)];
    EXPECT_TRUE(s.UsesJaw()) << name;
    EXPECT_TRUE(s.delta.vertex.empty()) << name;
  }
  for (const Shape& s : rig.shapes) {
    if (s.name.rfind("jaw", 0) != 0) {
      EXPECT_FALSE(s.UsesJaw()) << s.name;
    }
  }
  const Shape& open = rig.shapes[ShapeByName(rig, "jawOpen")];
  EXPECT_GT(open.jaw_euler.x(), 0.3f);
  EXPECT_LT(open.jaw_euler.x(), 0.5f);
  EXPECT_GT(rig.shapes[ShapeByName(rig, "jawForward")].jaw_translation.z(), 0.f);
  // M: 1 on chin and lower lip, 0 on the upper lip, nose, brows and eyes.
  auto m = [&](int k) { return rig.jaw_weights(rig.landmarks(k)); };
  EXPECT_GT(m(8), 0.95f);
  EXPECT_GT(m(57), 0.95f);
  EXPECT_GT(m(66), 0.95f);
  EXPECT_LT(m(51), 0.05f);
  EXPECT_LT(m(62), 0.05f);
  EXPECT_LT(m(30), 0.01f);
  EXPECT_LT(m(19), 0.01f);
  EXPECT_LT(m(43), 0.01f);
  EXPECT_GE(rig.jaw_weights.minCoeff(), 0.f);
  EXPECT_LE(rig.jaw_weights.maxCoeff(), 1.f);
  // Pivot in front of the ears, below the eyes.
  EXPECT_LT(rig.jaw_pivot.y(), Landmark(rig, rig.neutral, 39).y());
  EXPECT_LT(std::abs(rig.jaw_pivot.z()), 3.f);
}

TEST(DemoHead, JawOpenOpensTheMouthAndMouthCloseClosesTheLips) {
  const Rig& rig = Head();
  const Vertices open = EvaluateRig(rig, {{"jawOpen", 1.f}});
  const float gap = (Landmark(rig, open, 62) - Landmark(rig, open, 66)).norm();
  EXPECT_GT(gap, 1.5f);
  EXPECT_LT(Landmark(rig, open, 8).y(), Landmark(rig, rig.neutral, 8).y() - 1.f);
  // The upper face does not move.
  EXPECT_LT((Landmark(rig, open, 30) - Landmark(rig, rig.neutral, 30)).norm(), 1e-4f);
  const Vertices closed = EvaluateRig(rig, {{"jawOpen", 1.f}, {"mouthClose", 1.f}});
  EXPECT_LT((Landmark(rig, closed, 62) - Landmark(rig, closed, 66)).norm(), 0.25f * gap);
  // jawLeft moves the chin to the subject's left (+x), jawRight to -x.
  EXPECT_GT(Landmark(rig, EvaluateRig(rig, {{"jawLeft", 1.f}}), 8).x(), 0.3f);
  EXPECT_LT(Landmark(rig, EvaluateRig(rig, {{"jawRight", 1.f}}), 8).x(), -0.3f);
}

TEST(DemoHead, EyeBlinkLeftClosesTheLeftEyeOnly) {
  const Rig& rig = Head();
  const Vertices& n = rig.neutral;
  EXPECT_GT((Landmark(rig, n, 43) - Landmark(rig, n, 47)).norm(), 0.4f);
  EXPECT_GT((Landmark(rig, n, 44) - Landmark(rig, n, 46)).norm(), 0.4f);
  const Vertices blink = EvaluateRig(rig, {{"eyeBlinkLeft", 1.f}});
  EXPECT_LT((Landmark(rig, blink, 43) - Landmark(rig, blink, 47)).norm(), 0.02f);
  EXPECT_LT((Landmark(rig, blink, 44) - Landmark(rig, blink, 46)).norm(), 0.02f);
  // The upper lid came down; the right eye did not move.
  EXPECT_LT(Landmark(rig, blink, 43).y(), Landmark(rig, n, 43).y() - 0.4f);
  for (int k = 36; k <= 41; ++k) {
    EXPECT_LT((Landmark(rig, blink, k) - Landmark(rig, n, k)).norm(), 1e-5f) << k;
  }
  const Shape& s = rig.shapes[ShapeByName(rig, "eyeBlinkLeft")];
  for (int v : s.delta.vertex) EXPECT_GT(n(v, 0), 0.f);
  // The closed lid covers the eyeball: every lid margin vertex stays outside the eyeball.
  const Eigen::Vector3f centre = EyeballCentre(rig, n, 1.f);
  for (int k = 42; k <= 47; ++k) {
    EXPECT_GT((Landmark(rig, blink, k) - centre).norm(), 1.2f) << k;
  }
}

TEST(DemoHead, SidedShapesMoveTheirSide) {
  const Rig& rig = Head();
  const Vertices& n = rig.neutral;
  auto moved = [&](const std::string& shape, int k) {
    return Eigen::Vector3f(Landmark(rig, EvaluateRig(rig, {{shape, 1.f}}), k) - Landmark(rig, n, k));
  };
  EXPECT_GT(moved("mouthSmileLeft", 54).y(), 0.4f);
  EXPECT_LT(moved("mouthSmileLeft", 48).norm(), 0.05f);
  EXPECT_GT(moved("mouthSmileRight", 48).y(), 0.4f);
  EXPECT_LT(moved("mouthFrownLeft", 54).y(), -0.3f);
  EXPECT_GT(moved("mouthLeft", 62).x(), 0.5f);
  EXPECT_LT(moved("mouthRight", 62).x(), -0.5f);
  EXPECT_GT(moved("browOuterUpLeft", 26).y(), 0.3f);
  EXPECT_LT(moved("browOuterUpLeft", 17).norm(), 0.05f);
  EXPECT_LT(moved("browDownRight", 20).y(), -0.2f);
  EXPECT_GT(moved("browInnerUp", 21).y(), 0.3f);
  EXPECT_GT(moved("browInnerUp", 22).y(), 0.3f);
  EXPECT_GT(moved("mouthPucker", 62).z(), 0.5f);
  EXPECT_GT(moved("eyeWideLeft", 44).y(), 0.1f);
  EXPECT_GT(moved("eyeSquintLeft", 46).y(), 0.05f);
  // eyeLookInLeft turns the left pupil towards the nose (-x), eyeLookOutLeft away.
  auto pupil_shift = [&](const std::string& shape) {
    const Vertices v = EvaluateRig(rig, {{shape, 1.f}});
    const int pupil = RegionByName(rig, "pupil");
    Eigen::Vector3f before = Eigen::Vector3f::Zero(), after = Eigen::Vector3f::Zero();
    for (int f = 0; f < rig.triangles.rows(); ++f) {
      if (rig.triangle_region(f) != pupil || n(rig.triangles(f, 0), 0) < 0.f) continue;
      before += n.row(rig.triangles(f, 0)).transpose();
      after += v.row(rig.triangles(f, 0)).transpose();
    }
    return Eigen::Vector3f(after - before);
  };
  EXPECT_LT(pupil_shift("eyeLookInLeft").x(), 0.f);
  EXPECT_GT(pupil_shift("eyeLookOutLeft").x(), 0.f);
  EXPECT_GT(pupil_shift("eyeLookUpLeft").y(), 0.f);
  EXPECT_LT(pupil_shift("eyeLookDownLeft").y(), 0.f);
}

// Rasterizes UV triangles into a square texel grid, sampling at texel centres in exact integer
// arithmetic (UVs snapped to 1/256 texel), and counts per texel the triangles that hold the
// centre strictly inside and those that hold it inside or on their boundary.
class UvCoverage {
 public:
  explicit UvCoverage(int size)
      : size_(size), strict_(size * size, 0), closed_(size * size, 0), owner_(size * size, -1) {}

  void Add(const Eigen::Vector2f& a, const Eigen::Vector2f& b, const Eigen::Vector2f& c, int id) {
    std::array<Eigen::Matrix<int64_t, 2, 1>, 3> p = {Snap(a), Snap(b), Snap(c)};
    int64_t area = Edge(p[0], p[1], p[2]);
    if (area == 0) return;  // covers no centre strictly
    if (area < 0) std::swap(p[1], p[2]);  // a flipped triangle still covers its texels
    const int64_t lo_x = std::min({p[0].x(), p[1].x(), p[2].x()});
    const int64_t hi_x = std::max({p[0].x(), p[1].x(), p[2].x()});
    const int64_t lo_y = std::min({p[0].y(), p[1].y(), p[2].y()});
    const int64_t hi_y = std::max({p[0].y(), p[1].y(), p[2].y()});
    const int x0 = std::max<int>(0, static_cast<int>(lo_x / kSub) - 1);
    const int x1 = std::min<int>(size_ - 1, static_cast<int>(hi_x / kSub) + 1);
    const int y0 = std::max<int>(0, static_cast<int>(lo_y / kSub) - 1);
    const int y1 = std::min<int>(size_ - 1, static_cast<int>(hi_y / kSub) + 1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Matrix<int64_t, 2, 1> q(int64_t{x} * kSub + kSub / 2,
                                             int64_t{y} * kSub + kSub / 2);
        const int64_t e0 = Edge(p[0], p[1], q), e1 = Edge(p[1], p[2], q), e2 = Edge(p[2], p[0], q);
        if (e0 < 0 || e1 < 0 || e2 < 0) continue;
        const int texel = y * size_ + x;
        ++closed_[texel];
        if (e0 > 0 && e1 > 0 && e2 > 0) {
          ++strict_[texel];
          owner_[texel] = id;
        }
      }
    }
  }
  // A centre strictly inside one triangle and inside or on another: the two overlap. A centre
  // exactly on an edge or a corner that triangles share is not counted.
  bool Overlaps(int texel) const {
    return strict_[texel] >= 2 || (strict_[texel] == 1 && closed_[texel] >= 2);
  }
  int Owner(int texel) const { return owner_[texel]; }
  bool Covered(int texel) const { return closed_[texel] > 0; }
  int NumTexels() const { return size_ * size_; }

 private:
  static constexpr int64_t kSub = 256;  // subdivisions of a texel
  Eigen::Matrix<int64_t, 2, 1> Snap(const Eigen::Vector2f& uv) const {
    return {std::llround(double(uv.x()) * size_ * kSub),
            std::llround(double(uv.y()) * size_ * kSub)};
  }
  static int64_t Edge(const Eigen::Matrix<int64_t, 2, 1>& a, const Eigen::Matrix<int64_t, 2, 1>& b,
                      const Eigen::Matrix<int64_t, 2, 1>& q) {
    return (b.x() - a.x()) * (q.y() - a.y()) - (b.y() - a.y()) * (q.x() - a.x());
  }

  int size_;
  std::vector<int> strict_, closed_, owner_;
};

TEST(DemoHead, UvCoverageCountsSharedEdgesOnceAndOverlapsTwice) {
  // Two triangles of a unit square share the diagonal, which runs through texel centres.
  UvCoverage square(8);
  const Eigen::Vector2f a(0.f, 0.f), b(1.f, 0.f), c(1.f, 1.f), d(0.f, 1.f);
  square.Add(a, b, c, 0);
  square.Add(a, c, d, 1);
  for (int t = 0; t < square.NumTexels(); ++t) {
    EXPECT_TRUE(square.Covered(t)) << t;
    EXPECT_FALSE(square.Overlaps(t)) << t;
  }
  // A third, flipped triangle over part of the square overlaps it.
  square.Add(Eigen::Vector2f(0.1f, 0.1f), Eigen::Vector2f(0.4f, 0.6f), Eigen::Vector2f(0.6f, 0.1f),
             2);
  int overlapping = 0;
  for (int t = 0; t < square.NumTexels(); ++t) overlapping += square.Overlaps(t);
  EXPECT_GT(overlapping, 0);
}

TEST(DemoHead, FaceUvsDoNotOverlap) {
  // The head's chart (skin, hair, neck, nose, brows, lids, lips: the grid and its poles) maps
  // every triangle to its own part of the texture. The eyeballs are front projections (their
  // backs fall onto their fronts) and the pockets stretch from the opening's loop into their
  // boxes, so they are not part of it.
  const Rig& rig = Head();
  const std::set<int> not_skin = {RegionByName(rig, "sclera"), RegionByName(rig, "iris"),
                                  RegionByName(rig, "pupil"), RegionByName(rig, "mouth_interior")};
  constexpr int kTexels = 512;
  UvCoverage coverage(kTexels);
  int front = 0;
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    if (not_skin.count(rig.triangle_region(f))) continue;
    const Eigen::Vector2f a = rig.uvs.row(rig.uv_triangles(f, 0));
    const Eigen::Vector2f b = rig.uvs.row(rig.uv_triangles(f, 1));
    const Eigen::Vector2f c = rig.uvs.row(rig.uv_triangles(f, 2));
    coverage.Add(a, b, c, f);
    const Eigen::Vector3f centre = (rig.neutral.row(rig.triangles(f, 0)) +
                                    rig.neutral.row(rig.triangles(f, 1)) +
                                    rig.neutral.row(rig.triangles(f, 2))).transpose() / 3.f;
    if (centre.z() < 1.f) continue;  // the face front, away from the seam at the back
    // Front triangles keep the orientation of the chart (not flipped).
    const float area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    ASSERT_GT(area, 0.f) << "triangle " << f;
    ++front;
  }
  EXPECT_GT(front, 4000);
  int covered = 0, overlapping = 0;
  for (int t = 0; t < coverage.NumTexels(); ++t) {
    covered += coverage.Covered(t);
    if (coverage.Overlaps(t)) {
      if (overlapping++ < 10) {
        ADD_FAILURE() << "texel (" << t % kTexels << ", " << t / kTexels
                      << ") is covered by more than one triangle, one of them "
                      << coverage.Owner(t);
      }
    }
  }
  EXPECT_EQ(overlapping, 0);
  // The chart spans u in [0, 1] and v in [0.22, 0.98]: nearly all of that band is covered
  // (the eye and mouth openings are holes).
  EXPECT_GT(covered, 0.9 * kTexels * kTexels * 0.76);
}

TEST(DemoHead, IdentityModesAreSmoothAndPlausible) {
  const Rig& rig = Head();
  ASSERT_GE(rig.identity_modes.size(), 20u);
  EXPECT_EQ(rig.identity_modes.size(), DemoIdentityModeNames().size() >= 24 ? 24u : 0u);
  for (size_t k = 0; k < rig.identity_modes.size(); ++k) {
    const Vertices& mode = rig.identity_modes[k];
    ASSERT_EQ(mode.rows(), rig.NumVertices());
    const float largest = mode.rowwise().norm().maxCoeff();
    EXPECT_GT(largest, 0.15f) << DemoIdentityModeNames()[k];
    EXPECT_LT(largest, 1.5f) << DemoIdentityModeNames()[k];
    // Smooth: neighbouring vertices move alike.
    for (int f = 0; f < rig.triangles.rows(); ++f) {
      const float jump = (mode.row(rig.triangles(f, 0)) - mode.row(rig.triangles(f, 1))).norm();
      ASSERT_LT(jump, 0.5f) << DemoIdentityModeNames()[k] << " triangle " << f;
    }
  }
}

TEST(DemoHead, WithIdentityIsDeterministicAndMakesDifferentPeople) {
  const Rig& rig = Head();
  const Rig mean = WithIdentity(rig, 0);
  EXPECT_TRUE(mean.neutral == rig.neutral);
  const Rig a = WithIdentity(rig, 1), a_again = WithIdentity(rig, 1), b = WithIdentity(rig, 2);
  EXPECT_TRUE(a.neutral == a_again.neutral);
  EXPECT_GT((a.neutral - b.neutral).rowwise().norm().maxCoeff(), 0.5f);
  EXPECT_GT((a.neutral - rig.neutral).rowwise().norm().maxCoeff(), 0.5f);
  EXPECT_EQ(DemoIdentityCoefficients(7, 5), DemoIdentityCoefficients(7, 5));
  EXPECT_NE(DemoIdentityCoefficients(7, 5), DemoIdentityCoefficients(8, 5));
  // Many people stay valid: eyes in their sockets (behind the lid margins and inside the head),
  // and the blink still closes the eye.
  for (int seed = 1; seed <= 20; ++seed) {
    const Rig person = WithIdentity(rig, seed);
    ASSERT_TRUE(person.neutral.allFinite());
    for (float side : {1.f, -1.f}) {
      const Eigen::Vector3f centre = EyeballCentre(person, person.neutral, side);
      const int first = side > 0 ? 42 : 36;
      for (int k = first; k < first + 6; ++k) {
        const float d = (Landmark(person, person.neutral, k) - centre).norm();
        const bool corner = k == first || k == first + 3;
        EXPECT_GT(d, 1.2f) << "seed " << seed << " landmark " << k;
        EXPECT_LT(d, corner ? 2.7f : 1.8f) << "seed " << seed << " landmark " << k;
      }
    }
    const Vertices blink = EvaluateRig(person, {{"eyeBlinkLeft", 1.f}});
    EXPECT_LT((Landmark(person, blink, 43) - Landmark(person, blink, 47)).norm(), 0.1f) << seed;
  }
}

TEST(DemoHead, SameOptionsGiveIdenticalRigs) {
  DemoHeadOptions options;
  options.resolution = 80;
  options.num_identity_modes = 4;
  const Rig a = MakeDemoHead(options), b = MakeDemoHead(options);
  ASSERT_EQ(a.neutral.size(), b.neutral.size());
  EXPECT_EQ(std::memcmp(a.neutral.data(), b.neutral.data(), sizeof(float) * a.neutral.size()), 0);
  EXPECT_TRUE(a.triangles == b.triangles);
  EXPECT_TRUE(a.uvs == b.uvs);
  EXPECT_TRUE(a.jaw_weights == b.jaw_weights);
  for (int i = 0; i < a.NumShapes(); ++i) {
    ASSERT_EQ(a.shapes[i].delta.vertex, b.shapes[i].delta.vertex);
    for (size_t k = 0; k < a.shapes[i].delta.offset.size(); ++k) {
      ASSERT_TRUE(a.shapes[i].delta.offset[k] == b.shapes[i].delta.offset[k]);
    }
  }
  for (size_t k = 0; k < a.identity_modes.size(); ++k) {
    EXPECT_TRUE(a.identity_modes[k] == b.identity_modes[k]);
  }
  std::string why;
  EXPECT_TRUE(ClosedAndConsistent(a.triangles, &why)) << why;
  EXPECT_GE(a.NumVertices(), 5000);
}

}  // namespace
}  // namespace facecap::rig
