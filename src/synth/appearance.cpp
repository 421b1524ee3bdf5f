#include "synth/appearance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include <malloc.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "render/texel_map.h"
#include "synth/noise.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {

namespace {

constexpr float kPi = 3.14159265358979f;

float SrgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}
float LinearToSrgb(float c) {
  c = std::clamp(c, 0.f, 1.f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}
// An sRGB colour given in 8-bit levels, as linear RGB.
Eigen::Vector3f Srgb8(float r, float g, float b) {
  return {SrgbToLinear(r / 255.f), SrgbToLinear(g / 255.f), SrgbToLinear(b / 255.f)};
}
Eigen::Vector3f Lerp(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float t) {
  return a + t * (b - a);
}
float Smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

// Distance from p to segment ab.
float SegmentDistance(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                      const Eigen::Vector3f& b) {
  const Eigen::Vector3f ab = b - a;
  const float t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12f), 0.f, 1.f);
  return (a + t * ab - p).norm();
}
// Distance from p to the polyline through landmarks `indices` of `points`.
float PolylineDistance(const Eigen::Vector3f& p, const std::vector<Eigen::Vector3f>& points) {
  float d = std::numeric_limits<float>::max();
  for (size_t k = 0; k + 1 < points.size(); ++k) d = std::min(d, SegmentDistance(p, points[k], points[k + 1]));
  return d;
}

// What a region is made of, by its name.
enum class Material { kSkin, kNose, kLips, kMouth, kBrow, kEyelid, kSclera, kIris, kPupil, kHair, kNeck };

Material MaterialOfRegion(const std::string& name) {
  auto has = [&](const char* s) { return name.find(s) != std::string::npos; };
  if (has("lip") && !has("eyelid")) return Material::kLips;
  if (has("mouth") || has("teeth") || has("tongue")) return Material::kMouth;
  if (has("brow")) return Material::kBrow;
  if (has("eyelid") || has("lid")) return Material::kEyelid;
  if (has("sclera")) return Material::kSclera;
  if (has("iris")) return Material::kIris;
  if (has("pupil")) return Material::kPupil;
  if (has("hair")) return Material::kHair;
  if (has("neck")) return Material::kNeck;
  if (has("nose")) return Material::kNose;
  return Material::kSkin;
}

// Piecewise-linear pick from a palette of sRGB anchors at t in [0, 1].
Eigen::Vector3f PaletteSrgb(const std::vector<Eigen::Vector3f>& anchors, float t) {
  const float x = std::clamp(t, 0.f, 1.f) * static_cast<float>(anchors.size() - 1);
  const int k = std::min(static_cast<int>(x), static_cast<int>(anchors.size()) - 2);
  const Eigen::Vector3f c = Lerp(anchors[k], anchors[k + 1], x - static_cast<float>(k));
  return Srgb8(c.x(), c.y(), c.z());
}

// A random muted colour (linear RGB) from HSV in sRGB.
Eigen::Vector3f RandomMutedColor(Rng* rng, float v_lo, float v_hi, float s_hi) {
  const float h = static_cast<float>(rng->Uniform()) * 6.f;
  const float s = static_cast<float>(rng->Uniform(0.05, s_hi));
  const float v = static_cast<float>(rng->Uniform(v_lo, v_hi));
  const int i = static_cast<int>(h) % 6;
  const float f = h - std::floor(h);
  const float p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  Eigen::Vector3f rgb;
  switch (i) {
    case 0: rgb = {v, t, p}; break;
    case 1: rgb = {q, v, p}; break;
    case 2: rgb = {p, v, t}; break;
    case 3: rgb = {p, q, v}; break;
    case 4: rgb = {t, p, v}; break;
    default: rgb = {v, p, q}; break;
  }
  return {SrgbToLinear(rgb.x()), SrgbToLinear(rgb.y()), SrgbToLinear(rgb.z())};
}

void GaussianBlurInPlace(ImageF* image, float sigma) {
  if (sigma < 0.05f) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.f * sigma)));
  std::vector<float> kernel(2 * radius + 1);
  float sum = 0.f;
  for (int k = -radius; k <= radius; ++k) {
    kernel[k + radius] = std::exp(-0.5f * k * k / (sigma * sigma));
    sum += kernel[k + radius];
  }
  for (float& k : kernel) k /= sum;
  const int W = image->width, H = image->height, C = image->channels;
  ImageF tmp(W, H, C);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      for (int c = 0; c < C; ++c) {
        float acc = 0.f;
        for (int k = -radius; k <= radius; ++k) {
          acc += kernel[k + radius] * image->at(std::clamp(x + k, 0, W - 1), y, c);
        }
        tmp.at(x, y, c) = acc;
      }
    }
  }
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      for (int c = 0; c < C; ++c) {
        float acc = 0.f;
        for (int k = -radius; k <= radius; ++k) {
          acc += kernel[k + radius] * tmp.at(x, std::clamp(y + k, 0, H - 1), c);
        }
        image->at(x, y, c) = acc;
      }
    }
  }
}

// Bilinear sample with clamp to edge; (x, y) in pixel units with centres at i + 0.5.
void SampleClamped(const ImageF& image, float x, float y, float* rgb) {
  const float fx = std::clamp(x - 0.5f, 0.f, static_cast<float>(image.width - 1));
  const float fy = std::clamp(y - 0.5f, 0.f, static_cast<float>(image.height - 1));
  const int x0 = std::min(static_cast<int>(fx), image.width - 1);
  const int y0 = std::min(static_cast<int>(fy), image.height - 1);
  const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const float tx = fx - x0, ty = fy - y0;
  for (int c = 0; c < 3; ++c) {
    const float a = image.at(x0, y0, c) + tx * (image.at(x1, y0, c) - image.at(x0, y0, c));
    const float b = image.at(x0, y1, c) + tx * (image.at(x1, y1, c) - image.at(x0, y1, c));
    rgb[c] = a + ty * (b - a);
  }
}

void MotionBlurInPlace(ImageF* image, float length, float angle) {
  if (length < 0.5f) return;
  const int taps = std::max(2, static_cast<int>(std::ceil(length * 2.f)) + 1);
  const float dx = std::cos(angle) * length, dy = std::sin(angle) * length;
  ImageF out(image->width, image->height, 3);
  for (int y = 0; y < image->height; ++y) {
    for (int x = 0; x < image->width; ++x) {
      float acc[3] = {0.f, 0.f, 0.f};
      for (int k = 0; k < taps; ++k) {
        const float t = static_cast<float>(k) / (taps - 1) - 0.5f;
        float rgb[3];
        SampleClamped(*image, x + 0.5f + t * dx, y + 0.5f + t * dy, rgb);
        for (int c = 0; c < 3; ++c) acc[c] += rgb[c];
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = acc[c] / taps;
    }
  }
  *image = std::move(out);
}

}  // namespace

PersonColors DrawPersonColors(uint64_t seed) {
  Rng rng(seed, 0x5EED0C0102ull);
  PersonColors p;
  // Skin tones from light to dark (sRGB anchors of photographed skin).
  const std::vector<Eigen::Vector3f> skin_anchors = {
      {242, 204, 180}, {228, 180, 150}, {206, 150, 115}, {172, 118, 86},
      {128, 84, 58},   {88, 58, 42}};
  p.skin = PaletteSrgb(skin_anchors, static_cast<float>(rng.Uniform()));
  // Lips: the skin shifted towards a red-rose, more for light skin.
  const Eigen::Vector3f rose = Srgb8(178, 82, 88);
  p.lips = Lerp(p.skin, rose.cwiseProduct(p.skin.cwiseSqrt()) * 1.4f,
                static_cast<float>(rng.Uniform(0.55, 0.85)));
  const std::vector<Eigen::Vector3f> hairs = {
      {22, 18, 16}, {48, 33, 25}, {92, 62, 40}, {176, 140, 90}, {130, 62, 34}, {150, 146, 142}};
  const float hair_weights[] = {0.3f, 0.28f, 0.2f, 0.1f, 0.05f, 0.07f};
  float pick = static_cast<float>(rng.Uniform()), acc = 0.f;
  int h = 0;
  for (; h < 5; ++h) {
    acc += hair_weights[h];
    if (pick < acc) break;
  }
  p.hair = Srgb8(hairs[h].x(), hairs[h].y(), hairs[h].z()) *
           static_cast<float>(rng.Uniform(0.85, 1.15));
  const std::vector<Eigen::Vector3f> irises = {
      {70, 42, 24}, {110, 82, 45}, {80, 110, 68}, {78, 112, 158}, {118, 124, 130}};
  const int i = static_cast<int>(rng.UniformInt(static_cast<int64_t>(irises.size())));
  p.iris = Srgb8(irises[i].x(), irises[i].y(), irises[i].z());
  p.sclera = Srgb8(205, 195, 185) * static_cast<float>(rng.Uniform(0.85, 1.0));
  return p;
}

bool SkinTextureOptions::Check(std::string* why) const {
  if (texture_size < 16 || texture_size > 8192) {
    *why = "texture_size must be in [16, 8192], got " + std::to_string(texture_size);
    return false;
  }
  if (!(blotch_strength >= 0.f && blotch_strength <= 1.f) ||
      !(pore_strength >= 0.f && pore_strength <= 1.f)) {
    *why = "blotch_strength and pore_strength must be in [0, 1]";
    return false;
  }
  if (!(cheek_redness >= 0.f && cheek_redness <= 1.f)) {
    *why = "cheek_redness must be in [0, 1]";
    return false;
  }
  if (!(lash_darkness >= 0.f && lash_darkness <= 1.f)) {
    *why = "lash_darkness must be in [0, 1]";
    return false;
  }
  if (!(occlusion_strength >= 0.f && occlusion_strength <= 1.f)) {
    *why = "occlusion_strength must be in [0, 1]";
    return false;
  }
  return true;
}

namespace {

// Cavities (eye sockets, nostrils, folds, mouth corners) catch less light: a per-vertex
// concavity (the normal's component of the way to the neighbours' centroid, in units of the
// local edge length), smoothed a few times, darkens the albedo as baked-in occlusion.
std::vector<float> VertexCavity(const rig::Rig& rig) {
  const int V = rig.NumVertices();
  const int F = static_cast<int>(rig.triangles.rows());
  std::vector<std::vector<int>> neighbours(V);
  Eigen::MatrixXf vertex_normals = Eigen::MatrixXf::Zero(V, 3);
  for (int f = 0; f < F; ++f) {
    const Eigen::Vector3f p0 = rig.neutral.row(rig.triangles(f, 0)), p1 = rig.neutral.row(rig.triangles(f, 1)),
                          p2 = rig.neutral.row(rig.triangles(f, 2));
    const Eigen::Vector3f n = (p1 - p0).cross(p2 - p0);
    for (int k = 0; k < 3; ++k) {
      const int v = rig.triangles(f, k);
      vertex_normals.row(v) += n.transpose();
      neighbours[v].push_back(rig.triangles(f, (k + 1) % 3));
      neighbours[v].push_back(rig.triangles(f, (k + 2) % 3));
    }
  }
  std::vector<float> cavity(V, 0.f);
  for (int v = 0; v < V; ++v) {
    auto& nb = neighbours[v];
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    if (nb.empty() || vertex_normals.row(v).norm() == 0.f) continue;
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    float edge = 0.f;
    const Eigen::Vector3f pv = rig.neutral.row(v);
    for (int u : nb) {
      const Eigen::Vector3f pu = rig.neutral.row(u);
      centroid += pu;
      edge += (pu - pv).norm();
    }
    centroid /= static_cast<float>(nb.size());
    edge /= static_cast<float>(nb.size());
    const Eigen::Vector3f n = vertex_normals.row(v).normalized();
    cavity[v] = n.dot(centroid - pv) / std::max(edge, 1e-6f);
  }
  for (int iteration = 0; iteration < 6; ++iteration) {
    std::vector<float> smoothed(V, 0.f);
    for (int v = 0; v < V; ++v) {
      float sum = cavity[v];
      for (int u : neighbours[v]) sum += cavity[u];
      smoothed[v] = sum / static_cast<float>(neighbours[v].size() + 1);
    }
    cavity.swap(smoothed);
  }
  return cavity;
}

// What the texel colours depend on beyond the texel: places on the face from its landmarks
// (cheeks, nose tip, lash lines), each region's material, moles, the noise seed.
struct FaceLayout {
  float eye_span = 0.f;       // outer eye corners' distance
  Eigen::Vector3f cheeks[2];
  Eigen::Vector3f nose_tip;
  float eye_level = 0.f;
  std::vector<Eigen::Vector3f> upper_lash[2], lower_lash[2];
  std::vector<Material> region_material;
  std::vector<std::pair<Eigen::Vector3f, float>> moles;  // centre, radius
  uint32_t noise_seed = 0;
};

FaceLayout LayOutFace(const rig::Rig& rig, uint64_t seed) {
  FaceLayout l;
  std::vector<Eigen::Vector3f> lm(68);
  for (int k = 0; k < 68; ++k) lm[k] = rig.neutral.row(rig.landmarks[k]).transpose();
  l.eye_span = (lm[36] - lm[45]).norm();
  l.cheeks[0] = 0.3f * lm[1] + 0.3f * lm[31] + 0.4f * lm[41];
  l.cheeks[1] = 0.3f * lm[15] + 0.3f * lm[35] + 0.4f * lm[46];
  l.nose_tip = lm[30];
  l.eye_level = 0.25f * (lm[36].y() + lm[39].y() + lm[42].y() + lm[45].y());
  l.upper_lash[0] = {lm[36], lm[37], lm[38], lm[39]};
  l.upper_lash[1] = {lm[42], lm[43], lm[44], lm[45]};
  l.lower_lash[0] = {lm[39], lm[40], lm[41], lm[36]};
  l.lower_lash[1] = {lm[45], lm[46], lm[47], lm[42]};
  l.region_material.resize(rig.regions.size());
  for (size_t r = 0; r < rig.regions.size(); ++r) l.region_material[r] = MaterialOfRegion(rig.regions[r].name);
  // Moles and freckles: a few small dark spots on the face.
  Rng rng(seed, 0x7E27u);
  const int num_moles = static_cast<int>(rng.UniformInt(7));
  for (int m = 0; m < num_moles; ++m) {
    const Eigen::Vector3f a = lm[rng.UniformInt(68)], b = lm[rng.UniformInt(68)];
    const Eigen::Vector3f c = Lerp(a, b, static_cast<float>(rng.Uniform()));
    l.moles.emplace_back(c, static_cast<float>(rng.Uniform(0.05, 0.12)));
  }
  l.noise_seed = static_cast<uint32_t>(seed * 2654435761u + 12345u);
  return l;
}

// Skin at point p: base tone, low-frequency blotches (`blotch`), a hue drift, fine pores,
// redness of the cheeks and nose, moles.
Eigen::Vector3f SkinAt(const Eigen::Vector3f& p, float blotch, const FaceLayout& l,
                       const PersonColors& colors, const SkinTextureOptions& options) {
  const uint32_t s = l.noise_seed;
  const Eigen::Vector3f red_shift(1.0f, 0.72f, 0.74f);  // multiplies the skin where it reddens
  const float hue = Fbm(p, 0.2f, 2, s + 7u);
  const float pores = Fbm(p, 4.f, 2, s + 13u);
  Eigen::Vector3f skin = colors.skin * (1.f + options.blotch_strength * blotch) *
                         (1.f + options.pore_strength * pores);
  skin = skin.cwiseProduct(Eigen::Vector3f(1.f + 0.06f * hue, 1.f, 1.f - 0.08f * hue));
  float redness = 0.f;
  for (const auto& c : l.cheeks) {
    const float d = (p - c).norm() / (0.2f * l.eye_span);
    redness = std::max(redness, std::exp(-0.5f * d * d));
  }
  const float dn = (p - l.nose_tip).norm() / (0.09f * l.eye_span);
  redness = std::max(redness, 0.7f * std::exp(-0.5f * dn * dn));
  redness *= options.cheek_redness * (0.8f + 0.4f * Fbm(p, 1.5f, 2, s + 17u));
  skin = Lerp(skin, skin.cwiseProduct(red_shift), std::clamp(redness, 0.f, 1.f));
  for (const auto& mole : l.moles) {
    if ((p - mole.first).norm() < mole.second) skin *= 0.55f;
  }
  return skin;
}

// The albedo of `material` at point p over `skin`.
Eigen::Vector3f MaterialAlbedo(Material material, const Eigen::Vector3f& p, const Eigen::Vector3f& skin,
                               float blotch, const FaceLayout& l, const PersonColors& colors,
                               const SkinTextureOptions& options) {
  const uint32_t s = l.noise_seed;
  switch (material) {
    case Material::kSkin:
    case Material::kNose:
      return skin;
    case Material::kNeck:
      return skin * 0.88f;
    case Material::kEyelid:
      return skin.cwiseProduct(Eigen::Vector3f(0.93f, 0.84f, 0.84f));
    case Material::kLips: {
      const float lines = ValueNoise(p.x() * 9.f, p.y() * 0.8f, p.z() * 0.8f, s + 23u);
      return colors.lips * (1.f + 0.08f * lines + 0.5f * options.blotch_strength * blotch);
    }
    case Material::kMouth:
      return Srgb8(96, 30, 36);
    case Material::kBrow: {
      // Hairs along the brow (x), dense in the middle.
      const float strands = 0.5f + 0.5f * ValueNoise(p.x() * 2.f, p.y() * 14.f, p.z() * 6.f, s + 29u);
      const float density = std::clamp(0.65f + 0.45f * strands, 0.f, 1.f);
      return Lerp(skin, colors.hair * 0.8f, density);
    }
    case Material::kHair: {
      // Strands run front to back: fine across (x), long along y and z.
      const float strands = ValueNoise(p.x() * 6.f, p.y() * 0.7f, p.z() * 0.7f, s + 31u);
      const float clumps = Fbm(p, 0.8f, 2, s + 37u);
      return colors.hair * (1.f + 0.35f * strands + 0.25f * clumps);
    }
    case Material::kSclera: {
      const float veins = std::max(0.f, Fbm(p, 6.f, 2, s + 41u) - 0.3f);
      Eigen::Vector3f albedo = colors.sclera.cwiseProduct(Eigen::Vector3f(1.f, 1.f - 0.2f * veins, 1.f - 0.2f * veins));
      // Lids and lashes shade the eye white away from its centre.
      albedo *= 0.85f - 0.25f * Smoothstep(0.3f, 1.2f, std::abs(p.y() - l.eye_level) / (0.06f * l.eye_span));
      return albedo;
    }
    case Material::kIris:
      return colors.iris * (1.f + 0.3f * ValueNoise(p.x() * 12.f, p.y() * 12.f, p.z() * 12.f, s + 43u));
    case Material::kPupil:
      return Srgb8(12, 10, 10);
  }
  return skin;
}

// The colour of texel i (covered by triangle f).
Eigen::Vector3f TexelAlbedo(const rig::Rig& rig, const render::TexelMap& bake, const std::vector<float>& cavity,
                            size_t i, const FaceLayout& l, const PersonColors& colors,
                            const SkinTextureOptions& options) {
  const int f = bake.triangle[i];
  const Eigen::Vector3f& p = bake.position[i];
  const int region = rig.triangle_region[f];
  const Material material = region >= 0 && region < static_cast<int>(l.region_material.size())
                                ? l.region_material[region] : Material::kSkin;
  const float blotch = Fbm(p, 0.35f, 3, l.noise_seed);
  const Eigen::Vector3f skin = SkinAt(p, blotch, l, colors, options);
  Eigen::Vector3f albedo = MaterialAlbedo(material, p, skin, blotch, l, colors, options);
  // Lash lines on the eyelid margins (and a little of the skin next to them).
  if (material == Material::kEyelid || material == Material::kSkin) {
    float lash = 0.f;
    for (int e = 0; e < 2; ++e) {
      const float du = PolylineDistance(p, l.upper_lash[e]) / (0.045f * l.eye_span);
      const float dl = PolylineDistance(p, l.lower_lash[e]) / (0.03f * l.eye_span);
      lash = std::max({lash, 1.f - Smoothstep(0.5f, 1.f, du), 0.6f * (1.f - Smoothstep(0.5f, 1.f, dl))});
    }
    albedo = Lerp(albedo, colors.hair * 0.4f, options.lash_darkness * lash);
  }
  if (material != Material::kMouth && material != Material::kPupil && material != Material::kIris &&
      material != Material::kSclera) {
    const Eigen::Vector3f& b = bake.barycentrics[i];
    const float concavity = b[0] * cavity[rig.triangles(f, 0)] + b[1] * cavity[rig.triangles(f, 1)] +
                            b[2] * cavity[rig.triangles(f, 2)];
    albedo *= 1.f - options.occlusion_strength * Smoothstep(0.f, 0.12f, concavity);
  }
  return albedo;
}

// Uncovered texels take their covered neighbours' mean (a few rings), then `fill`.
void FillUncovered(std::vector<uint8_t> covered, const Eigen::Vector3f& fill, ImageF* texture) {
  const int N = texture->width;
  for (int ring = 0; ring < 6; ++ring) {
    std::vector<uint8_t> next = covered;
    for (int y = 0; y < N; ++y) {
      for (int x = 0; x < N; ++x) {
        const size_t i = static_cast<size_t>(y) * N + x;
        if (covered[i]) continue;
        float acc[3] = {0.f, 0.f, 0.f};
        int n = 0;
        const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
        for (int k = 0; k < 4; ++k) {
          if (nx[k] < 0 || ny[k] < 0 || nx[k] >= N || ny[k] >= N) continue;
          const size_t j = static_cast<size_t>(ny[k]) * N + nx[k];
          if (!covered[j]) continue;
          for (int c = 0; c < 3; ++c) acc[c] += texture->at(nx[k], ny[k], c);
          ++n;
        }
        if (n == 0) continue;
        for (int c = 0; c < 3; ++c) texture->at(x, y, c) = acc[c] / n;
        next[i] = 1;
      }
    }
    covered.swap(next);
  }
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      if (covered[static_cast<size_t>(y) * N + x]) continue;
      for (int c = 0; c < 3; ++c) texture->at(x, y, c) = fill[c];
    }
  }
}

}  // namespace

ImageF MakeSkinTexture(const rig::Rig& rig, const PersonColors& colors, uint64_t seed,
                       const SkinTextureOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("skin texture: " + why);
  if (rig.uvs.rows() == 0 || rig.uv_triangles.rows() != rig.triangles.rows()) {
    throw InvalidInputError("skin texture: the rig has no UVs (uvs and uv_triangles)");
  }
  if (rig.landmarks.size() != 68) {
    throw InvalidInputError("skin texture: the rig needs the 68 iBUG landmarks");
  }
  const int N = options.texture_size;
  // 1. Bake each texel's point on the neutral mesh; 2. the occlusion of cavities and the
  // places on the face; 3. the colour of each covered texel; 4. the uncovered texels.
  const render::TexelMap bake = render::BakeTexelMap(rig, N);
  const std::vector<float> cavity = VertexCavity(rig);
  const FaceLayout layout = LayOutFace(rig, seed);
  ImageF texture(N, N, 3);
  std::vector<uint8_t> covered(static_cast<size_t>(N) * N, 0);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      const size_t i = static_cast<size_t>(y) * N + x;
      if (bake.triangle[i] < 0) continue;
      covered[i] = 1;
      const Eigen::Vector3f albedo = TexelAlbedo(rig, bake, cavity, i, layout, colors, options);
      for (int c = 0; c < 3; ++c) texture.at(x, y, c) = std::clamp(albedo[c], 0.f, 1.f);
    }
  }
  FillUncovered(std::move(covered), colors.skin, &texture);
  return texture;
}

ImageF MakeBackground(int width, int height, uint64_t seed, const Image8* photo,
                      BackgroundKind* kind_out) {
  if (width <= 0 || height <= 0) throw InvalidInputError("background: size must be positive");
  Rng rng(seed, 0xBAC6u);
  ImageF image(width, height, 3);
  const float scale = static_cast<float>(std::max(width, height));
  BackgroundKind kind;
  if (photo != nullptr && !photo->empty()) {
    kind = BackgroundKind::kPhoto;
    // A square-ish window of the photo at a random place, scaled to fill.
    const float aspect = static_cast<float>(width) / height;
    const float max_h = std::min(static_cast<float>(photo->height), photo->width / aspect);
    const float h = max_h * static_cast<float>(rng.Uniform(0.5, 1.0));
    const float w = h * aspect;
    const float x0 = static_cast<float>(rng.Uniform()) * (photo->width - w);
    const float y0 = static_cast<float>(rng.Uniform()) * (photo->height - h);
    ImageF linear(photo->width, photo->height, 3);
    float lut[256];
    for (int v = 0; v < 256; ++v) lut[v] = SrgbToLinear(v / 255.f);
    for (int y = 0; y < photo->height; ++y) {
      for (int x = 0; x < photo->width; ++x) {
        for (int c = 0; c < 3; ++c) linear.at(x, y, c) = lut[photo->at(x, y, std::min(c, photo->channels - 1))];
      }
    }
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        SampleClamped(linear, x0 + (x + 0.5f) * w / width, y0 + (y + 0.5f) * h / height,
                      image.pixel(x, y));
      }
    }
    GaussianBlurInPlace(&image, 0.6f * width / w);  // the camera focuses on the face
  } else {
    kind = static_cast<BackgroundKind>(rng.UniformInt(3));
    const Eigen::Vector3f c0 = RandomMutedColor(&rng, 0.15f, 0.85f, 0.45f);
    const Eigen::Vector3f c1 = RandomMutedColor(&rng, 0.1f, 0.9f, 0.5f);
    const float angle = static_cast<float>(rng.Uniform()) * 2.f * kPi;
    const Eigen::Vector2f dir(std::cos(angle), std::sin(angle));
    const Eigen::Vector2f light(static_cast<float>(rng.Uniform(0.1, 0.9)) * width,
                                static_cast<float>(rng.Uniform(0.0, 0.6)) * height);
    const float light_radius = static_cast<float>(rng.Uniform(0.3, 0.8)) * scale;
    const float light_gain = static_cast<float>(rng.Uniform(0.0, 0.8));
    const uint32_t s = static_cast<uint32_t>(rng.NextU64());
    // Stripes: period, orientation, sharpness.
    const float period = static_cast<float>(rng.Uniform(0.04, 0.25)) * scale;
    const float stripe_angle = (rng.Uniform() < 0.6 ? 0.f : 0.5f * kPi) +
                               static_cast<float>(rng.Uniform(-0.15, 0.15));
    const Eigen::Vector2f stripe_dir(std::cos(stripe_angle), std::sin(stripe_angle));
    const float duty = static_cast<float>(rng.Uniform(0.3, 0.7));
    // Blobs: out-of-focus objects and lights.
    struct Blob { Eigen::Vector2f centre; float radius; Eigen::Vector3f color; };
    std::vector<Blob> blobs;
    const int num_blobs = kind == BackgroundKind::kBlobs ? 8 + static_cast<int>(rng.UniformInt(14)) : 0;
    for (int b = 0; b < num_blobs; ++b) {
      Blob blob;
      blob.centre = Eigen::Vector2f(static_cast<float>(rng.Uniform()) * width,
                                    static_cast<float>(rng.Uniform()) * height);
      blob.radius = static_cast<float>(rng.Uniform(0.04, 0.3)) * scale;
      blob.color = RandomMutedColor(&rng, 0.1f, 1.0f, 0.7f);
      blobs.push_back(blob);
    }
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const Eigen::Vector2f q(x + 0.5f, y + 0.5f);
        const Eigen::Vector3f p3(q.x() / scale, q.y() / scale, 0.f);
        Eigen::Vector3f c;
        switch (kind) {
          case BackgroundKind::kGradient: {
            const float t = std::clamp(0.5f + q.dot(dir) / scale * 0.8f - 0.4f * dir.sum(), 0.f, 1.f);
            c = Lerp(c0, c1, t);
            break;
          }
          case BackgroundKind::kBlobs: {
            c = c0 * 0.6f;
            for (const Blob& blob : blobs) {
              const float d = (q - blob.centre).norm() / blob.radius;
              const float alpha = 0.85f * (1.f - Smoothstep(0.6f, 1.2f, d));
              c = Lerp(c, blob.color, alpha);
            }
            break;
          }
          default: {
            const float phase = q.dot(stripe_dir) / period;
            const float frac = phase - std::floor(phase);
            const float edge = 0.08f;
            const float t = Smoothstep(duty - edge, duty + edge, frac) *
                            (1.f - Smoothstep(1.f - edge, 1.f, frac));
            c = Lerp(c0, c1, t);
            break;
          }
        }
        // Soft light fall-off and low-frequency texture (walls are never flat).
        const float l = std::exp(-0.5f * (q - light).squaredNorm() / (light_radius * light_radius));
        c *= (0.75f + light_gain * l) * (1.f + 0.12f * Fbm(p3 * 4.f, 1.f, 3, s));
        for (int ch = 0; ch < 3; ++ch) image.at(x, y, ch) = std::max(0.f, c[ch]);
      }
    }
    GaussianBlurInPlace(&image, 0.004f * scale);
  }
  if (kind_out != nullptr) *kind_out = kind;
  return image;
}

void BackgroundWindow(const ImageF& background, float center_x, float center_y,
                      float window_width, float window_height, int width, int height,
                      ImageF* window) {
  if (window->width != width || window->height != height || window->channels != 3) {
    *window = ImageF(width, height, 3);
  }
  const float x0 = center_x - 0.5f * window_width, y0 = center_y - 0.5f * window_height;
  const float sx = window_width / width, sy = window_height / height;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      SampleClamped(background, x0 + (x + 0.5f) * sx, y0 + (y + 0.5f) * sy, window->pixel(x, y));
    }
  }
}

void DownsampleBox(const ImageF& image, int factor, ImageF* out) {
  if (factor < 1) throw InvalidInputError("DownsampleBox: factor must be >= 1");
  const int W = image.width / factor, H = image.height / factor, C = image.channels;
  if (out->width != W || out->height != H || out->channels != C) *out = ImageF(W, H, C);
  const float norm = 1.f / (factor * factor);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      for (int c = 0; c < C; ++c) {
        float acc = 0.f;
        for (int dy = 0; dy < factor; ++dy) {
          for (int dx = 0; dx < factor; ++dx) acc += image.at(x * factor + dx, y * factor + dy, c);
        }
        out->at(x, y, c) = acc * norm;
      }
    }
  }
}

bool CameraDegradationOptions::Check(std::string* why) const {
  auto range = [&](float lo, float hi, float min, float max, const char* name) {
    if (!(lo >= min && hi <= max && lo <= hi)) {
      *why = std::string(name) + "_min/_max must satisfy " + std::to_string(min) +
             " <= min <= max <= " + std::to_string(max) + ", got [" + std::to_string(lo) +
             ", " + std::to_string(hi) + "]";
      return false;
    }
    return true;
  };
  if (!range(exposure_min, exposure_max, 0.05f, 20.f, "exposure")) return false;
  if (!range(defocus_sigma_min, defocus_sigma_max, 0.f, 20.f, "defocus_sigma")) return false;
  if (!range(noise_sigma_min, noise_sigma_max, 0.f, 100.f, "noise_sigma")) return false;
  if (!(white_balance_jitter >= 0.f && white_balance_jitter < 0.5f)) {
    *why = "white_balance_jitter must be in [0, 0.5)";
    return false;
  }
  if (!(motion_blur_max >= 0.f && motion_blur_max <= 50.f)) {
    *why = "motion_blur_max must be in [0, 50] pixels";
    return false;
  }
  if (!(motion_blur_probability >= 0.f && motion_blur_probability <= 1.f)) {
    *why = "motion_blur_probability must be in [0, 1]";
    return false;
  }
  if (jpeg_quality_max != 0 &&
      !(jpeg_quality_min >= 1 && jpeg_quality_max <= 100 && jpeg_quality_min <= jpeg_quality_max)) {
    *why = "jpeg_quality_min/_max must satisfy 1 <= min <= max <= 100 (or max 0: no JPEG), got [" +
           std::to_string(jpeg_quality_min) + ", " + std::to_string(jpeg_quality_max) + "]";
    return false;
  }
  return true;
}

FrameDegradation DegradeFrame(const ImageF& linear, const Eigen::Vector3f& white_balance,
                              uint64_t seed, int64_t frame,
                              const CameraDegradationOptions& options, Image8* image) {
  Rng rng(seed, static_cast<uint64_t>(frame));
  FrameDegradation d;
  d.exposure = static_cast<float>(rng.Uniform(options.exposure_min, options.exposure_max));
  d.defocus_sigma = static_cast<float>(rng.Uniform(options.defocus_sigma_min, options.defocus_sigma_max));
  const bool motion = rng.Uniform() < options.motion_blur_probability;
  const float motion_length = static_cast<float>(rng.Uniform()) * options.motion_blur_max;
  d.motion_blur_angle = static_cast<float>(rng.Uniform()) * kPi;
  d.motion_blur_length = motion ? motion_length : 0.f;
  d.noise_sigma = static_cast<float>(rng.Uniform(options.noise_sigma_min, options.noise_sigma_max));
  d.jpeg_quality = options.jpeg_quality_max == 0
                       ? 0
                       : options.jpeg_quality_min +
                             static_cast<int>(rng.UniformInt(options.jpeg_quality_max -
                                                             options.jpeg_quality_min + 1));
  ImageF work = linear;
  const Eigen::Vector3f gain = d.exposure * white_balance;
  for (size_t i = 0; i < work.data.size(); i += 3) {
    for (int c = 0; c < 3; ++c) work.data[i + c] *= gain[c];
  }
  GaussianBlurInPlace(&work, d.defocus_sigma);
  MotionBlurInPlace(&work, d.motion_blur_length, d.motion_blur_angle);
  // Encode, then sensor noise in 8-bit levels: read noise plus shot noise that grows with
  // the signal, independent per channel (colour noise of small sensors).
  if (image->width != work.width || image->height != work.height || image->channels != 3) {
    *image = Image8(work.width, work.height, 3);
  }
  for (size_t i = 0; i < work.data.size(); ++i) {
    const float v = 255.f * LinearToSrgb(work.data[i]);
    const float sigma = d.noise_sigma * std::sqrt(0.35f + 0.65f * v / 128.f);
    const float noisy = v + sigma * static_cast<float>(rng.Normal());
    image->data[i] = static_cast<uint8_t>(std::clamp(std::lround(noisy), 0l, 255l));
  }
  if (d.jpeg_quality > 0) {
    cv::Mat rgb(image->height, image->width, CV_8UC3, image->data.data());
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    std::vector<uint8_t> bytes;
    if (!cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, d.jpeg_quality})) {
      throw Error("JPEG encoding failed");
    }
    const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_COLOR);
    if (decoded.rows != image->height || decoded.cols != image->width) {
      throw Error("JPEG decoding failed");
    }
    cv::Mat back(image->height, image->width, CV_8UC3, image->data.data());
    cv::cvtColor(decoded, back, cv::COLOR_BGR2RGB);
  }
  return d;
}

namespace {

// x264 behind OpenCV's ffmpeg writer reads the uninitialised padding of the writer's frame
// buffers (when a plane's width is not a multiple of 64, as for 160-pixel frames), so the same
// frames encode differently after different heap histories. While one of these is alive,
// glibc fills every new allocation with a fixed byte (M_PERTURB), which makes the encoding a
// function of the frames alone; the previous setting (MALLOC_PERTURB_) is restored after.
class FixedAllocationBytes {
 public:
  FixedAllocationBytes() { mallopt(M_PERTURB, 0x5a); }
  ~FixedAllocationBytes() {
    const char* user = std::getenv("MALLOC_PERTURB_");
    mallopt(M_PERTURB, user ? std::atoi(user) : 0);
  }
  FixedAllocationBytes(const FixedAllocationBytes&) = delete;
  FixedAllocationBytes& operator=(const FixedAllocationBytes&) = delete;
};

}  // namespace

std::string WriteVideo(const std::string& path, const std::vector<Image8>& frames, double fps) {
  if (frames.empty()) throw InvalidInputError("video " + path + ": no frames");
  const FixedAllocationBytes fixed_bytes;
  const int W = frames[0].width, H = frames[0].height;
  const std::filesystem::path final_path(path);
  const std::string temporary = (final_path.parent_path() /
                                 (final_path.stem().string() + ".partial" +
                                  final_path.extension().string())).string();
  cv::VideoWriter writer;
  std::string codec;
  for (const char* c : {"avc1", "mp4v"}) {
    if (writer.open(temporary, cv::CAP_FFMPEG, cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]), fps,
                    cv::Size(W, H), true)) {
      codec = c;
      break;
    }
  }
  if (codec.empty()) {
    throw OutputError("video " + path + ": OpenCV's ffmpeg backend opened neither avc1 nor mp4v");
  }
  cv::Mat bgr;
  for (const Image8& f : frames) {
    if (f.width != W || f.height != H || f.channels != 3) {
      throw InvalidInputError("video " + path + ": frames differ in size");
    }
    const cv::Mat rgb(H, W, CV_8UC3, const_cast<uint8_t*>(f.data.data()));
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    writer.write(bgr);
  }
  writer.release();
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) throw OutputError("video " + path + ": cannot rename " + temporary + ": " + ec.message());
  return codec;
}

Image8 UpscaleNearest(const Image8& image, int factor) {
  if (factor <= 1) return image;
  Image8 out(image.width * factor, image.height * factor, image.channels);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      for (int c = 0; c < image.channels; ++c) out.at(x, y, c) = image.at(x / factor, y / factor, c);
    }
  }
  return out;
}

}  // namespace facecap::synth
