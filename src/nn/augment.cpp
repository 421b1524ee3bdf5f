#include "nn/augment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

namespace facecap::nn {

bool AugmentOptions::Check(std::string* why) const {
  if (warp < 0 || warp > 0.3f) { *why = "warp must be in [0, 0.3]"; return false; }
  if (warp_grid < 2 || warp_grid > 32) { *why = "warp_grid must be in [2, 32]"; return false; }
  if (rotate_deg < 0 || rotate_deg > 90) { *why = "rotate_deg must be in [0, 90]"; return false; }
  if (scale < 0 || scale > 0.5f) { *why = "scale must be in [0, 0.5]"; return false; }
  if (shift < 0 || shift > 0.5f) { *why = "shift must be in [0, 0.5]"; return false; }
  if (color_jitter < 0 || color_jitter > 1) { *why = "color_jitter must be in [0, 1]"; return false; }
  if (!(random_background >= 0 && random_background <= 1)) {
    *why = "random_background must be in [0, 1]";
    return false;
  }
  if (!(randomize_a >= 0 && randomize_a <= 1)) { *why = "randomize_a must be in [0, 1]"; return false; }
  if (!(paired_appearance >= 0 && paired_appearance <= 1)) {
    *why = "paired_appearance must be in [0, 1]";
    return false;
  }
  return true;
}

namespace {

// An RGB pixel as 0xRRGGBB (the key of a segmentation palette).
inline uint32_t PackPixel(const uint8_t* rgb) {
  return (uint32_t{rgb[0]} << 16) | (uint32_t{rgb[1]} << 8) | rgb[2];
}

// Bilinear sample of channel-interleaved uint8 RGB at pixel coordinates (x, y), edges clamped.
inline void Sample(const uint8_t* image, int n, float x, float y, float* rgb) {
  x = std::clamp(x, 0.f, static_cast<float>(n - 1));
  y = std::clamp(y, 0.f, static_cast<float>(n - 1));
  const int x0 = std::min(static_cast<int>(x), n - 2 < 0 ? 0 : n - 2);
  const int y0 = std::min(static_cast<int>(y), n - 2 < 0 ? 0 : n - 2);
  const int x1 = std::min(x0 + 1, n - 1), y1 = std::min(y0 + 1, n - 1);
  const float fx = x - x0, fy = y - y0;
  const uint8_t* p00 = image + (static_cast<size_t>(y0) * n + x0) * 3;
  const uint8_t* p01 = image + (static_cast<size_t>(y0) * n + x1) * 3;
  const uint8_t* p10 = image + (static_cast<size_t>(y1) * n + x0) * 3;
  const uint8_t* p11 = image + (static_cast<size_t>(y1) * n + x1) * 3;
  for (int c = 0; c < 3; ++c) {
    const float top = p00[c] + fx * (p01[c] - p00[c]);
    const float bottom = p10[c] + fx * (p11[c] - p10[c]);
    rgb[c] = (top + fy * (bottom - top)) * (1.f / 255.f);
  }
}

// Nearest sample (the pixel whose centre is nearest (x, y), edges clamped): a segmentation's
// labels must not blend, since a blend of two region colours is often nearer a third region's
// colour than either (skin and background make hair or a lower eyelid, neck and background
// the mouth interior), and a target blended so teaches thin false regions along every border.
inline void SampleNearest(const uint8_t* image, int n, float x, float y, float* rgb) {
  const int xi = std::clamp(static_cast<int>(std::floor(x + 0.5f)), 0, n - 1);
  const int yi = std::clamp(static_cast<int>(std::floor(y + 0.5f)), 0, n - 1);
  const uint8_t* p = image + (static_cast<size_t>(yi) * n + xi) * 3;
  for (int c = 0; c < 3; ++c) rgb[c] = p[c] * (1.f / 255.f);
}

// Bilinear interpolation of a grid x grid field at normalized (u, v) in [0, 1].
inline float Field(const std::vector<float>& field, int grid, float u, float v) {
  const float gx = u * (grid - 1), gy = v * (grid - 1);
  const int x0 = std::min(static_cast<int>(gx), grid - 2), y0 = std::min(static_cast<int>(gy), grid - 2);
  const float fx = gx - x0, fy = gy - y0;
  const float a = field[y0 * grid + x0], b = field[y0 * grid + x0 + 1];
  const float c = field[(y0 + 1) * grid + x0], d = field[(y0 + 1) * grid + x0 + 1];
  return (a + fx * (b - a)) + fy * ((c + fx * (d - c)) - (a + fx * (b - a)));
}

}  // namespace

void ResizeToFloat(const uint8_t* image, int source_size, int size, float* out) {
  const float ratio = static_cast<float>(source_size) / size;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      Sample(image, source_size, (x + 0.5f) * ratio - 0.5f, (y + 0.5f) * ratio - 0.5f,
             out + (static_cast<size_t>(y) * size + x) * 3);
    }
  }
}

std::vector<int> MirrorRegions(const std::vector<std::string>& names) {
  std::vector<int> mirror(names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    mirror[i] = static_cast<int>(i);
    for (const auto& [from, to] : {std::pair<std::string, std::string>{"left_", "right_"}, {"right_", "left_"}}) {
      if (names[i].rfind(from, 0) != 0) continue;
      const auto it = std::find(names.begin(), names.end(), to + names[i].substr(from.size()));
      if (it != names.end()) mirror[i] = static_cast<int>(it - names.begin());
    }
  }
  return mirror;
}

SideSwap SideSwapOf(const std::vector<std::string>& names, const std::vector<uint32_t>& colors) {
  SideSwap sides;
  const std::vector<int> mirror = MirrorRegions(names);
  for (size_t i = 0; i < names.size() && i < colors.size(); ++i) {
    const size_t j = static_cast<size_t>(mirror[i]);
    if (names[i].rfind("left_", 0) == 0 && j != i && j < colors.size()) {
      sides.pairs.emplace_back(colors[i], colors[j]);
    }
  }
  return sides;
}

void SwapSides(const uint8_t* image, int size, const SideSwap& sides, uint8_t* out) {
  const size_t pixels = static_cast<size_t>(size) * size;
  for (size_t p = 0; p < pixels; ++p) {
    const uint32_t packed = PackPixel(image + 3 * p);
    uint32_t to = packed;
    for (const auto& [l, r] : sides.pairs) {
      if (packed == l) to = r;
      if (packed == r) to = l;
    }
    out[3 * p] = static_cast<uint8_t>(to >> 16);
    out[3 * p + 1] = static_cast<uint8_t>(to >> 8);
    out[3 * p + 2] = static_cast<uint8_t>(to);
  }
}

void AugmentPair(const uint8_t* image, int source_size, int size, const AugmentOptions& o,
                 PairKind kind, Rng* rng, float* input, float* target,
                 const uint8_t* input_image, const SideSwap* sides) {
  // The similarity transform, in normalized coordinates centred on the image: output point
  // p (in [-1, 1]^2) samples the source at s R p + t, mirrored in x when flipped.
  const float angle = static_cast<float>(rng->Uniform(-1, 1)) * o.rotate_deg * 3.14159265f / 180.f;
  const float s = 1.f + static_cast<float>(rng->Uniform(-1, 1)) * o.scale;
  const float tx = static_cast<float>(rng->Uniform(-1, 1)) * o.shift * 2.f;
  const float ty = static_cast<float>(rng->Uniform(-1, 1)) * o.shift * 2.f;
  // A mirrored segmentation paints the left brow, eyelids and so on in the right ones' place,
  // so segmentation pairs are mirrored only with their sides' colours swapped.
  const bool mirrorable = kind == PairKind::kCamera ||
                          (o.flip_segmentation && sides != nullptr && !sides->empty());
  const bool flip = o.flip && rng->Uniform() < 0.5 && mirrorable;
  std::vector<uint8_t> swapped;
  if (flip && kind != PairKind::kCamera) {
    swapped.resize(3 * static_cast<size_t>(source_size) * source_size);
    SwapSides(image, source_size, *sides, swapped.data());
    if (!input_image) input_image = swapped.data();
    image = swapped.data();
  }
  if (!input_image) input_image = image;
  const float ca = std::cos(angle) * s, sa = std::sin(angle) * s;
  // The warp field: grid x grid random offsets (normalized units), zero on the border.
  const int grid = o.warp_grid;
  std::vector<float> warp_x(grid * grid, 0.f), warp_y(grid * grid, 0.f);
  for (int j = 0; j < grid; ++j) {
    for (int i = 0; i < grid; ++i) {
      const float dx = static_cast<float>(rng->Uniform(-1, 1)) * o.warp * 2.f;
      const float dy = static_cast<float>(rng->Uniform(-1, 1)) * o.warp * 2.f;
      if (i == 0 || j == 0 || i == grid - 1 || j == grid - 1) continue;
      warp_x[j * grid + i] = dx;
      warp_y[j * grid + i] = dy;
    }
  }
  // Colour jitter: v' = ((v - 0.5) * contrast + 0.5 + brightness) * gain_c.
  float brightness = 0.f, contrast = 1.f, gain[3] = {1.f, 1.f, 1.f};
  const bool jitter_input = kind != PairKind::kSegmentation;
  const bool jitter_target = kind == PairKind::kCamera;
  const bool warp_target = kind == PairKind::kPairedCamera;
  if (jitter_input && o.color_jitter > 0) {
    brightness = static_cast<float>(rng->Uniform(-1, 1)) * o.color_jitter * 0.5f;
    contrast = 1.f + static_cast<float>(rng->Uniform(-1, 1)) * o.color_jitter;
    for (float& g : gain) g = 1.f + static_cast<float>(rng->Uniform(-1, 1)) * o.color_jitter * 0.5f;
  }
  const float half = 0.5f * source_size;
  auto to_source = [&](float nx, float ny, float* sx, float* sy) {
    if (flip) nx = -nx;
    const float px = ca * nx - sa * ny + tx, py = sa * nx + ca * ny + ty;
    *sx = (px + 1.f) * half - 0.5f;
    *sy = (py + 1.f) * half - 0.5f;
  };
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float u = (x + 0.5f) / size, v = (y + 0.5f) / size;
      const float nx = 2.f * u - 1.f, ny = 2.f * v - 1.f;
      const size_t k = (static_cast<size_t>(y) * size + x) * 3;
      const float wx = nx + Field(warp_x, grid, u, v), wy = ny + Field(warp_y, grid, u, v);
      float sx, sy;
      to_source(warp_target ? wx : nx, warp_target ? wy : ny, &sx, &sy);
      if (kind == PairKind::kCamera) {
        Sample(image, source_size, sx, sy, target + k);
      } else {
        SampleNearest(image, source_size, sx, sy, target + k);  // a segmentation
      }
      to_source(wx, wy, &sx, &sy);
      Sample(input_image, source_size, sx, sy, input + k);
      for (int c = 0; c < 3; ++c) {
        auto jitter = [&](float* out) {
          *out = std::clamp(((*out - 0.5f) * contrast + 0.5f + brightness) * gain[c], 0.f, 1.f);
        };
        if (jitter_input) jitter(input + k + c);
        if (jitter_target) jitter(target + k + c);
      }
    }
  }
}

void AugmentAppearance(float* image, int size, Rng* rng) {
  auto uniform = [&](double lo, double hi) { return static_cast<float>(rng->Uniform(lo, hi)); };
  const float sigma = rng->Uniform() < 0.5 ? uniform(0.0, 1.5) : 0.f;
  const float ramp_x = uniform(-0.35, 0.35), ramp_y = uniform(-0.35, 0.35);
  const float gamma = std::exp(uniform(std::log(0.7), std::log(1.45)));
  const float gain[3] = {uniform(0.8, 1.2), uniform(0.8, 1.2), uniform(0.8, 1.2)};
  const size_t n = static_cast<size_t>(size) * size;
  if (sigma > 0.2f) {
    // Separable Gaussian, edges clamped: rows into `tmp`, then columns back into the image.
    const int radius = static_cast<int>(std::ceil(3.f * sigma));
    std::vector<float> kernel(2 * radius + 1);
    float sum = 0.f;
    for (int i = -radius; i <= radius; ++i) sum += kernel[i + radius] = std::exp(-0.5f * i * i / (sigma * sigma));
    for (float& k : kernel) k /= sum;
    std::vector<float> tmp(3 * n);
    for (int pass = 0; pass < 2; ++pass) {
      const float* from = pass == 0 ? image : tmp.data();
      float* to = pass == 0 ? tmp.data() : image;
      for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
          float acc[3] = {0.f, 0.f, 0.f};
          for (int i = -radius; i <= radius; ++i) {
            const int sx = pass == 0 ? std::clamp(x + i, 0, size - 1) : x;
            const int sy = pass == 1 ? std::clamp(y + i, 0, size - 1) : y;
            const float* p = from + (static_cast<size_t>(sy) * size + sx) * 3;
            for (int c = 0; c < 3; ++c) acc[c] += kernel[i + radius] * p[c];
          }
          std::copy(acc, acc + 3, to + (static_cast<size_t>(y) * size + x) * 3);
        }
      }
    }
  }
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float light = 1.f + ramp_x * (2.f * (x + 0.5f) / size - 1.f) + ramp_y * (2.f * (y + 0.5f) / size - 1.f);
      float* p = image + (static_cast<size_t>(y) * size + x) * 3;
      for (int c = 0; c < 3; ++c) p[c] = std::clamp(std::pow(p[c], gamma) * light * gain[c], 0.f, 1.f);
    }
  }
}

RegionKind RegionKindOf(const std::string& n) {
  auto has = [&](const char* part) { return n.find(part) != std::string::npos; };
  if (has("lip")) return RegionKind::kLips;
  if (has("brow")) return RegionKind::kBrow;
  if (has("hair")) return RegionKind::kHair;
  if (has("sclera")) return RegionKind::kSclera;
  if (has("iris")) return RegionKind::kIris;
  if (has("pupil")) return RegionKind::kPupil;
  if (has("mouth")) return RegionKind::kMouth;
  return RegionKind::kSkin;  // skin, nose, neck, eyelids, cheeks, ...
}

namespace {

using Rgb = std::array<float, 3>;

Rgb Mix(const Rgb& a, const Rgb& b, float t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

Rgb Scaled(const Rgb& c, float r, float g, float b) { return {c[0] * r, c[1] * g, c[2] * b}; }

Rgb Unpack(uint32_t c) {
  return {((c >> 16) & 255) / 255.f, ((c >> 8) & 255) / 255.f, (c & 255) / 255.f};
}

}  // namespace

void RepaintSegmentation(const uint8_t* image, int size, const SegmentationPalette& palette,
                         Rng* rng, uint8_t* out) {
  auto uniform = [&](double lo, double hi) { return static_cast<float>(rng->Uniform(lo, hi)); };
  // The person: a skin tone between dark and light, hair and brows, eyes.
  const Rgb skin = Mix({0.33f, 0.21f, 0.15f}, {0.96f, 0.80f, 0.70f}, uniform(0, 1));
  const Rgb hair = Mix({0.04f, 0.03f, 0.02f}, {0.55f, 0.40f, 0.25f}, uniform(0, 1));
  const Rgb iris = Mix({0.20f, 0.12f, 0.06f}, {0.30f, 0.45f, 0.60f}, uniform(0, 1));
  std::vector<Rgb> albedo(palette.colors.size());
  for (size_t r = 0; r < albedo.size(); ++r) {
    Rgb c;
    switch (palette.kinds[r]) {
      case RegionKind::kSkin:
        c = Scaled(skin, uniform(0.9, 1.08), uniform(0.9, 1.06), uniform(0.9, 1.06));
        break;
      case RegionKind::kLips:
        c = Scaled(skin, uniform(0.8, 0.95), uniform(0.45, 0.6), uniform(0.5, 0.65));
        break;
      case RegionKind::kBrow: c = Mix(hair, skin, uniform(0.0, 0.5)); break;
      case RegionKind::kHair: c = hair; break;
      case RegionKind::kSclera: c = Mix({0.70f, 0.66f, 0.62f}, {0.95f, 0.93f, 0.90f}, uniform(0, 1)); break;
      case RegionKind::kIris: c = iris; break;
      case RegionKind::kPupil: c = {0.03f, 0.03f, 0.03f}; break;
      case RegionKind::kMouth: c = Scaled(skin, uniform(0.25, 0.45), uniform(0.1, 0.2), uniform(0.1, 0.2)); break;
    }
    albedo[r] = c;
  }
  // Background: a colour or a vertical or horizontal gradient between two colours.
  const Rgb back0 = {uniform(0, 1), uniform(0, 1), uniform(0, 1)};
  const Rgb back1 = rng->Uniform() < 0.5 ? back0 : Rgb{uniform(0, 1), uniform(0, 1), uniform(0, 1)};
  const bool vertical = rng->Uniform() < 0.5;
  // Shading: ambient plus a directional ramp and one soft blob of light or shadow.
  const float ambient = uniform(0.55, 0.85), ramp_x = uniform(-0.35, 0.35), ramp_y = uniform(-0.25, 0.25);
  const float blob_x = uniform(0.2, 0.8), blob_y = uniform(0.2, 0.8), blob_r = uniform(0.15, 0.45);
  const float blob_gain = uniform(-0.25, 0.35);
  const float noise = uniform(0.0, 0.04);
  // Palette lookup by packed colour; colours not in the palette (resampled borders) take
  // the nearest entry.
  std::unordered_map<uint32_t, int> index;
  for (size_t r = 0; r < palette.colors.size(); ++r) index[palette.colors[r]] = static_cast<int>(r);
  index[palette.background] = -1;
  auto region_of = [&](uint32_t c) {
    auto it = index.find(c);
    if (it != index.end()) return it->second;
    const Rgb v = Unpack(c);
    float best = 1e9f;
    int best_r = -1;
    auto consider = [&](uint32_t q, int r) {
      const Rgb u = Unpack(q);
      const float d = (u[0] - v[0]) * (u[0] - v[0]) + (u[1] - v[1]) * (u[1] - v[1]) +
                      (u[2] - v[2]) * (u[2] - v[2]);
      if (d < best) {
        best = d;
        best_r = r;
      }
    };
    consider(palette.background, -1);
    for (size_t r = 0; r < palette.colors.size(); ++r) consider(palette.colors[r], static_cast<int>(r));
    index[c] = best_r;
    return best_r;
  };
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const size_t k = (static_cast<size_t>(y) * size + x) * 3;
      const uint32_t packed = PackPixel(image + k);
      const int r = region_of(packed);
      const float u = (x + 0.5f) / size, v = (y + 0.5f) / size;
      Rgb c;
      if (r < 0) {
        c = Mix(back0, back1, vertical ? v : u);
      } else {
        const float dx = u - blob_x, dy = v - blob_y;
        const float shade = ambient + ramp_x * (u - 0.5f) + ramp_y * (v - 0.5f) +
                            blob_gain * std::exp(-(dx * dx + dy * dy) / (blob_r * blob_r));
        c = Scaled(albedo[r], shade, shade, shade);
      }
      for (int ch = 0; ch < 3; ++ch) {
        const float value = c[ch] + noise * static_cast<float>(rng->Normal());
        out[k + ch] = static_cast<uint8_t>(std::clamp(std::lround(255.f * value), 0L, 255L));
      }
    }
  }
}

std::vector<uint8_t> BorderBackgroundMask(const uint8_t* segmentation, int size) {
  const int n = size * size;
  std::vector<uint8_t> mask(n, 0);
  auto black = [&](int i) {
    const uint8_t* p = segmentation + 3 * i;
    return p[0] <= 8 && p[1] <= 8 && p[2] <= 8;
  };
  std::vector<int> stack;
  auto seed = [&](int i) {
    if (!mask[i] && black(i)) {
      mask[i] = 1;
      stack.push_back(i);
    }
  };
  for (int t = 0; t < size; ++t) {
    seed(t);
    seed((size - 1) * size + t);
    seed(t * size);
    seed(t * size + size - 1);
  }
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    const int x = i % size, y = i / size;
    if (x > 0) seed(i - 1);
    if (x + 1 < size) seed(i + 1);
    if (y > 0) seed(i - size);
    if (y + 1 < size) seed(i + size);
  }
  return mask;
}

void ReplaceBackground(const uint8_t* image, const uint8_t* background,
                       const std::vector<uint8_t>& mask, int size, uint8_t* out) {
  for (int i = 0; i < size * size; ++i) {
    const uint8_t* from = mask[i] ? background + 3 * i : image + 3 * i;
    out[3 * i] = from[0];
    out[3 * i + 1] = from[1];
    out[3 * i + 2] = from[2];
  }
}

}  // namespace facecap::nn
