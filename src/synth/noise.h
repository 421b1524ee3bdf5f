// Procedural noise for synthetic textures: a lattice hash, 3D value noise and its fractal sum.
// Pure functions of their arguments, identical on every platform, so textures baked from
// positions on the mesh are continuous across UV seams and reproducible on any rank.
#ifndef FACECAP_SYNTH_NOISE_H_
#define FACECAP_SYNTH_NOISE_H_

#include <cstdint>

#include <Eigen/Core>

namespace facecap::synth {

// Hash of a lattice point to [-1, 1].
float LatticeValue(int x, int y, int z, uint32_t seed);

// Value noise in 3D: smooth interpolation of lattice values, in [-1, 1].
float ValueNoise(float x, float y, float z, uint32_t seed);

// Fractal sum of `octaves` value noises, the first at `frequency`, normalized to about
// [-1, 1].
float Fbm(const Eigen::Vector3f& p, float frequency, int octaves, uint32_t seed);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_NOISE_H_
