#include "appearance/texture_metrics.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "util/errors.h"

namespace facecap::appearance {
namespace {

double Cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

// Convex hull, counter-clockwise (Andrew's monotone chain).
std::vector<Eigen::Vector2d> ConvexHull(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k > 0 ? k - 1 : 0);
  return hull;
}

bool InsideConvex(const std::vector<Eigen::Vector2d>& hull, const Eigen::Vector2d& p) {
  for (size_t i = 0; i < hull.size(); ++i) {
    if (Cross(hull[i], hull[(i + 1) % hull.size()], p) < 0) return false;
  }
  return !hull.empty();
}

bool FaceRegionName(const std::string& name) {
  for (const char* excluded : {"hair", "neck", "sclera", "iris", "pupil", "mouth"}) {
    if (name.find(excluded) != std::string::npos) return false;
  }
  return true;
}

}  // namespace

std::vector<uint8_t> FaceRegionMask(const rig::Rig& rig, const render::TexelMap& texels) {
  if (rig.landmarks.size() != 68) {
    throw InvalidInputError("face region: the rig needs the 68 iBUG landmarks");
  }
  std::vector<Eigen::Vector2d> points;
  for (int l = 0; l < 68; ++l) points.push_back(rig.neutral.row(rig.landmarks[l]).head<2>().cast<double>());
  const std::vector<Eigen::Vector2d> hull = ConvexHull(points);
  const float front_z = 0.5f * (rig.neutral(rig.landmarks[0], 2) + rig.neutral(rig.landmarks[16], 2));
  std::vector<bool> face_region(rig.regions.size());
  for (size_t r = 0; r < rig.regions.size(); ++r) face_region[r] = FaceRegionName(rig.regions[r].name);
  std::vector<uint8_t> mask(texels.triangle.size(), 0);
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!texels.Covered(i)) continue;
    const int region = rig.triangle_region[texels.triangle[i]];
    const Eigen::Vector3f& p = texels.position[i];
    mask[i] = face_region[region] && p.z() > front_z &&
              InsideConvex(hull, p.head<2>().cast<double>());
  }
  return mask;
}

TextureComparison CompareTextures(const ImageF& captured, const ImageF& confidence,
                                  const ImageF& truth, const std::vector<uint8_t>& mask) {
  const size_t n = mask.size();
  const auto size_of = [](const ImageF& image) {
    return static_cast<size_t>(image.width) * image.height;
  };
  if (size_of(captured) != n || size_of(confidence) != n || size_of(truth) != n ||
      captured.channels < 3 || truth.channels < 3 || confidence.channels != 1 ||
      captured.width != truth.width) {
    throw InvalidInputError("texture comparison: the captured texture, its confidence, the "
                            "truth and the face mask differ in size");
  }
  TextureComparison out;
  std::vector<size_t> used;
  for (size_t i = 0; i < n; ++i) {
    if (!mask[i]) continue;
    ++out.face_texels;
    if (confidence.data[i] > 0.f) used.push_back(i);
  }
  if (out.face_texels == 0) throw InvalidInputError("texture comparison: the face region is empty");
  out.coverage = static_cast<double>(used.size()) / static_cast<double>(out.face_texels);
  if (used.empty()) return out;
  const auto value = [](const ImageF& image, size_t i, int c) { return double(image.data[i * image.channels + c]); };
  // Least-squares gain per channel, then the mean squared error of both candidates.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i : used) {
    for (int c = 0; c < 3; ++c) mean[c] += value(captured, i, c);
  }
  mean /= static_cast<double>(used.size());
  Eigen::Vector3d cross = Eigen::Vector3d::Zero(), own = Eigen::Vector3d::Zero(),
                  flat_cross = Eigen::Vector3d::Zero();
  for (size_t i : used) {
    for (int c = 0; c < 3; ++c) {
      cross[c] += value(captured, i, c) * value(truth, i, c);
      own[c] += value(captured, i, c) * value(captured, i, c);
      flat_cross[c] += mean[c] * value(truth, i, c);
    }
  }
  Eigen::Vector3d flat_gain;
  for (int c = 0; c < 3; ++c) {
    out.gain[c] = own[c] > 0. ? cross[c] / own[c] : 1.;
    const double flat_own = mean[c] * mean[c] * static_cast<double>(used.size());
    flat_gain[c] = flat_own > 0. ? flat_cross[c] / flat_own : 1.;
  }
  double squared = 0., flat_squared = 0.;
  for (size_t i : used) {
    for (int c = 0; c < 3; ++c) {
      const double t = value(truth, i, c);
      squared += std::pow(out.gain[c] * value(captured, i, c) - t, 2);
      flat_squared += std::pow(flat_gain[c] * mean[c] - t, 2);
    }
  }
  const double count = 3. * static_cast<double>(used.size());
  const auto psnr = [](double mse) { return 10. * std::log10(1. / std::max(mse, 1e-12)); };
  out.psnr_db = psnr(squared / count);
  out.psnr_flat_db = psnr(flat_squared / count);
  return out;
}

}  // namespace facecap::appearance
