#include "curate/features.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include "face/landmarks68.h"
#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::curate {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Depth (towards the camera) of the 13 stable points relative to the inner eye corners, in
// mean-face units (~0.11 m): an average adult nose and eye-corner profile.
//
// Checked against synthetic truth by analysis/calibrate_pose_template.py (datasets/README.md):
// on dlib's landmarks of wild clips (identity seeds 11 and 23, |yaw| < 45) the pitch bias is
// +0.7 degrees, the yaw error 2.9 degrees mean. On the demo rig's own landmark vertices (posed,
// framed and projected as the renders are) yaw is within 1 degree but pitch reads 6 to 7
// degrees low: the rig's frontal landmark layout differs from dlib's mean face (after a
// similarity, nose tip 0.03 face units lower, nose base 0.03 higher, outer eye corners 0.025
// lower and 0.04 wider), which no depth profile removes. A depth-only fit to those vertices
// lowers that offset to 2.2 degrees but moves the wild clips' pitch bias to +3.2 and their
// pitch error from 4.0 to 4.8 degrees, so f_pose, which only ever sees dlib's landmarks, keeps
// this profile.
//                                 27    28    29    30    31    32    33    34    35    36     39   42   45
constexpr double kStableDepth[] = {0.08, 0.12, 0.18, 0.25, 0.07, 0.11, 0.14, 0.11, 0.07, -0.12, 0.0, 0.0, -0.12};

using Points = Eigen::Matrix<double, Eigen::Dynamic, 2>;

// Residual of the best 2D similarity taking `from` onto `to` (both centred), by the complex
// form of Umeyama's solution: s e^{i theta} = <from, to> / <from, from>.
double SimilarityResidual(const Points& from, const Points& to) {
  std::complex<double> cross(0.0, 0.0);
  double from_norm = 0.0;
  for (int i = 0; i < from.rows(); ++i) {
    const std::complex<double> a(from(i, 0), from(i, 1)), b(to(i, 0), to(i, 1));
    cross += std::conj(a) * b;
    from_norm += std::norm(a);
  }
  const double to_norm = to.squaredNorm();
  if (from_norm <= 0.0) return to_norm;
  return std::max(0.0, to_norm - std::norm(cross) / from_norm);
}

Points Centred(const Points& p) { return p.rowwise() - p.colwise().mean(); }

}  // namespace

const Eigen::Matrix<double, 13, 3, Eigen::RowMajor>& PoseTemplate3D() {
  static const Eigen::Matrix<double, 13, 3, Eigen::RowMajor> kTemplate = [] {
    Eigen::Matrix<double, 13, 3, Eigen::RowMajor> t;
    const std::vector<int>& idx = face::ExpressionStableLandmarks();
    for (int i = 0; i < 13; ++i) {
      t(i, 0) = face::MeanFaceShape()(idx[i], 0);
      t(i, 1) = face::MeanFaceShape()(idx[i], 1);
      t(i, 2) = kStableDepth[i];
    }
    t.rowwise() -= t.colwise().mean();
    return t;
  }();
  return kTemplate;
}

Eigen::MatrixX2d ProjectPoseTemplate(double pitch_deg, double yaw_deg) {
  const double p = pitch_deg * kDeg, y = yaw_deg * kDeg;
  // The rotation of rig::RigidPose, R = Ry(yaw) * Rx(pitch) (roll is in-plane and left to the
  // 2D alignment), written in the template's axes (x right, y down, z towards the camera):
  // the rig's y is up, so Rx's off-diagonal signs flip. Pitch > 0 takes z towards +y (the nose
  // moves down in the image), yaw > 0 takes z towards +x (the nose moves right).
  Eigen::Matrix3d ry, rx;
  ry << std::cos(y), 0, std::sin(y), 0, 1, 0, -std::sin(y), 0, std::cos(y);
  rx << 1, 0, 0, 0, std::cos(p), std::sin(p), 0, -std::sin(p), std::cos(p);
  const Eigen::Matrix3d r = ry * rx;
  const Eigen::Matrix<double, 13, 3, Eigen::RowMajor>& t = PoseTemplate3D();
  Eigen::MatrixX2d out(13, 2);
  for (int i = 0; i < 13; ++i) {
    const Eigen::Vector3d q = r * t.row(i).transpose();
    out.row(i) << q.x(), q.y();
  }
  return out;
}

PoseEstimate EstimatePose(const face::Landmarks& landmarks) {
  const std::vector<int>& idx = face::ExpressionStableLandmarks();
  // Step 1: rigid (similarity) alignment of L_r to the frontal template \tilde L_r.
  const Eigen::MatrixX2d l_r = face::SelectRows(landmarks, idx);
  const Eigen::MatrixX2d frontal = PoseTemplate3D().leftCols<2>();
  const face::Similarity2 align = face::FitSimilarity(l_r, frontal);
  Points aligned(13, 2);
  for (int i = 0; i < 13; ++i) aligned.row(i) = align.Apply(l_r.row(i).transpose()).transpose();
  aligned = Centred(aligned);
  const double radius2 = std::max(1e-12, aligned.squaredNorm());

  // Step 2: pitch and yaw of the 3D template whose projection fits the aligned points best.
  auto cost = [&](double pitch, double yaw) {
    return SimilarityResidual(Centred(ProjectPoseTemplate(pitch, yaw)), aligned);
  };
  double best_pitch = 0.0, best_yaw = 0.0, best = cost(0.0, 0.0);
  for (double pitch = -60.0; pitch <= 60.0; pitch += 10.0) {
    for (double yaw = -80.0; yaw <= 80.0; yaw += 10.0) {
      const double c = cost(pitch, yaw);
      if (c < best) { best = c; best_pitch = pitch; best_yaw = yaw; }
    }
  }
  for (double step = 5.0; step >= 0.05; step *= 0.5) {
    bool moved = true;
    while (moved) {
      moved = false;
      for (const auto& [dp, dy] : {std::pair<int, int>{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const double p = std::clamp(best_pitch + dp * step, -89.0, 89.0);
        const double y = std::clamp(best_yaw + dy * step, -89.0, 89.0);
        const double c = cost(p, y);
        if (c < best - 1e-15) { best = c; best_pitch = p; best_yaw = y; moved = true; }
      }
    }
  }
  PoseEstimate e;
  e.pitch_deg = best_pitch;
  e.yaw_deg = best_yaw;
  e.residual = std::sqrt(best / radius2);
  return e;
}

Eigen::VectorXf LightingFeature(const Image8& image, const face::Landmarks& landmarks) {
  if (image.empty() || image.channels != 3) throw InvalidInputError("LightingFeature: needs an RGB image");
  float x0 = 1e30f, y0 = 1e30f, x1 = -1e30f, y1 = -1e30f;
  for (int i = 27; i <= 35; ++i) {
    x0 = std::min(x0, landmarks(i, 0)); x1 = std::max(x1, landmarks(i, 0));
    y0 = std::min(y0, landmarks(i, 1)); y1 = std::max(y1, landmarks(i, 1));
  }
  const float grow_x = 0.15f * (x1 - x0), grow_y = 0.15f * (y1 - y0);
  x0 -= grow_x; x1 += grow_x; y0 -= grow_y; y1 += grow_y;
  auto sample = [&](float x, float y, int c) {  // bilinear, clamped to the image
    x = std::clamp(x, 0.f, image.width - 1.f);
    y = std::clamp(y, 0.f, image.height - 1.f);
    const int xi = std::min(static_cast<int>(x), image.width - 2 < 0 ? 0 : image.width - 2);
    const int yi = std::min(static_cast<int>(y), image.height - 2 < 0 ? 0 : image.height - 2);
    const int xj = std::min(xi + 1, image.width - 1), yj = std::min(yi + 1, image.height - 1);
    const float fx = x - xi, fy = y - yi;
    return (1 - fx) * (1 - fy) * image.at(xi, yi, c) + fx * (1 - fy) * image.at(xj, yi, c) +
           (1 - fx) * fy * image.at(xi, yj, c) + fx * fy * image.at(xj, yj, c);
  };
  constexpr int kSamples = 4;  // per cell side
  Eigen::VectorXf f(kLightingDims);
  const float cw = (x1 - x0) / kLightingCols, ch = (y1 - y0) / kLightingRows;
  for (int r = 0; r < kLightingRows; ++r) {
    for (int col = 0; col < kLightingCols; ++col) {
      for (int c = 0; c < 3; ++c) {
        float sum = 0.f;
        for (int sy = 0; sy < kSamples; ++sy)
          for (int sx = 0; sx < kSamples; ++sx)
            sum += sample(x0 + (col + (sx + 0.5f) / kSamples) * cw, y0 + (r + (sy + 0.5f) / kSamples) * ch, c);
        f[(r * kLightingCols + col) * 3 + c] = sum / (kSamples * kSamples * 255.f);
      }
    }
  }
  return f;
}

const std::vector<std::vector<int>>& ExpressionGroups() {
  static const std::vector<std::vector<int>> kGroups = {
      {17, 18, 19, 20, 21, 36, 37, 38, 39, 40, 41},
      {22, 23, 24, 25, 26, 42, 43, 44, 45, 46, 47},
      {48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64, 65, 66, 67}};
  return kGroups;
}

Eigen::VectorXf ExpressionFeature(const face::Landmarks& landmarks) {
  Eigen::VectorXf f(kExpressionDims);
  int k = 0;
  for (const std::vector<int>& group : ExpressionGroups()) {
    const Eigen::MatrixX2d points = face::SelectRows(landmarks, group);
    const Eigen::MatrixX2d tmpl = face::SelectRows(face::MeanFaceShape(), group);
    const face::Similarity2 t = face::FitSimilarity(points, tmpl);
    for (int i = 0; i < points.rows(); ++i) {
      const Eigen::Vector2d q = t.Apply(points.row(i).transpose()) - tmpl.row(i).transpose();
      f[k++] = static_cast<float>(q.x());
      f[k++] = static_cast<float>(q.y());
    }
  }
  return f;
}

FeatureKind ParseFeatureKind(const std::string& name) {
  if (name == "pose") return FeatureKind::kPose;
  if (name == "lighting") return FeatureKind::kLighting;
  if (name == "expression") return FeatureKind::kExpression;
  throw InvalidInputError("unknown feature '" + name + "'; valid: pose, lighting, expression");
}

const char* FeatureName(FeatureKind kind) {
  switch (kind) {
    case FeatureKind::kPose: return "pose";
    case FeatureKind::kLighting: return "lighting";
    default: return "expression";
  }
}

int FeatureDims(FeatureKind kind) {
  switch (kind) {
    case FeatureKind::kPose: return kPoseDims;
    case FeatureKind::kLighting: return kLightingDims;
    default: return kExpressionDims;
  }
}

const Eigen::MatrixXf& FeatureTable::Of(FeatureKind kind) const {
  switch (kind) {
    case FeatureKind::kPose: return pose;
    case FeatureKind::kLighting: return lighting;
    default: return expression;
  }
}

FeatureTable ComputeFeatures(const std::vector<const Image8*>& crops,
                             const std::vector<face::Landmarks>& landmarks, int threads) {
  if (crops.size() != landmarks.size()) {
    throw InvalidInputError("ComputeFeatures: " + std::to_string(crops.size()) + " crops but " +
                            std::to_string(landmarks.size()) + " landmark sets");
  }
  const int n = static_cast<int>(crops.size());
  FeatureTable t;
  t.pose.resize(n, kPoseDims);
  t.lighting.resize(n, kLightingDims);
  t.expression.resize(n, kExpressionDims);
  ParallelFor(0, n, threads, [&](int i) {
    const PoseEstimate p = EstimatePose(landmarks[i]);
    t.pose(i, 0) = static_cast<float>(p.pitch_deg);
    t.pose(i, 1) = static_cast<float>(p.yaw_deg);
    t.lighting.row(i) = LightingFeature(*crops[i], landmarks[i]).transpose();
    t.expression.row(i) = ExpressionFeature(landmarks[i]).transpose();
  });
  return t;
}

}  // namespace facecap::curate
