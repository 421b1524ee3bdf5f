#include "rig/evaluate.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "rig/pose.h"
#include "rig/rig.h"
#include "util/errors.h"

namespace facecap::rig {
namespace {

// ---- a small synthetic rig: subdivided icosahedron with random sparse shapes -------------------

void Icosphere(int subdivisions, float radius, Vertices* vertices, Triangles* triangles) {
  const float t = (1.f + std::sqrt(5.f)) / 2.f;
  std::vector<Eigen::Vector3f> v = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back((v[a] + v[b]) / 2.f);
      midpoint[key] = static_cast<int>(v.size()) - 1;
      return static_cast<int>(v.size()) - 1;
    };
    std::vector<Eigen::Vector3i> next;
    for (const auto& tri : f) {
      const int a = mid(tri[0], tri[1]), b = mid(tri[1], tri[2]), c = mid(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    f = next;
  }
  vertices->resize(static_cast<int>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) vertices->row(i) = radius * v[i].normalized().transpose();
  triangles->resize(static_cast<int>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) triangles->row(i) = f[i].transpose();
}

SparseDelta RandomSparseDelta(int num_vertices, float density, float magnitude,
                              std::mt19937* rng) {
  std::uniform_real_distribution<float> unit(0.f, 1.f), offset(-magnitude, magnitude);
  SparseDelta delta;
  for (int v = 0; v < num_vertices; ++v) {
    if (unit(*rng) >= density) continue;
    delta.vertex.push_back(v);
    delta.offset.emplace_back(offset(*rng), offset(*rng), offset(*rng));
  }
  return delta;
}

// Six shapes: 0, 1, 3, 5 plain sparse deltas; 2 a delta with jaw rotation and translation;
// 4 jaw only (no delta). Jaw weights in (0, 1] below the equator, 0 above.
Rig SyntheticRig(int subdivisions = 2, unsigned seed = 7) {
  std::mt19937 rng(seed);
  Rig rig;
  Icosphere(subdivisions, 10.f, &rig.neutral, &rig.triangles);
  const int num_vertices = rig.NumVertices();
  const int num_triangles = static_cast<int>(rig.triangles.rows());
  rig.uvs.resize(num_vertices, 2);
  for (int v = 0; v < num_vertices; ++v) {
    const Eigen::Vector3f p = rig.neutral.row(v).normalized();
    rig.uvs.row(v) << 0.5f + std::atan2(p.x(), p.z()) / 6.3f, 0.5f + std::asin(p.y()) / 3.2f;
  }
  rig.uv_triangles = rig.triangles;
  rig.regions = {{"upper", {1, 0, 0}}, {"lower", {0, 1, 0}}};
  rig.triangle_region.resize(num_triangles);
  for (int f = 0; f < num_triangles; ++f) {
    rig.triangle_region[f] = rig.neutral(rig.triangles(f, 0), 1) < 0 ? 1 : 0;
  }
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  rig.jaw_weights.resize(num_vertices);
  for (int v = 0; v < num_vertices; ++v) {
    const float y = rig.neutral(v, 1);
    rig.jaw_weights[v] = y < -5.f ? 1.f : (y < 0.f ? 0.05f + 0.9f * unit(rng) : 0.f);
  }
  rig.jaw_pivot = Eigen::Vector3f(0.f, 1.f, -6.f);
  const char* names[] = {"browUp", "eyeBlink", "jawOpen", "mouthSmile", "jawLeft", "cheekPuff"};
  for (int s = 0; s < 6; ++s) {
    Shape shape;
    shape.name = names[s];
    if (s != 4) shape.delta = RandomSparseDelta(num_vertices, 0.3f, 1.f, &rng);
    rig.shapes.push_back(shape);
  }
  rig.shapes[2].jaw_euler = Eigen::Vector3f(0.35f, 0.04f, -0.03f);
  rig.shapes[2].jaw_translation = Eigen::Vector3f(0.f, -0.2f, 0.4f);
  rig.shapes[4].jaw_euler = Eigen::Vector3f(0.02f, 0.15f, 0.1f);
  rig.shapes[4].jaw_translation = Eigen::Vector3f(0.3f, 0.f, 0.f);
  rig.landmarks.resize(68);
  for (int k = 0; k < 68; ++k) rig.landmarks[k] = (k * 7) % num_vertices;
  return rig;
}

Eigen::VectorXf RandomWeights(int n, std::mt19937* rng) {
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  Eigen::VectorXf w(n);
  for (int i = 0; i < n; ++i) w[i] = unit(*rng);
  return w;
}

// ---- dense double-precision reference of the rig equation -----------------------------------

using VerticesD = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Rz(ez) Ry(ey) Rx(ex) composed from axis rotations, independently of EulerToMatrix.
Eigen::Matrix3d ComposedEuler(const Eigen::Vector3d& e) {
  return (Eigen::AngleAxisd(e.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(e.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(e.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// params = [pitch, yaw, roll, tx, ty, tz, scale, w...]; returns P_rigid S(w) for all vertices,
// or S(w) when posed is false.
VerticesD ReferenceEvaluate(const Rig& rig, const Eigen::VectorXd& params, bool posed = true) {
  const int num_vertices = rig.NumVertices();
  const Eigen::VectorXd w = params.tail(rig.NumShapes());
  // Dense D_i.
  VerticesD blended = rig.neutral.cast<double>();
  for (int s = 0; s < rig.NumShapes(); ++s) {
    VerticesD dense = VerticesD::Zero(num_vertices, 3);
    for (size_t k = 0; k < rig.shapes[s].delta.vertex.size(); ++k) {
      dense.row(rig.shapes[s].delta.vertex[k]) = rig.shapes[s].delta.offset[k].cast<double>();
    }
    blended += w[s] * dense;
  }
  Eigen::Vector3d theta = Eigen::Vector3d::Zero(), translation = Eigen::Vector3d::Zero();
  for (int s = 0; s < rig.NumShapes(); ++s) {
    theta += w[s] * rig.shapes[s].jaw_euler.cast<double>();
    translation += w[s] * rig.shapes[s].jaw_translation.cast<double>();
  }
  const Eigen::Matrix3d jaw_rotation = ComposedEuler(theta);
  const Eigen::Vector3d pivot = rig.jaw_pivot.cast<double>();
  const Eigen::Matrix3d pose_rotation =
      ComposedEuler(Eigen::Vector3d(params[kPitch], params[kYaw], params[kRoll]));
  const Eigen::Vector3d pose_translation(params[kTx], params[kTy], params[kTz]);
  VerticesD out(num_vertices, 3);
  for (int v = 0; v < num_vertices; ++v) {
    const double m = rig.jaw_weights[v];
    const Eigen::Vector3d x = blended.row(v).transpose();
    // (M R + (1 - M) I) x + M T, R about the pivot.
    const Eigen::Vector3d s =
        m * (jaw_rotation * (x - pivot) + pivot) + (1.0 - m) * x + m * translation;
    const Eigen::Vector3d y = posed ? Eigen::Vector3d(params[kScale] * pose_rotation * s + pose_translation) : s;
    out.row(v) = y.transpose();
  }
  return out;
}

Eigen::VectorXd ParamsOf(const RigidPose& pose, const Eigen::VectorXf& w) {
  return PackRigParams(pose, w).cast<double>();
}

RigidPose TestPose() {
  RigidPose pose;
  pose.pitch = 0.2f;
  pose.yaw = -0.45f;
  pose.roll = 0.12f;
  pose.translation = Eigen::Vector3f(1.5f, -2.f, -55.f);
  pose.scale = 1.3f;
  return pose;
}

// ---- tests -----------------------------------------------------------------------------------

TEST(SyntheticRigTest, PassesCheck) {
  const Rig rig = SyntheticRig();
  std::string why;
  EXPECT_TRUE(rig.Check(&why)) << why;
  EXPECT_EQ(rig.ShapeIndex("jawOpen"), 2);
  EXPECT_EQ(rig.ShapeIndex("nope"), -1);
}

TEST(EvaluateShapeTest, MatchesDenseReferenceOnRandomWeights) {
  const Rig rig = SyntheticRig();
  std::mt19937 rng(11);
  RigEvaluator single(rig);
  RigEvaluator::Options threaded_options;
  threaded_options.num_threads = 4;
  RigEvaluator threaded(rig, threaded_options);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXf w = RandomWeights(rig.NumShapes(), &rng);
    const VerticesD expected = ReferenceEvaluate(rig, ParamsOf(RigidPose(), w), false);
    Vertices direct, from_single, from_threaded;
    EvaluateShape(rig, w, &direct);
    single.EvaluateShape(w, &from_single);
    threaded.EvaluateShape(w, &from_threaded);
    EXPECT_LT((direct.cast<double>() - expected).cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_LT((from_single.cast<double>() - expected).cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_LT((from_threaded.cast<double>() - expected).cwiseAbs().maxCoeff(), 1e-4);
    // The jaw actually moved something (the comparison is not vacuous).
    EXPECT_GT((expected - rig.neutral.cast<double>()).cwiseAbs().maxCoeff(), 0.1);
  }
}

TEST(EvaluateShapeTest, ZeroWeightsGiveNeutralAndReuseOutput) {
  const Rig rig = SyntheticRig();
  Vertices out(rig.NumVertices(), 3);
  const float* storage = out.data();
  RigEvaluator(rig).EvaluateShape(Eigen::VectorXf::Zero(rig.NumShapes()), &out);
  EXPECT_EQ(out.data(), storage);  // no reallocation
  EXPECT_EQ((out - rig.neutral).cwiseAbs().maxCoeff(), 0.f);
}

TEST(EvaluateShapeTest, JawOnlyShapeMovesOnlyJawSkinnedVertices) {
  const Rig rig = SyntheticRig();
  const int jaw_only = rig.ShapeIndex("jawLeft");
  ASSERT_TRUE(rig.shapes[jaw_only].delta.vertex.empty());
  Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
  w[jaw_only] = 1.f;
  Vertices out;
  EvaluateShape(rig, w, &out);
  int moved = 0;
  for (int v = 0; v < rig.NumVertices(); ++v) {
    const float distance = (out.row(v) - rig.neutral.row(v)).norm();
    if (rig.jaw_weights[v] == 0.f) {
      EXPECT_EQ(distance, 0.f) << "vertex " << v << " has no jaw weight but moved";
    } else if (distance > 1e-3f) {
      ++moved;
    }
  }
  EXPECT_GT(moved, rig.NumVertices() / 4);
}

TEST(EvaluatePosedTest, MatchesReference) {
  const Rig rig = SyntheticRig();
  std::mt19937 rng(3);
  const Eigen::VectorXf w = RandomWeights(rig.NumShapes(), &rng);
  const RigidPose pose = TestPose();
  const VerticesD expected = ReferenceEvaluate(rig, ParamsOf(pose, w));
  Vertices direct, from_evaluator;
  EvaluatePosed(rig, pose, w, &direct);
  RigEvaluator(rig).EvaluatePosed(pose, w, &from_evaluator);
  EXPECT_LT((direct.cast<double>() - expected).cwiseAbs().maxCoeff(), 2e-4);
  EXPECT_LT((from_evaluator.cast<double>() - expected).cwiseAbs().maxCoeff(), 2e-4);
  // Pose applied per vertex agrees with RigidPose::Apply.
  Vertices shape;
  EvaluateShape(rig, w, &shape);
  for (int v = 0; v < rig.NumVertices(); v += 17) {
    EXPECT_LT((pose.Apply(shape.row(v).transpose()) - direct.row(v).transpose()).norm(), 1e-4f);
  }
}

TEST(EvaluatePosedWithJacobianTest, MatchesCentralDifferencesForAllParameters) {
  const Rig rig = SyntheticRig();
  std::mt19937 rng(5);
  RigEvaluator evaluator(rig);
  std::vector<int> ids;
  for (int v = 0; v < rig.NumVertices(); v += 3) ids.push_back(v);
  bool saw_jaw_vertex = false;
  for (int v : ids) saw_jaw_vertex |= rig.jaw_weights[v] > 0.f && rig.jaw_weights[v] < 1.f;
  ASSERT_TRUE(saw_jaw_vertex);

  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXf w = RandomWeights(rig.NumShapes(), &rng);
    const RigidPose pose = TestPose();
    Vertices positions;
    Eigen::MatrixXf jacobian;
    evaluator.EvaluatePosedWithJacobian(pose, w, ids, &positions, &jacobian);
    ASSERT_EQ(jacobian.rows(), 3 * static_cast<int>(ids.size()));
    ASSERT_EQ(jacobian.cols(), NumRigParams(rig));

    const Eigen::VectorXd params = ParamsOf(pose, w);
    const VerticesD at = ReferenceEvaluate(rig, params);
    for (size_t k = 0; k < ids.size(); ++k) {
      EXPECT_LT((positions.row(k).cast<double>() - at.row(ids[k])).norm(), 2e-4);
    }
    const double step = 1e-5;
    for (int p = 0; p < NumRigParams(rig); ++p) {
      Eigen::VectorXd plus = params, minus = params;
      plus[p] += step;
      minus[p] -= step;
      const VerticesD difference =
          (ReferenceEvaluate(rig, plus) - ReferenceEvaluate(rig, minus)) / (2 * step);
      double largest = 0;
      for (size_t k = 0; k < ids.size(); ++k) {
        for (int c = 0; c < 3; ++c) {
          const double numeric = difference(ids[k], c);
          largest = std::max(largest, std::abs(numeric));
          EXPECT_NEAR(jacobian(3 * k + c, p), numeric, 1e-4 * (1.0 + std::abs(numeric)))
              << "parameter " << p << " vertex " << ids[k] << " coordinate " << c;
        }
      }
      EXPECT_GT(largest, 1e-3) << "parameter " << p << " has no effect; the check is vacuous";
    }
  }
}

TEST(EvaluatePosedWithJacobianTest, WrapperAgreesAndRejectsBadInput) {
  const Rig rig = SyntheticRig();
  std::mt19937 rng(9);
  const Eigen::VectorXf w = RandomWeights(rig.NumShapes(), &rng);
  const std::vector<int> ids = {0, 5, rig.NumVertices() - 1};
  Vertices a, b;
  Eigen::MatrixXf ja, jb;
  EvaluatePosedWithJacobian(rig, TestPose(), w, ids, &a, &ja);
  RigEvaluator(rig).EvaluatePosedWithJacobian(TestPose(), w, ids, &b, &jb);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.f);
  EXPECT_EQ((ja - jb).cwiseAbs().maxCoeff(), 0.f);
  EXPECT_THROW(RigEvaluator(rig).EvaluatePosedWithJacobian(TestPose(), w, {rig.NumVertices()},
                                                           &a, &ja),
               InvalidInputError);
  EXPECT_THROW(EvaluateShape(rig, Eigen::VectorXf::Zero(2), &a), InvalidInputError);
}

TEST(RigParamsTest, PackUnpackRoundTrip) {
  std::mt19937 rng(1);
  const Eigen::VectorXf w = RandomWeights(5, &rng);
  const Eigen::VectorXf params = PackRigParams(TestPose(), w);
  ASSERT_EQ(params.size(), kNumPoseParams + 5);
  EXPECT_EQ(params[kYaw], TestPose().yaw);
  EXPECT_EQ(params[kScale], TestPose().scale);
  RigidPose pose;
  Eigen::VectorXf back;
  UnpackRigParams(params, &pose, &back);
  EXPECT_EQ(back, w);
  EXPECT_EQ(pose.translation, TestPose().translation);
  EXPECT_EQ(pose.roll, TestPose().roll);
}

TEST(JawShapeIndicesTest, ListsShapesWithJawMotion) {
  const Rig rig = SyntheticRig();
  EXPECT_EQ(JawShapeIndices(rig), (std::vector<int>{2, 4}));
}

// ---- Rig::Check ------------------------------------------------------------------------------

TEST(RigCheckTest, ReportsNaNWithShapeNameAndVertex) {
  Rig rig = SyntheticRig();
  const int v = rig.shapes[1].delta.vertex[3];
  rig.shapes[1].delta.offset[3].y() = std::nanf("");
  std::string why;
  EXPECT_FALSE(rig.Check(&why));
  EXPECT_NE(why.find("eyeBlink"), std::string::npos) << why;
  EXPECT_NE(why.find("vertex " + std::to_string(v)), std::string::npos) << why;
}

TEST(RigCheckTest, ReportsNonFiniteNeutral) {
  Rig rig = SyntheticRig();
  rig.neutral(12, 0) = std::numeric_limits<float>::infinity();
  std::string why;
  EXPECT_FALSE(rig.Check(&why));
  EXPECT_NE(why.find("neutral vertex 12"), std::string::npos) << why;
}

TEST(RigCheckTest, ReportsOutOfRangeIndices) {
  {
    Rig rig = SyntheticRig();
    rig.triangles(7, 1) = rig.NumVertices();
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("triangle 7"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.shapes[0].delta.vertex.back() = rig.NumVertices() + 3;
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("browUp"), std::string::npos) << why;
    EXPECT_NE(why.find("outside"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.landmarks[5] = -1;
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("landmark 5"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.triangle_region[4] = 2;
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("region 2"), std::string::npos) << why;
  }
}

TEST(RigCheckTest, ReportsWrongSizes) {
  {
    Rig rig = SyntheticRig();
    rig.jaw_weights.conservativeResize(rig.NumVertices() - 1);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("jaw_weights"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.triangle_region.conservativeResize(3);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("triangle_region"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.uv_triangles.conservativeResize(5, 3);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("uv_triangles"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.landmarks.conservativeResize(10);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("landmarks"), std::string::npos) << why;
  }
}

TEST(RigCheckTest, ReportsDegenerateTriangles) {
  {
    Rig rig = SyntheticRig();
    rig.triangles(9, 2) = rig.triangles(9, 0);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("triangle 9 is degenerate"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    // Move one corner onto the midpoint of the opposite edge: zero area.
    const int a = rig.triangles(20, 0), b = rig.triangles(20, 1), c = rig.triangles(20, 2);
    rig.neutral.row(c) = 0.5f * (rig.neutral.row(a) + rig.neutral.row(b));
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("triangle 20 is degenerate: zero area"), std::string::npos) << why;
  }
}

TEST(RigCheckTest, ReportsBadJawWeightsAndUnsortedDeltas) {
  {
    Rig rig = SyntheticRig();
    rig.jaw_weights[30] = 1.5f;
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("vertex 30"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    std::swap(rig.shapes[3].delta.vertex[0], rig.shapes[3].delta.vertex[1]);
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("ascending"), std::string::npos) << why;
    EXPECT_NE(why.find("mouthSmile"), std::string::npos) << why;
  }
  {
    Rig rig = SyntheticRig();
    rig.shapes[5].name = rig.shapes[0].name;
    std::string why;
    EXPECT_FALSE(rig.Check(&why));
    EXPECT_NE(why.find("repeats"), std::string::npos) << why;
  }
}

// ---- speed on a head-sized rig (printed, not asserted) ----------------------------------------

// ~8k vertices on a 100 x 80 grid (row-major indices, as a parametric head), 52 shapes, 2 jaw
// shapes, 30% jaw-skinned. Local shapes move a disc of the grid (as facial shapes do); random
// shapes move 20% of the vertices picked uniformly (worst case for memory locality).
Rig HeadSizedRig(bool local_shapes, std::mt19937* rng) {
  Rig rig;
  const int columns = 100, rows = 80, num_vertices = columns * rows;
  rig.neutral.resize(num_vertices, 3);
  for (int v = 0; v < num_vertices; ++v) {
    rig.neutral.row(v) << 0.2f * (v % columns), 0.2f * (v / columns), 0.f;
  }
  rig.jaw_weights = Eigen::VectorXf::Zero(num_vertices);
  std::uniform_real_distribution<float> unit(0.f, 1.f), offset(-1.f, 1.f);
  for (int v = 0; v < num_vertices; ++v) {
    if (v / columns < rows * 3 / 10) rig.jaw_weights[v] = unit(*rng);
  }
  for (int s = 0; s < 52; ++s) {
    Shape shape;
    shape.name = "shape" + std::to_string(s);
    if (local_shapes) {
      const int center_x = static_cast<int>(unit(*rng) * columns);
      const int center_y = static_cast<int>(unit(*rng) * rows);
      for (int v = 0; v < num_vertices; ++v) {
        const int dx = v % columns - center_x, dy = v / columns - center_y;
        if (dx * dx + dy * dy > 20 * 20) continue;
        shape.delta.vertex.push_back(v);
        shape.delta.offset.emplace_back(offset(*rng), offset(*rng), offset(*rng));
      }
    } else {
      shape.delta = RandomSparseDelta(num_vertices, 0.2f, 1.f, rng);
    }
    rig.shapes.push_back(shape);
  }
  rig.shapes[10].jaw_euler = Eigen::Vector3f(0.3f, 0.f, 0.f);
  rig.shapes[11].jaw_euler = Eigen::Vector3f(0.f, 0.1f, 0.f);
  return rig;
}

template <typename Fn>
double MicrosecondsPerCall(int repeats, Fn&& fn) {
  fn();
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) fn();
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
             .count() / repeats;
}

TEST(EvaluateShapeTest, TimingOnHeadSizedRig) {
  std::mt19937 rng(2);
  for (bool local_shapes : {true, false}) {
    const Rig rig = HeadSizedRig(local_shapes, &rng);
    size_t entries = 0;
    for (const Shape& shape : rig.shapes) entries += shape.delta.vertex.size();
    const Eigen::VectorXf w = RandomWeights(rig.NumShapes(), &rng);
    RigEvaluator evaluator(rig);
    Vertices out, direct;
    const double evaluator_us = MicrosecondsPerCall(500, [&] { evaluator.EvaluateShape(w, &out); });
    const double direct_us = MicrosecondsPerCall(500, [&] { EvaluateShape(rig, w, &direct); });
    EXPECT_LT((out - direct).cwiseAbs().maxCoeff(), 1e-4f);
    RigEvaluator::Options threaded_options;
    threaded_options.num_threads = 2;
    RigEvaluator threaded(rig, threaded_options);
    Vertices threaded_out;
    const double threaded_us =
        MicrosecondsPerCall(500, [&] { threaded.EvaluateShape(w, &threaded_out); });
    EXPECT_LT((out - threaded_out).cwiseAbs().maxCoeff(), 1e-4f);
    std::vector<int> ids;
    for (int v = 0; v < rig.NumVertices(); v += 2) ids.push_back(v);
    Vertices positions;
    Eigen::MatrixXf jacobian;
    const double jacobian_us = MicrosecondsPerCall(20, [&] {
      evaluator.EvaluatePosedWithJacobian(TestPose(), w, ids, &positions, &jacobian);
    });
    std::printf("EvaluateShape, %d vertices x %d shapes, %s shapes, %.0f%% of vertices per "
                "shape: RigEvaluator %.1f us (2 threads %.1f us), free function %.1f us; "
                "posed Jacobian for %zu vertices %.0f us\n",
                rig.NumVertices(), rig.NumShapes(), local_shapes ? "local" : "random",
                100.0 * entries / rig.NumShapes() / rig.NumVertices(), evaluator_us, threaded_us,
                direct_us, ids.size(), jacobian_us);
  }
}

}  // namespace
}  // namespace facecap::rig
