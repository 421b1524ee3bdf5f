// Runtime dynamic textures (paper 001 Sec. 5.3) at 1024 x 1024 on one core: a frame's albedo,
// specular and displacement from the library of the demo head (compress and stretch maps from
// the 24 FACS expressions' skin maps), in ms. The strain texture facecap uses
// (textures/compress_stretch.h: the frame's mesh from the 55 template shapes, its eq. 10-11
// influence map, the blend) beside, on the same weights: eq. 14 as printed with sparse and with
// dense normalized influence maps of the shapes, and the per-blendshape maps blended linearly
// (T_N + sum_i alpha_i (T_i - T_N), only the active shapes read).
//
//   facecap_bench_dynamic_texture [--size N] [--frames F] [--active A]
//
// Each frame activates A random shapes (all when A is 0) at weights in (0, 1].
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "assets/template_shapes.h"
#include "rig/demo_head.h"
#include "synth/skin_dynamics.h"
#include "textures/compress_stretch.h"
#include "textures/influence.h"
#include "util/random.h"

namespace facecap {
namespace {

double Ms(std::chrono::steady_clock::time_point since) {
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

int Run(int size, int frames, int active) {
  const rig::Rig head = rig::MakeDemoHead();
  const assets::LinearShapes shapes = assets::MakeTemplateShapes(head);
  const int N = shapes.NumShapes(), V = shapes.NumVertices();
  const auto table = assets::ParseFacsTable(assets::DefaultFacsTable());
  const Eigen::MatrixXf alpha = assets::FacsWeights(table, shapes.names, true);
  auto t0 = std::chrono::steady_clock::now();
  const textures::TexelInterpolator texels(head, size);
  const textures::OneRing ring = textures::BuildOneRing(head.triangles, V);
  const Eigen::VectorXf en = textures::MeanEdgeLength(ring, head.neutral);
  const synth::SkinDynamics skin = synth::DrawSkinDynamics(7);
  const std::vector<float> neutral = synth::NeutralSkinMaps(head, texels, synth::DrawPersonColors(7), skin, 8);
  auto mesh = [&](const Eigen::VectorXf& column) {
    return rig::Vertices(Eigen::Map<const rig::Vertices>(column.data(), V, 3));
  };
  auto influence = [&](const rig::Vertices& m) {
    return textures::InfluenceMap(texels, textures::InfluenceValues(en, textures::MeanEdgeLength(ring, m)));
  };
  auto skin_maps = [&](const rig::Vertices& m) {
    std::vector<float> c, s;
    synth::RelativeStrain(ring, texels, en, m, &c, &s);
    return synth::ExpressionSkinMaps(neutral, texels, skin, c, s);
  };
  const Eigen::VectorXf base = Eigen::Map<const Eigen::VectorXf>(shapes.neutral.data(), 3 * V);
  std::vector<std::vector<float>> expression_influence, expression_maps, shape_influence, shape_deltas;
  for (int k = 0; k < alpha.rows(); ++k) {
    const rig::Vertices m = mesh(base + shapes.deltas * alpha.row(k).transpose());
    expression_influence.push_back(influence(m));
    expression_maps.push_back(skin_maps(m));
  }
  for (int i = 0; i < N; ++i) {
    const rig::Vertices m = mesh(base + shapes.deltas.col(i));
    shape_influence.push_back(influence(m));
    std::vector<float> d = skin_maps(m);
    for (size_t t = 0; t < d.size(); ++t) d[t] -= neutral[t];
    shape_deltas.push_back(std::move(d));
  }
  auto pointers = [](const std::vector<std::vector<float>>& v) {
    std::vector<const float*> p;
    for (const auto& x : v) p.push_back(x.data());
    return p;
  };
  const float b = 100.f;
  const size_t n = static_cast<size_t>(size) * size;
  const int C = synth::kSkinChannels;
  const auto maps = textures::ExtractCompressStretch(pointers(expression_influence), pointers(expression_maps), n, C, b);
  const textures::DynamicTexture dyn(n, C, neutral, maps, pointers(shape_influence), b);
  const textures::StrainTexture strain(
      n, C, neutral, textures::FitCompressStretch(pointers(expression_influence), pointers(expression_maps), neutral,
                                                  n, C, b));
  const auto dense_c = textures::NormalizeInfluence(pointers(shape_influence), n, 2, 0, b);
  const auto dense_s = textures::NormalizeInfluence(pointers(shape_influence), n, 2, 1, b);
  std::printf("library of %d x %d texels, %d shapes, %d vertices built in %.1f s; %zu sparse influence "
              "entries (%.1f%% of dense)\n", size, size, N, V, Ms(t0) / 1e3, dyn.NumSparseEntries(),
              100.0 * dyn.NumSparseEntries() / (2.0 * N * n));

  Rng rng(11, 3);
  std::vector<std::vector<float>> weights(frames, std::vector<float>(N, 0.f));
  for (auto& w : weights) {
    if (active <= 0) {
      for (float& x : w) x = static_cast<float>(rng.Uniform(0.01, 1.0));
    } else {
      for (int a = 0; a < active; ++a) w[rng.UniformInt(N)] = static_cast<float>(rng.Uniform(0.01, 1.0));
    }
  }
  std::vector<float> out(n * C), check(n * C);
  double strain_ms = 0, sparse_ms = 0, dense_ms = 0, linear_ms = 0, worst = 0;
  std::vector<float> wc(n), ws(n);
  for (const auto& w : weights) {
    auto t = std::chrono::steady_clock::now();
    const Eigen::VectorXf column = base + shapes.deltas * Eigen::Map<const Eigen::VectorXf>(w.data(), N);
    strain.Evaluate(influence(mesh(column)).data(), out.data());
    strain_ms += Ms(t);
    t = std::chrono::steady_clock::now();
    dyn.Evaluate(w.data(), out.data());
    sparse_ms += Ms(t);
    t = std::chrono::steady_clock::now();
    std::fill(wc.begin(), wc.end(), 0.f);
    std::fill(ws.begin(), ws.end(), 0.f);
    for (int i = 0; i < N; ++i) {
      if (w[i] == 0.f) continue;
      for (size_t p = 0; p < n; ++p) {
        wc[p] += w[i] * dense_c[i][p];
        ws[p] += w[i] * dense_s[i][p];
      }
    }
    for (size_t p = 0; p < n; ++p) {
      for (int c = 0; c < C; ++c) {
        const size_t k = p * C + c;
        check[k] = neutral[k] + wc[p] * (maps.compress[k] - neutral[k]) + ws[p] * (maps.stretch[k] - neutral[k]);
      }
    }
    dense_ms += Ms(t);
    for (size_t k = 0; k < check.size(); ++k) worst = std::max(worst, static_cast<double>(std::abs(check[k] - out[k])));
    t = std::chrono::steady_clock::now();
    std::copy(neutral.begin(), neutral.end(), check.begin());
    for (int i = 0; i < N; ++i) {
      if (w[i] == 0.f) continue;
      const float* d = shape_deltas[i].data();
      for (size_t k = 0; k < check.size(); ++k) check[k] += w[i] * d[k];
    }
    linear_ms += Ms(t);
  }
  std::printf("strain texture (mesh, influence, blend): %.1f ms per frame (%d frames, %s active shapes)\n",
              strain_ms / frames, frames, active > 0 ? std::to_string(active).c_str() : "all");
  std::printf("eq. 14 as printed, sparse influences:   %.1f ms per frame (%.2fx the strain texture's time)\n",
              sparse_ms / frames, sparse_ms / strain_ms);
  std::printf("eq. 14 as printed, dense influences:    %.1f ms per frame (%.2fx; largest difference from sparse "
              "%.2g)\n", dense_ms / frames, dense_ms / strain_ms, worst);
  std::printf("per-blendshape maps:                    %.1f ms per frame (%.2fx the strain texture's time)\n",
              linear_ms / frames, linear_ms / strain_ms);
  return 0;
}

}  // namespace
}  // namespace facecap

int main(int argc, char** argv) {
  int size = 1024, frames = 20, active = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--size")) size = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--frames")) frames = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--active")) active = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "usage: %s [--size N] [--frames F] [--active A]\n", argv[0]);
      return 2;
    }
  }
  if (size < 16 || frames < 1) {
    std::fprintf(stderr, "size must be >= 16 and frames >= 1\n");
    return 2;
  }
  return facecap::Run(size, frames, active);
}
