#include "appearance/texture_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include <Eigen/Cholesky>

#include "render/shading.h"
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

std::vector<Eigen::Vector2f> LandmarkUVs(const rig::Rig& rig, const std::vector<int>& landmarks) {
  if (rig.uvs.rows() == 0 || rig.uv_triangles.rows() != rig.triangles.rows() ||
      rig.landmarks.size() != 68) {
    throw InvalidInputError("LandmarkUVs: the rig needs texture coordinates and 68 landmarks");
  }
  std::vector<Eigen::Vector2f> uvs;
  for (int l : landmarks) {
    if (l < 0 || l >= 68) throw InvalidInputError("LandmarkUVs: landmark " + std::to_string(l));
    const int vertex = rig.landmarks[l];
    int uv = -1;
    for (int f = 0; f < rig.triangles.rows() && uv < 0; ++f) {
      for (int c = 0; c < 3; ++c) {
        if (rig.triangles(f, c) == vertex) {
          uv = rig.uv_triangles(f, c);
          break;
        }
      }
    }
    if (uv < 0) {
      throw InvalidInputError("LandmarkUVs: landmark " + std::to_string(l) + "'s vertex is in no triangle");
    }
    uvs.push_back(rig.uvs.row(uv).transpose());
  }
  return uvs;
}

const std::vector<int>& CornerLandmarks() {
  static const std::vector<int> corners = {36, 39, 42, 45, 48, 54};
  return corners;
}

namespace {

// Luminance of an RGB texture.
std::vector<double> Luminance(const ImageF& image) {
  std::vector<double> out(static_cast<size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      out[static_cast<size_t>(y) * image.width + x] =
          0.2126 * image.at(x, y, 0) + 0.7152 * image.at(x, y, 1) + 0.0722 * image.at(x, y, 2);
    }
  }
  return out;
}

// Normalized cross-correlation of the (2 w + 1)^2 windows centred at a in `p` and at b in `q`
// (images `n` wide); 0 when either window is flat.
double Ncc(const std::vector<double>& p, const std::vector<double>& q, int n, int ax, int ay,
           int bx, int by, int w) {
  double sp = 0., sq = 0., spp = 0., sqq = 0., spq = 0.;
  const double count = (2. * w + 1.) * (2. * w + 1.);
  for (int dy = -w; dy <= w; ++dy) {
    for (int dx = -w; dx <= w; ++dx) {
      const double a = p[static_cast<size_t>(ay + dy) * n + ax + dx];
      const double b = q[static_cast<size_t>(by + dy) * n + bx + dx];
      sp += a;
      sq += b;
      spp += a * a;
      sqq += b * b;
      spq += a * b;
    }
  }
  const double vp = spp - sp * sp / count, vq = sqq - sq * sq / count;
  if (vp <= 1e-12 * count || vq <= 1e-12 * count) return 0.;
  return (spq - sp * sq / count) / std::sqrt(vp * vq);
}

// The offset of a parabola's peak through (-1, a), (0, b), (1, c) from 0, in [-0.5, 0.5].
double ParabolaPeak(double a, double b, double c) {
  const double d = a - 2. * b + c;
  return d < 0. ? std::clamp(0.5 * (a - c) / d, -0.5, 0.5) : 0.;
}

}  // namespace

CornerAlignment MeasureCornerAlignment(const ImageF& captured, const ImageF& truth,
                                       const std::vector<Eigen::Vector2f>& uvs, int window,
                                       int search, double min_correlation) {
  const int n = truth.width;
  if (captured.width != n || captured.height != n || truth.height != n || captured.channels != 3 ||
      truth.channels != 3) {
    throw InvalidInputError("MeasureCornerAlignment: the textures must be square, RGB and of one size");
  }
  if (window < 1 || search < 1 || 2 * (window + search) + 1 > n) {
    throw InvalidInputError("MeasureCornerAlignment: window and search must be at least 1 and fit "
                            "the texture");
  }
  const std::vector<double> p = Luminance(truth), q = Luminance(captured);
  const int reach = window + search;
  CornerAlignment out;
  for (const Eigen::Vector2f& uv : uvs) {
    // The texel whose centre is nearest the point, kept far enough from the edges.
    const int cx = std::clamp(static_cast<int>(std::floor(uv.x() * n)), reach, n - 1 - reach);
    const int cy = std::clamp(static_cast<int>(std::floor((1.f - uv.y()) * n)), reach, n - 1 - reach);
    const int side = 2 * search + 1;
    std::vector<double> score(static_cast<size_t>(side) * side);
    int best = 0;
    for (int sy = -search; sy <= search; ++sy) {
      for (int sx = -search; sx <= search; ++sx) {
        const int i = (sy + search) * side + sx + search;
        score[i] = Ncc(p, q, n, cx, cy, cx + sx, cy + sy, window);
        if (score[i] > score[best]) best = i;
      }
    }
    const int bx = best % side, by = best / side;
    // A best shift on the border of the search is no peak: the detail lies farther, or nowhere.
    const bool on_border = bx == 0 || by == 0 || bx == side - 1 || by == side - 1;
    double shift = search;
    if (score[best] >= min_correlation && !on_border) {
      const auto at = [&](int x, int y) { return score[static_cast<size_t>(y) * side + x]; };
      const double fx = ParabolaPeak(at(bx - 1, by), at(bx, by), at(bx + 1, by));
      const double fy = ParabolaPeak(at(bx, by - 1), at(bx, by), at(bx, by + 1));
      shift = std::min<double>(search, std::hypot(bx - search + fx, by - search + fy));
      ++out.found;
    }
    out.shift_texels.push_back(shift);
    out.correlation.push_back(score[best]);
  }
  double sum = 0.;
  for (double s : out.shift_texels) sum += s;
  out.mean_shift_texels = out.shift_texels.empty() ? 0. : sum / out.shift_texels.size();
  return out;
}

RerenderScore::RerenderScore(std::vector<const ImageF*> textures)
    : textures_(std::move(textures)), error_(textures_.size(), 0.) {
  for (const ImageF* t : textures_) {
    if (t == nullptr || t->empty() || t->channels != 3) {
      throw InvalidInputError("RerenderScore: every texture must be a non-empty RGB image");
    }
  }
}

namespace {

// Per channel, the normal equations of one frame's shading fit f ~ r (a + b . n): the basis
// r (1, n_x, n_y, n_z) of each pixel, against the frame's value f.
struct ShadingFit {
  std::array<Eigen::Matrix4d, 3> normal = {Eigen::Matrix4d::Zero(), Eigen::Matrix4d::Zero(),
                                           Eigen::Matrix4d::Zero()};
  std::array<Eigen::Vector4d, 3> target = {Eigen::Vector4d::Zero(), Eigen::Vector4d::Zero(),
                                           Eigen::Vector4d::Zero()};
  void Add(const Eigen::Vector3d& r, const Eigen::Vector3d& n, const Eigen::Vector3d& f) {
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector4d b = r[c] * Eigen::Vector4d(1., n.x(), n.y(), n.z());
      normal[c] += b * b.transpose();
      target[c] += b * f[c];
    }
  }
  // The part of sum(f^2) the best fit explains: y^T A^-1 y per channel (A regularized a little
  // so that a texture with no variation, or normals all alike, stays solvable).
  double Explained() const {
    double explained = 0.;
    for (int c = 0; c < 3; ++c) {
      const double scale = std::max(normal[c].trace(), 1e-30);
      const Eigen::Matrix4d a = normal[c] + 1e-9 * scale * Eigen::Matrix4d::Identity();
      explained += target[c].dot(a.ldlt().solve(target[c]));
    }
    return explained;
  }
};

}  // namespace

void RerenderScore::AddFrame(const ImageF& image, const ImageF& uv_image, const ImageF& normals,
                             const ImageF& mask) {
  const auto same = [&](const ImageF& x, int channels) {
    return x.width == image.width && x.height == image.height && x.channels >= channels;
  };
  if (image.channels < 3 || !same(uv_image, 3) || !same(normals, 3) || !same(mask, 1)) {
    throw InvalidInputError("RerenderScore: the image, U(I), normals and mask differ in size or "
                            "channels");
  }
  double ff = 0.;
  std::vector<ShadingFit> fits(textures_.size() + 1);  // the last: the flat texture
  int64_t count = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (uv_image.at(x, y, 2) <= 0.5f || mask.at(x, y) <= 0.5f) continue;
      const Eigen::Vector3d f(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
      const Eigen::Vector3d n(normals.at(x, y, 0), normals.at(x, y, 1), normals.at(x, y, 2));
      ff += f.squaredNorm();
      ++count;
      for (size_t t = 0; t < textures_.size(); ++t) {
        const Eigen::Vector3d r =
            render::SampleBilinear(*textures_[t], uv_image.at(x, y, 0), uv_image.at(x, y, 1))
                .cast<double>();
        fits[t].Add(r, n, f);
      }
      fits.back().Add(Eigen::Vector3d::Ones(), n, f);
    }
  }
  if (count == 0) return;
  for (size_t t = 0; t < textures_.size(); ++t) error_[t] += ff - fits[t].Explained();
  flat_error_ += ff - fits.back().Explained();
  ++frames_;
  pixels_ += count;
}

namespace {
double PsnrOf(double squared_error, int64_t pixels) {
  const double mse = std::max(squared_error, 0.) / std::max<int64_t>(3 * pixels, 1);
  return 10. * std::log10(1. / std::max(mse, 1e-12));
}
}  // namespace

double RerenderScore::PsnrDb(size_t t) const { return PsnrOf(error_.at(t), pixels_); }
double RerenderScore::FlatPsnrDb() const { return PsnrOf(flat_error_, pixels_); }

}  // namespace facecap::appearance
