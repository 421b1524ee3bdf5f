// Photon gathering (paper 000 Sec. 5.4): colours seen in images become a texture. Every valid
// pixel of an image whose UV-coordinate image U(I) is known is a particle at its (u, v) with
// its colour; each texel gathers its k nearest particles, the radius growing or shrinking to
// hold that fixed count, and averages them with inverse-distance weights. The confidence of a
// texel is inversely proportional to the radius it needed.
//
// Particles carry the UV chart of the triangle they were seen on, and a texel gathers only
// particles of its own chart: colours never bleed across a seam to the unrelated part of the
// face that lies beside it in texture space.
#ifndef FACECAP_APPEARANCE_PHOTON_GATHER_H_
#define FACECAP_APPEARANCE_PHOTON_GATHER_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/texel_map.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::appearance {

struct Particle {
  Eigen::Vector2f uv;     // texture coordinates (OBJ convention, render::SampleBilinear)
  Eigen::Vector3f color;  // linear RGB
  int32_t chart = 0;      // UV chart of the triangle it was seen on (UVCharts)
};

// Per triangle, its UV chart: triangles that share a UV corner index are in one chart.
// Charts are numbered in the order of their lowest triangle.
std::vector<int32_t> UVCharts(const rig::Rig& rig);

struct GatherOptions {
  int neighbours = 16;            // k: particles each texel gathers
  // A texel whose k-th nearest particle of its chart is farther than this (texels) stays
  // empty (confidence 0): a hole, not a colour smeared from afar.
  float max_radius_texels = 12.f;
  // Inverse-distance weights 1 / max(d, min_distance_texels): particles closer than this
  // count alike, so that one particle at a texel centre does not take all the weight.
  float min_distance_texels = 0.5f;

  bool Check(std::string* why) const;
};

// The gathered texture and what it rests on, all N x N (the texel map's size), row-major.
struct GatheredTexture {
  ImageF color;                  // 3 channels, linear RGB; 0 where empty
  // 1 channel: min(1, r_1 / r) with r the texel's gathering radius and r_1 = sqrt(k / pi) the
  // radius that holds k particles at one particle per texel; 0 where empty or not in the UV
  // layout.
  ImageF confidence;
  Image<int32_t> count;          // 1 channel: particles whose nearest texel centre is this one
};

// Gathers `particles` into the texels of `texels` (texels outside the UV layout stay empty).
// The result depends only on the particles and their order, not on threads.
//
// Inputs:
//   particles  the particles (any order; ties between equally distant particles are broken
//              by their order)
//   texels     the texel map of the rig (render::BakeTexelMap) at the texture's size
//   charts     UVCharts of the same rig
//   options    k, radius limit, weights
// Throws InvalidInputError on bad options, a particle with a chart out of range or a
// non-finite value.
GatheredTexture GatherParticles(const std::vector<Particle>& particles,
                                const render::TexelMap& texels,
                                const std::vector<int32_t>& charts, const GatherOptions& options);

// Fills every texel whose confidence is 0 (holes, and texels outside the UV layout) by
// push-pull: the known texels are averaged down a pyramid of halved resolutions (weighted by
// their confidence), and each level's empty texels take the bilinear value of the coarser
// level. Known texels keep their colour; holes get a smooth continuation of their
// surroundings, so that bilinear lookups near chart borders and renders of unseen parts show
// no black. A texture with no known texel is left as it is.
//
// Inputs:
//   confidence  1 channel, the texture's size; > 0 where the colour is known
// Outputs:
//   color       3 channels, filled in place
void FillHoles(const ImageF& confidence, ImageF* color);

// The pixels of U(I) at least `margin` pixels inside the head's silhouette: 1 where every
// pixel within `margin` (a square) is covered, else 0. Pixels at the silhouette see the
// surface at grazing angles and, in a translation, the background bleeding into the face.
//
// Inputs:
//   uv_image  U(I) (render::RenderUVImage: u, v, coverage)
//   margin    pixels; 0 keeps every covered pixel
// Outputs:
//   mask      1 channel, U(I)'s size
void SilhouetteInterior(const ImageF& uv_image, int margin, ImageF* mask);

// The particles of one image: every pixel with U(I) coverage > 0.5 and a visible triangle.
//
// Inputs:
//   image      the image's colours, linear RGB (3 channels)
//   uv_image   U(I) of the same size (render::RenderUVImage: u, v, coverage)
//   triangles  per pixel the visible triangle (-1: none), as render::RenderTriangleIdImage
//   charts     UVCharts of the rig
//   mask       optional per-pixel weight image (1 channel, same size): pixels at or below 0.5
//              are skipped (e.g. outside a deepfake's crop); null: every covered pixel
// Outputs:
//   particles  appended to
void AppendImageParticles(const ImageF& image, const ImageF& uv_image,
                          const Image<int32_t>& triangles, const std::vector<int32_t>& charts,
                          const ImageF* mask, std::vector<Particle>* particles);

}  // namespace facecap::appearance

#endif  // FACECAP_APPEARANCE_PHOTON_GATHER_H_
