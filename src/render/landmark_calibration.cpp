#include "render/landmark_calibration.h"

#include <cmath>
#include <limits>
#include <string>

#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::render {

LandmarkCalibration CalibrateLandmarks(const rig::Rig& rig,
                                       const std::vector<CalibrationView>& views, float radius) {
  const int V = rig.NumVertices();
  const int L = static_cast<int>(rig.landmarks.size());
  if (L != 68) throw InvalidInputError("landmark calibration: the rig needs 68 landmarks");
  if (views.empty()) throw InvalidInputError("landmark calibration: no view");
  std::vector<double> inv_iod(views.size());
  for (size_t k = 0; k < views.size(); ++k) {
    const CalibrationView& v = views[k];
    if (v.posed.rows() != V || v.detected.rows() != 68) {
      throw InvalidInputError("landmark calibration: view " + std::to_string(k) +
                              " has another vertex or landmark count");
    }
    inv_iod[k] = 1.0 / std::max(1e-6, static_cast<double>((v.detected.row(36) - v.detected.row(45)).norm()));
  }
  // Mean squared normalised distance of vertex `vertex`'s projections to landmark l.
  auto error_of = [&](int vertex, int l) {
    double sum = 0.;
    for (size_t k = 0; k < views.size(); ++k) {
      const CalibrationView& v = views[k];
      const Eigen::Vector2f p = v.camera.Project(v.posed.row(vertex).transpose()).head<2>();
      sum += (p - v.detected.row(l).transpose()).squaredNorm() * inv_iod[k] * inv_iod[k];
    }
    return sum / static_cast<double>(views.size());
  };
  auto mean_distance = [&](int vertex, int l) {
    double sum = 0.;
    for (size_t k = 0; k < views.size(); ++k) {
      const CalibrationView& v = views[k];
      const Eigen::Vector2f p = v.camera.Project(v.posed.row(vertex).transpose()).head<2>();
      sum += (p - v.detected.row(l).transpose()).norm() * inv_iod[k];
    }
    return sum / static_cast<double>(views.size());
  };
  LandmarkCalibration out;
  out.landmarks = rig.landmarks;
  out.error_before.resize(L);
  out.error_after.resize(L);
  const float r2 = radius * radius;
  // Candidates: vertices of the skin surface, not of the eyeballs or the mouth's inside.
  std::vector<uint8_t> surface(V, 0);
  for (int t = 0; t < rig.triangles.rows(); ++t) {
    const std::string& region = rig.regions[rig.triangle_region[t]].name;
    if (region == "sclera" || region == "iris" || region == "pupil" || region == "mouth_interior") continue;
    for (int c = 0; c < 3; ++c) surface[rig.triangles(t, c)] = 1;
  }
  // A landmark stays on the part of the face it moves with: a candidate's jaw skinning weight is
  // within kJawWeightTolerance of the landmark's own vertex's.
  const bool has_jaw = rig.jaw_weights.size() == V;
  ParallelFor(0, L, 0, [&](int l) {
    const Eigen::Vector3f centre = rig.neutral.row(rig.landmarks[l]).transpose();
    int best = rig.landmarks[l];
    double best_error = error_of(best, l);
    const float jaw = has_jaw ? rig.jaw_weights[best] : 0.f;
    for (int vertex = 0; vertex < V; ++vertex) {
      if (!surface[vertex] || (rig.neutral.row(vertex).transpose() - centre).squaredNorm() > r2) continue;
      if (has_jaw && std::abs(rig.jaw_weights[vertex] - jaw) > kJawWeightTolerance) continue;
      const double e = error_of(vertex, l);
      if (e < best_error) {
        best_error = e;
        best = vertex;
      }
    }
    out.landmarks[l] = best;
    out.error_before[l] = mean_distance(rig.landmarks[l], l);
    out.error_after[l] = mean_distance(best, l);
  });
  return out;
}

}  // namespace facecap::render
