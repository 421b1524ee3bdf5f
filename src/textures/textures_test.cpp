#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "rig/demo_head.h"
#include "rig/evaluate.h"
#include "textures/compress_stretch.h"
#include "textures/influence.h"
#include "textures/network_channels.h"
#include "util/errors.h"

namespace facecap::textures {
namespace {

const rig::Rig& Head() {
  static const rig::Rig head = [] {
    rig::DemoHeadOptions o;
    o.resolution = 60;
    return rig::MakeDemoHead(o);
  }();
  return head;
}

TEST(OneRing, NeighboursOfTwoTriangles) {
  rig::Triangles tris(2, 3);
  tris << 0, 1, 2, 2, 1, 3;
  const OneRing ring = BuildOneRing(tris, 5);
  auto of = [&](int v) {
    return std::vector<int>(ring.neighbor.begin() + ring.offset[v], ring.neighbor.begin() + ring.offset[v + 1]);
  };
  EXPECT_EQ(of(0), (std::vector<int>{1, 2}));
  EXPECT_EQ(of(1), (std::vector<int>{0, 2, 3}));
  EXPECT_EQ(of(3), (std::vector<int>{1, 2}));
  EXPECT_TRUE(of(4).empty());
  rig::Vertices v(5, 3);
  v << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 5, 5, 5;
  const Eigen::VectorXf e = MeanEdgeLength(ring, v);
  EXPECT_NEAR(e[0], 1.f, 1e-6f);
  EXPECT_NEAR(e[1], (1.f + std::sqrt(2.f) + 1.f) / 3.f, 1e-6f);
  EXPECT_EQ(e[4], 0.f);
  EXPECT_THROW(BuildOneRing(tris, 3), InvalidInputError);
}

// A mesh scaled by s about any point: every edge scales by s, so the influence is pure
// stretch (s > 1) or pure compress (s < 1) of |s - 1| E_N(x), per vertex and per texel.
TEST(Influence, UniformScaleIsPureStretchOrCompress) {
  const rig::Rig& head = Head();
  const OneRing ring = BuildOneRing(head.triangles, head.NumVertices());
  const Eigen::VectorXf en = MeanEdgeLength(ring, head.neutral);
  const TexelInterpolator texels(head, 64);
  const std::vector<float> en_map = texels.Interpolate(en);
  int covered = 0;
  for (int t = 0; t < texels.NumTexels(); ++t) covered += texels.Covered(t);
  ASSERT_GT(covered, texels.NumTexels() / 4);
  for (float s : {0.8f, 1.25f}) {
    rig::Vertices scaled = head.neutral;
    for (int v = 0; v < scaled.rows(); ++v) scaled.row(v) = s * (scaled.row(v) - Eigen::RowVector3f(1, 2, 3)) + Eigen::RowVector3f(1, 2, 3);
    const VertexInfluence inf = InfluenceValues(en, MeanEdgeLength(ring, scaled));
    const Eigen::VectorXf& active = s > 1 ? inf.stretch : inf.compress;
    const Eigen::VectorXf& idle = s > 1 ? inf.compress : inf.stretch;
    EXPECT_EQ(idle.cwiseAbs().maxCoeff(), 0.f);
    EXPECT_LT((active - std::abs(s - 1.f) * en).cwiseAbs().maxCoeff(), 1e-5f);
    const std::vector<float> map = InfluenceMap(texels, inf);
    const int a = s > 1 ? 1 : 0;
    for (int t = 0; t < texels.NumTexels(); ++t) {
      ASSERT_EQ(map[2 * t + 1 - a], 0.f);
      ASSERT_NEAR(map[2 * t + a], std::abs(s - 1.f) * en_map[t], 1e-5f);
      if (texels.Covered(t)) {
        ASSERT_GT(map[2 * t + a], 0.f);
      }
    }
  }
}

// Random influence maps (many texels with zero influence, as real ones) and textures.
struct RandomLibrary {
  size_t n = 500;
  int channels = 5;
  std::vector<std::vector<float>> influence, textures;
  RandomLibrary(int maps, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    for (int i = 0; i < maps; ++i) {
      std::vector<float> inf(2 * n), tex(n * channels);
      for (float& v : inf) v = u(rng) < 0.5f ? 0.f : 0.3f * u(rng);
      for (float& v : tex) v = u(rng);
      influence.push_back(inf);
      textures.push_back(tex);
    }
  }
  std::vector<const float*> Influence() const {
    std::vector<const float*> p;
    for (const auto& m : influence) p.push_back(m.data());
    return p;
  }
  std::vector<const float*> Textures() const {
    std::vector<const float*> p;
    for (const auto& m : textures) p.push_back(m.data());
    return p;
  }
};

// Eq. 12-13 written out term by term in double precision.
double DirectMap(const RandomLibrary& lib, size_t t, int c, int kind, double b) {
  double z = 0;
  for (const auto& m : lib.influence) z += std::exp(b * m[2 * t + kind]);
  double sum = 0;
  for (size_t i = 0; i < lib.influence.size(); ++i) {
    sum += std::exp(b * lib.influence[i][2 * t + kind]) / z * lib.textures[i][t * lib.channels + c];
  }
  return sum;
}

TEST(CompressStretch, Eq12And13MatchTheDirectFormula) {
  const RandomLibrary lib(7, 3);
  for (float b : {1.f, 30.f}) {
    const CompressStretchMaps maps = ExtractCompressStretch(lib.Influence(), lib.Textures(), lib.n, lib.channels, b);
    double worst = 0;
    for (size_t t = 0; t < lib.n; ++t) {
      for (int c = 0; c < lib.channels; ++c) {
        worst = std::max(worst, std::abs(maps.compress[t * lib.channels + c] - DirectMap(lib, t, c, 0, b)));
        worst = std::max(worst, std::abs(maps.stretch[t * lib.channels + c] - DirectMap(lib, t, c, 1, b)));
      }
    }
    EXPECT_LT(worst, 1e-6) << "sharpness " << b;
  }
}

TEST(CompressStretch, Eq14MatchesTheDenseFormulaAndZeroWeightsGiveTheNeutral) {
  const RandomLibrary expressions(6, 5), blendshapes(9, 7);
  const float b = 20.f;
  const CompressStretchMaps maps = ExtractCompressStretch(expressions.Influence(), expressions.Textures(),
                                                          expressions.n, expressions.channels, b);
  const std::vector<float> neutral = blendshapes.textures[0];
  const DynamicTexture dyn(expressions.n, expressions.channels, neutral, maps, blendshapes.Influence(), b);
  EXPECT_EQ(dyn.Evaluate(std::vector<float>(9, 0.f)), neutral);  // exactly
  const auto nc = NormalizeInfluence(blendshapes.Influence(), blendshapes.n, 2, 0, b);
  const auto ns = NormalizeInfluence(blendshapes.Influence(), blendshapes.n, 2, 1, b);
  std::vector<float> alpha = {0.f, 0.3f, 1.f, 0.f, 0.7f, 0.1f, 0.f, 0.5f, 0.9f};
  const std::vector<float> got = dyn.Evaluate(alpha);
  double worst = 0;
  for (size_t t = 0; t < expressions.n; ++t) {
    double wc = 0, ws = 0;
    for (int i = 0; i < 9; ++i) {
      wc += alpha[i] * nc[i][t];
      ws += alpha[i] * ns[i][t];
    }
    for (int c = 0; c < expressions.channels; ++c) {
      const size_t k = t * expressions.channels + c;
      const double want = neutral[k] + wc * (maps.compress[k] - neutral[k]) + ws * (maps.stretch[k] - neutral[k]);
      worst = std::max(worst, std::abs(got[k] - want));
    }
  }
  EXPECT_LT(worst, 1e-5);
  EXPECT_THROW(dyn.Evaluate(std::vector<float>(8, 0.f)), InvalidInputError);
}

// Where no blendshape has influence the softmax is uniform: every blendshape contributes
// alpha_i / M there, as eq. 12 and 14 say.
TEST(CompressStretch, ZeroInfluenceTexelsShareTheWeightsEvenly) {
  const size_t n = 4;
  std::vector<float> zero(2 * n, 0.f), one(2 * n, 0.f);
  one[0] = 0.5f;  // texel 0: compress influence of blendshape 1 only
  CompressStretchMaps maps{std::vector<float>(n, 1.f), std::vector<float>(n, 2.f)};
  const DynamicTexture dyn(n, 1, std::vector<float>(n, 0.f), maps, {zero.data(), one.data()}, 2.f);
  const std::vector<float> out = dyn.Evaluate({1.f, 0.f});
  const double e = std::exp(1.0);  // exp(b * 0.5)
  EXPECT_NEAR(out[0], 1.0 / (1.0 + e) * 1.0 + 0.5 * 2.0, 1e-6);
  EXPECT_NEAR(out[1], 0.5 * 1.0 + 0.5 * 2.0, 1e-6);
}

// Expressions whose textures follow the strain texture's model exactly, T_k = T_N + w_C,k D_C +
// w_S,k D_S with w = min(1.5, I / R): the fit recovers D_C and D_S (eq. 13's blend does not), the
// strain texture then reproduces every expression, gives T_N exactly at zero influence and
// T_C where the compress influence equals its reference, and saturates beyond 1.5 R.
TEST(StrainTexture, FitRecoversTexturesThatFollowTheStrainModel) {
  const RandomLibrary expressions(8, 21), offsets(3, 22);
  const size_t n = expressions.n;
  const int C = expressions.channels;
  const float b = 30.f;
  const std::vector<float>& neutral = offsets.textures[0];
  const CompressStretchMaps eq13 = ExtractCompressStretch(expressions.Influence(), expressions.Textures(), n, C, b);
  // Reference influences: eq. 13 applied to the influences themselves.
  for (size_t t = 0; t < n; ++t) {
    for (int kind = 0; kind < 2; ++kind) {
      double z = 0, want = 0;
      for (const auto& m : expressions.influence) z += std::exp(b * m[2 * t + kind]);
      for (const auto& m : expressions.influence) want += std::exp(b * m[2 * t + kind]) / z * m[2 * t + kind];
      ASSERT_NEAR(eq13.reference[2 * t + kind], want, 1e-6);
    }
  }
  auto weight = [&](float influence, float reference) {
    return reference > 1e-4f ? std::min(kMaxStrainWeight, influence / reference) : 0.f;
  };
  std::vector<std::vector<float>> textures;
  for (const auto& inf : expressions.influence) {
    std::vector<float> tex(n * C);
    for (size_t t = 0; t < n; ++t) {
      const float wc = weight(inf[2 * t], eq13.reference[2 * t]);
      const float ws = weight(inf[2 * t + 1], eq13.reference[2 * t + 1]);
      for (int c = 0; c < C; ++c) {
        const size_t k = t * C + c;
        tex[k] = neutral[k] + wc * (offsets.textures[1][k] - 0.5f) + ws * (offsets.textures[2][k] - 0.5f);
      }
    }
    textures.push_back(tex);
  }
  std::vector<const float*> pointers;
  for (const auto& m : textures) pointers.push_back(m.data());
  const CompressStretchMaps fit = FitCompressStretch(expressions.Influence(), pointers, neutral, n, C, b);
  const CompressStretchMaps blend = ExtractCompressStretch(expressions.Influence(), pointers, n, C, b);
  const StrainTexture strain(n, C, neutral, fit), strain_of_blend(n, C, neutral, blend);
  double fit_worst = 0, blend_worst = 0;
  for (size_t e = 0; e < textures.size(); ++e) {
    const std::vector<float> got = strain.Evaluate(expressions.influence[e]);
    const std::vector<float> got_blend = strain_of_blend.Evaluate(expressions.influence[e]);
    for (size_t k = 0; k < got.size(); ++k) {
      fit_worst = std::max(fit_worst, static_cast<double>(std::abs(got[k] - textures[e][k])));
      blend_worst = std::max(blend_worst, static_cast<double>(std::abs(got_blend[k] - textures[e][k])));
    }
  }
  EXPECT_LT(fit_worst, 2e-3);
  EXPECT_GT(blend_worst, 0.05);
  EXPECT_EQ(strain.Evaluate(std::vector<float>(2 * n, 0.f)), neutral);  // exactly
  // Compress influence at the reference, none of stretch: T_C; at 3 R: still 1.5 (T_C - T_N).
  std::vector<float> at_reference(2 * n, 0.f), beyond(2 * n, 0.f);
  for (size_t t = 0; t < n; ++t) {
    at_reference[2 * t] = fit.reference[2 * t];
    beyond[2 * t] = 3.f * fit.reference[2 * t];
  }
  const std::vector<float> c1 = strain.Evaluate(at_reference), c3 = strain.Evaluate(beyond);
  for (size_t t = 0; t < n; ++t) {
    if (fit.reference[2 * t] <= 1e-4f) continue;
    for (int c = 0; c < C; ++c) {
      const size_t k = t * C + c;
      EXPECT_NEAR(c1[k], fit.compress[k], 1e-5f);
      EXPECT_NEAR(c3[k], neutral[k] + kMaxStrainWeight * (fit.compress[k] - neutral[k]), 1e-5f);
    }
  }
  EXPECT_THROW(strain.Evaluate(std::vector<float>(2 * n - 2, 0.f)), InvalidInputError);
}

// A rig's strain texture at zero weights is its neutral texture exactly, and at a shape that
// moves the skin it changes the texture only where that shape moves it.
TEST(StrainTexture, RigAtZeroWeightsIsTheNeutralAndAShapeChangesOnlyItsSkin) {
  const rig::Rig& head = Head();
  const int S = 32;
  const size_t n = static_cast<size_t>(S) * S;
  const int C = 1;
  CompressStretchMaps maps{std::vector<float>(n, 1.f), std::vector<float>(n, 2.f), std::vector<float>(2 * n, 0.01f)};
  const RigStrainTexture texture(head, S, C, std::vector<float>(n, 0.f), maps);
  const int N = head.NumShapes();
  EXPECT_EQ(texture.Evaluate(std::vector<float>(N, 0.f)), std::vector<float>(n, 0.f));
  std::vector<float> w(N, 0.f);
  w[head.ShapeIndex("jawOpen")] = 1.f;
  const std::vector<float> open = texture.Evaluate(w);
  const TexelInterpolator texels(head, S);
  const OneRing ring = BuildOneRing(head.triangles, head.NumVertices());
  rig::Vertices mesh;
  rig::EvaluateShape(head, Eigen::Map<const Eigen::VectorXf>(w.data(), N), &mesh);
  const std::vector<float> inf =
      InfluenceMap(texels, InfluenceValues(MeanEdgeLength(ring, head.neutral), MeanEdgeLength(ring, mesh)));
  int moved = 0;
  for (size_t t = 0; t < n; ++t) {
    const float want = std::min(kMaxStrainWeight, inf[2 * t] / 0.01f) * 1.f +
                       std::min(kMaxStrainWeight, inf[2 * t + 1] / 0.01f) * 2.f;
    EXPECT_NEAR(open[t], want, 1e-4f) << t;
    moved += open[t] != 0.f;
  }
  EXPECT_GT(moved, 20);
  EXPECT_LT(moved, static_cast<int>(n) / 2);
  EXPECT_THROW(texture.Evaluate(std::vector<float>(N - 1, 0.f)), InvalidInputError);
}

// The networks' channels: the targets' low and high displacement frequencies sum to the
// displacement offset and the outputs rebuild the expression maps exactly; the offset geometry
// image of a mesh scaled by s is (s - 1) times its point, with pure stretch; normalization
// inverts on covered texels.
TEST(NetworkChannels, TargetsRebuildTheExpressionAndGeometryFollowsTheMesh) {
  const int S = 32;
  const TexelInterpolator texels(Head(), S);
  const size_t n = static_cast<size_t>(S) * S;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<float> neutral(n * 5), expression(n * 5);
  for (size_t i = 0; i < neutral.size(); ++i) {
    neutral[i] = u(rng);
    expression[i] = neutral[i] + 0.2f * (u(rng) - 0.5f);
  }
  const std::vector<float> out = OutputChannels(neutral, expression, S, 2.f);
  ASSERT_EQ(out.size(), static_cast<size_t>(kOutputChannels) * n);
  double low_energy = 0, high_energy = 0;
  for (size_t t = 0; t < n; ++t) {
    EXPECT_NEAR(out[4 * n + t] + out[5 * n + t], expression[5 * t + 4] - neutral[5 * t + 4], 1e-6f);
    low_energy += out[4 * n + t] * out[4 * n + t];
    high_energy += out[5 * n + t] * out[5 * n + t];
  }
  EXPECT_LT(low_energy, 0.2 * high_energy);  // white noise is mostly high frequency
  const std::vector<float> rebuilt = ExpressionMapsFromOutputs(neutral, out.data(), S);
  for (size_t i = 0; i < rebuilt.size(); ++i) EXPECT_NEAR(rebuilt[i], expression[i], 1e-6f);

  const rig::Vertices& mesh = Head().neutral;
  const rig::Vertices scaled = 1.1f * mesh;
  const OneRing ring = BuildOneRing(Head().triangles, Head().NumVertices());
  const std::vector<float> e = ExpressionChannels(texels, ring, MeanEdgeLength(ring, mesh), mesh, scaled);
  const std::vector<float> person = PersonChannels(texels, mesh, mesh, neutral);
  int covered = 0;
  for (size_t t = 0; t < n; ++t) {
    if (!texels.Covered(static_cast<int>(t))) {
      EXPECT_EQ(person[8 * n + t], 0.f);
      continue;
    }
    ++covered;
    EXPECT_EQ(person[8 * n + t], 1.f);
    EXPECT_NEAR(person[5 * n + t], 0.f, 1e-6f);  // the neutral is the template
    EXPECT_EQ(person[3 * n + t], neutral[5 * t + 3]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c * n + t], 0.1f * texels.positions()[t][c], 1e-4f);
    EXPECT_EQ(e[3 * n + t], 0.f);
    EXPECT_GT(e[4 * n + t], 0.f);
  }
  EXPECT_GT(covered, static_cast<int>(n) / 4);

  std::vector<float> coverage(n);
  for (size_t t = 0; t < n; ++t) coverage[t] = person[8 * n + t];
  const ChannelNormalization norm = ChannelNormalization::Fit({e.data()}, kExpressionChannels, coverage.data(), S,
                                                              {true, true, true, false, false});
  EXPECT_EQ(norm.mean[3], 0.f);
  std::vector<float> x = e;
  norm.Apply(x.data(), coverage.data(), S);
  double mean0 = 0, var0 = 0;
  for (size_t t = 0; t < n; ++t) {
    if (coverage[t] == 0.f) continue;
    mean0 += x[t];
    var0 += x[t] * x[t];
  }
  EXPECT_NEAR(mean0 / covered, 0.0, 1e-4);
  EXPECT_NEAR(var0 / covered, 1.0, 1e-3);
  norm.Invert(x.data(), coverage.data(), S);
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(x[i], e[i], 1e-5f);
}

}  // namespace
}  // namespace facecap::textures
