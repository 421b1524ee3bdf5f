#include "nn/augment.h"

#include <algorithm>
#include <cmath>
#include <string>
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
  return true;
}

namespace {

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

void AugmentPair(const uint8_t* image, int source_size, int size, const AugmentOptions& o,
                 PairKind kind, Rng* rng, float* input, float* target,
                 const uint8_t* input_image) {
  // The similarity transform, in normalized coordinates centred on the image: output point
  // p (in [-1, 1]^2) samples the source at s R p + t, mirrored in x when flipped.
  const float angle = static_cast<float>(rng->Uniform(-1, 1)) * o.rotate_deg * 3.14159265f / 180.f;
  const float s = 1.f + static_cast<float>(rng->Uniform(-1, 1)) * o.scale;
  const float tx = static_cast<float>(rng->Uniform(-1, 1)) * o.shift * 2.f;
  const float ty = static_cast<float>(rng->Uniform(-1, 1)) * o.shift * 2.f;
  // A mirrored segmentation would paint the left brow, eyelids and so on in the right ones'
  // place, so only camera pairs are mirrored (the draw is made for every pair alike).
  const bool flip = o.flip && rng->Uniform() < 0.5 && kind == PairKind::kCamera;
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
