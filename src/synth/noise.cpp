#include "synth/noise.h"

#include <cmath>

namespace facecap::synth {

// Hash of a lattice point to [-1, 1] (a murmur-style finalizer; the same on every platform).
float LatticeValue(int x, int y, int z, uint32_t seed) {
  uint32_t h = seed * 0x27d4eb2du;
  h ^= static_cast<uint32_t>(x) * 0x8da6b343u;
  h ^= static_cast<uint32_t>(y) * 0xd8163841u;
  h ^= static_cast<uint32_t>(z) * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return static_cast<float>(h) * (2.f / 4294967295.f) - 1.f;
}

// Value noise in 3D: smooth interpolation of lattice values, in [-1, 1].
float ValueNoise(float x, float y, float z, uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy), iz = static_cast<int>(fz);
  auto fade = [](float t) { return t * t * (3.f - 2.f * t); };
  const float tx = fade(x - fx), ty = fade(y - fy), tz = fade(z - fz);
  float c[2][2];
  for (int dz = 0; dz < 2; ++dz) {
    for (int dy = 0; dy < 2; ++dy) {
      const float a = LatticeValue(ix, iy + dy, iz + dz, seed);
      const float b = LatticeValue(ix + 1, iy + dy, iz + dz, seed);
      c[dz][dy] = a + tx * (b - a);
    }
  }
  const float y0 = c[0][0] + ty * (c[0][1] - c[0][0]);
  const float y1 = c[1][0] + ty * (c[1][1] - c[1][0]);
  return y0 + tz * (y1 - y0);
}

// Fractal sum of `octaves` value noises, the first at `frequency`, normalized to about
// [-1, 1].
float Fbm(const Eigen::Vector3f& p, float frequency, int octaves, uint32_t seed) {
  float sum = 0.f, amplitude = 1.f, norm = 0.f;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * ValueNoise(p.x() * frequency, p.y() * frequency, p.z() * frequency,
                                  seed + 101u * static_cast<uint32_t>(o));
    norm += amplitude;
    amplitude *= 0.5f;
    frequency *= 2.03f;
  }
  return sum / norm;
}

}  // namespace facecap::synth
