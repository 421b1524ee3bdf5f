#include "stages/rig_texture.h"

#include "io/dynamic_texture_file.h"
#include "io/texture_file.h"
#include "render/shading.h"
#include "rig/evaluate.h"
#include "synth/appearance.h"
#include "textures/influence.h"
#include "util/errors.h"

namespace facecap::stages {

Image8 ReadRigTextureSrgb(const std::string& rig_path) {
  const ImageF linear = io::ReadRigTexture(rig_path);
  Image8 srgb;
  if (!linear.empty()) render::LinearToImage8(linear, true, &srgb);
  return srgb;
}

ImageF GenericSkinTexture(const rig::Rig& rig) {
  if (rig.uvs.rows() == 0 || rig.uv_triangles.rows() != rig.triangles.rows() ||
      rig.landmarks.size() != 68) {
    throw InvalidInputError("the generic skin texture needs a rig with UVs and 68 landmarks");
  }
  return synth::MakeSkinTexture(rig, synth::DrawPersonColors(1), 1, synth::SkinTextureOptions());
}

std::unique_ptr<textures::RigStrainTexture> ReadRigDynamicTexture(const std::string& path, const rig::Rig& rig,
                                                                  int* size) {
  if (!io::HasDynamicTexture(path)) return nullptr;
  io::DynamicTextureLibrary library = io::ReadDynamicTextureLibrary(path, rig.NumShapes(), rig.NumVertices());
  *size = library.size;
  return std::make_unique<textures::RigStrainTexture>(
      rig, library.size, io::kSkinMapChannels, std::move(library.neutral),
      textures::CompressStretchMaps{library.compress, library.stretch, library.reference});
}

io::DynamicTextureLibrary MakeDynamicTextureLibrary(const rig::Rig& rig, const rig::Vertices& neutral,
                                                    const std::vector<rig::Vertices>& expressions,
                                                    std::vector<float> neutral_maps,
                                                    const std::vector<std::vector<float>>& expression_maps, int size,
                                                    float sharpness) {
  const int V = rig.NumVertices(), N = rig.NumShapes();
  const size_t n = static_cast<size_t>(size) * size;
  if (expressions.size() != expression_maps.size() || expressions.empty()) {
    throw InvalidInputError("dynamic texture library: one skin map per expression, at least one expression");
  }
  io::DynamicTextureLibrary lib;
  lib.size = size;
  lib.sharpness = sharpness;
  lib.neutral = std::move(neutral_maps);
  // Eq. 10-13 over the expressions.
  const textures::TexelInterpolator texels(rig, size);
  const textures::OneRing ring = textures::BuildOneRing(rig.triangles, V);
  const Eigen::VectorXf en = textures::MeanEdgeLength(ring, neutral);
  std::vector<std::vector<float>> influence;
  std::vector<const float*> influence_ptrs, map_ptrs;
  for (const rig::Vertices& e : expressions) {
    influence.push_back(textures::InfluenceMap(texels, textures::InfluenceValues(en, textures::MeanEdgeLength(ring, e))));
  }
  for (size_t k = 0; k < expressions.size(); ++k) {
    influence_ptrs.push_back(influence[k].data());
    map_ptrs.push_back(expression_maps[k].data());
  }
  const auto cs = textures::FitCompressStretch(influence_ptrs, map_ptrs, lib.neutral, n, io::kSkinMapChannels,
                                               sharpness);
  lib.compress = cs.compress;
  lib.stretch = cs.stretch;
  lib.reference = cs.reference;
  // Eq. 10-11 of each rig shape at weight 1 (jaw rotation included) against the rig's neutral.
  lib.num_shapes = N;
  lib.num_vertices = V;
  const Eigen::VectorXf rig_en = textures::MeanEdgeLength(ring, rig.neutral);
  rig::RigidPose identity;
  identity.translation.setZero();
  rig::Vertices posed;
  for (int i = 0; i < N; ++i) {
    Eigen::VectorXf w = Eigen::VectorXf::Zero(N);
    w[i] = 1.f;
    rig::EvaluatePosed(rig, identity, w, &posed);
    const auto inf = textures::InfluenceValues(rig_en, textures::MeanEdgeLength(ring, posed));
    for (int v = 0; v < V; ++v) {
      lib.influence.push_back(inf.compress[v]);
      lib.influence.push_back(inf.stretch[v]);
    }
  }
  return lib;
}

}  // namespace facecap::stages
