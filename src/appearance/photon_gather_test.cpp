#include "appearance/photon_gather.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "appearance/texture_metrics.h"
#include "render/shading.h"
#include "rig/demo_head.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::appearance {
namespace {

// A smooth colour field over the head (linear RGB in [0.1, 0.9]).
Eigen::Vector3f KnownColor(const Eigen::Vector3f& p) {
  return Eigen::Vector3f(0.5f + 0.4f * std::sin(0.35f * p.x()), 0.5f + 0.4f * std::cos(0.3f * p.y()),
                         0.5f + 0.4f * std::sin(0.25f * (p.x() + p.z())));
}

// Particles spread uniformly over the UV image of every triangle the texel map uses, about
// `per_texel` per texel, each with the known colour of its surface point. `keep(uv)` thins.
template <class Keep>
std::vector<Particle> SampleParticles(const rig::Rig& rig, const render::TexelMap& texels,
                                      const std::vector<int32_t>& charts, float per_texel, Keep keep) {
  std::vector<bool> used(rig.triangles.rows(), false);
  for (int32_t t : texels.triangle) {
    if (t >= 0) used[t] = true;
  }
  const float N = static_cast<float>(texels.size);
  std::vector<Particle> particles;
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    if (!used[f]) continue;
    Eigen::Vector2f uv[3];
    Eigen::Vector3f p[3];
    for (int k = 0; k < 3; ++k) {
      uv[k] = rig.uvs.row(rig.uv_triangles(f, k)).transpose();
      p[k] = rig.neutral.row(rig.triangles(f, k)).transpose();
    }
    const Eigen::Vector2f e1 = uv[1] - uv[0], e2 = uv[2] - uv[0];
    const float area_texels = 0.5f * std::abs(e1.x() * e2.y() - e1.y() * e2.x()) * N * N;
    Rng rng(11, static_cast<uint64_t>(f));
    const int n = static_cast<int>(std::ceil(area_texels * per_texel));
    for (int i = 0; i < n; ++i) {
      float a = static_cast<float>(rng.Uniform()), b = static_cast<float>(rng.Uniform());
      if (a + b > 1.f) {
        a = 1.f - a;
        b = 1.f - b;
      }
      Particle particle;
      particle.uv = uv[0] + a * e1 + b * e2;
      if (!keep(particle.uv)) continue;
      particle.color = KnownColor((1.f - a - b) * p[0] + a * p[1] + b * p[2]);
      particle.chart = charts[f];
      particles.push_back(particle);
    }
  }
  return particles;
}

class PhotonGatherTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig_ = new rig::Rig(rig::MakeDemoHead());
    texels_ = new render::TexelMap(render::BakeTexelMap(*rig_, 128));
    charts_ = new std::vector<int32_t>(UVCharts(*rig_));
  }
  static void TearDownTestSuite() {
    delete rig_;
    delete texels_;
    delete charts_;
  }
  static rig::Rig* rig_;
  static render::TexelMap* texels_;
  static std::vector<int32_t>* charts_;
};
rig::Rig* PhotonGatherTest::rig_ = nullptr;
render::TexelMap* PhotonGatherTest::texels_ = nullptr;
std::vector<int32_t>* PhotonGatherTest::charts_ = nullptr;

TEST_F(PhotonGatherTest, ChartsJoinTrianglesThatShareUVCorners) {
  const std::vector<int32_t>& charts = *charts_;
  ASSERT_EQ(charts.size(), static_cast<size_t>(rig_->triangles.rows()));
  std::vector<int32_t> chart_of_uv(rig_->uvs.rows(), -1);
  for (int f = 0; f < rig_->uv_triangles.rows(); ++f) {
    for (int k = 0; k < 3; ++k) {
      int32_t& c = chart_of_uv[rig_->uv_triangles(f, k)];
      if (c < 0) c = charts[f];
      EXPECT_EQ(c, charts[f]) << "triangle " << f;
    }
  }
  EXPECT_GT(*std::max_element(charts.begin(), charts.end()), 0) << "the head has several charts";
}

TEST_F(PhotonGatherTest, GatheringReproducesAKnownTexture) {
  const auto particles = SampleParticles(*rig_, *texels_, *charts_, 4.f, [](const Eigen::Vector2f&) { return true; });
  const GatheredTexture gathered = GatherParticles(particles, *texels_, *charts_, GatherOptions());
  const int N = texels_->size;
  double error = 0., flat_error = 0.;
  int64_t covered = 0, layout = 0, confident = 0;
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      const size_t i = static_cast<size_t>(y) * N + x;
      if (!texels_->Covered(i)) {
        EXPECT_EQ(gathered.confidence.at(x, y), 0.f);
        continue;
      }
      ++layout;
      if (gathered.confidence.at(x, y) <= 0.f) continue;
      ++covered;
      confident += gathered.confidence.at(x, y) >= 0.99f;
      const Eigen::Vector3f truth = KnownColor(texels_->position[i]);
      for (int c = 0; c < 3; ++c) error += std::abs(gathered.color.at(x, y, c) - truth[c]);
      flat_error += (Eigen::Vector3f::Constant(0.5f) - truth).cwiseAbs().sum();
    }
  }
  // Every texel of the layout is covered, almost all at full density, and the colours are the
  // field's (a flat grey is 20 times worse).
  EXPECT_GT(covered, 0.98 * layout);
  EXPECT_GT(confident, 0.9 * layout);
  EXPECT_LT(error / (3. * covered), 0.01);
  EXPECT_GT(flat_error / (3. * covered), 0.2);
  // Each particle counts in exactly one texel.
  int64_t counted = 0;
  for (int32_t n : gathered.count.data) counted += n;
  EXPECT_EQ(counted, static_cast<int64_t>(particles.size()));
}

TEST_F(PhotonGatherTest, ConfidenceFallsWhereParticlesAreSparseAndHolesStayEmpty) {
  // Left half (u < 0.5): one particle in 16 kept; a band u in [0.7, 0.8): none.
  Rng rng(5, 0);
  const auto particles = SampleParticles(*rig_, *texels_, *charts_, 4.f, [&](const Eigen::Vector2f& uv) {
    if (uv.x() >= 0.7f && uv.x() < 0.8f) return false;
    return uv.x() >= 0.5f || rng.Uniform() < 1. / 16.;
  });
  GatherOptions options;
  options.max_radius_texels = 6.f;
  const GatheredTexture gathered = GatherParticles(particles, *texels_, *charts_, options);
  const int N = texels_->size;
  double sparse = 0., dense = 0.;
  int64_t n_sparse = 0, n_dense = 0, band = 0, band_empty = 0;
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      if (!texels_->Covered(static_cast<size_t>(y) * N + x)) continue;
      const float u = (x + 0.5f) / N;
      const float c = gathered.confidence.at(x, y);
      if (u < 0.45f) {
        sparse += c;
        ++n_sparse;
      } else if (u > 0.52f && u < 0.68f) {
        dense += c;
        ++n_dense;
      } else if (u > 0.74f && u < 0.76f) {
        ++band;
        if (c == 0.f) {
          ++band_empty;
          EXPECT_EQ(gathered.color.at(x, y, 0), 0.f);
        }
      }
    }
  }
  ASSERT_GT(n_sparse, 0);
  ASSERT_GT(n_dense, 0);
  ASSERT_GT(band, 0);
  // 16 times fewer particles: a radius about 4 times larger, a confidence well under half.
  EXPECT_LT(sparse / n_sparse, 0.5 * dense / n_dense);
  EXPECT_GT(dense / n_dense, 0.95);
  // The middle of a band 12.8 texels wide with no particles is farther than 6 texels from any.
  EXPECT_EQ(band_empty, band);
}

TEST(FillHolesTest, HolesTakeASmoothContinuationAndKnownTexelsStay) {
  // A horizontal ramp with a 10 x 10 hole and an unknown right third.
  const int N = 64;
  ImageF color(N, N, 3), confidence(N, N, 1);
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      const bool hole = (x >= 20 && x < 30 && y >= 20 && y < 30) || x >= 44;
      confidence.at(x, y) = hole ? 0.f : 1.f;
      for (int c = 0; c < 3; ++c) color.at(x, y, c) = hole ? 0.f : 0.2f + 0.01f * x;
    }
  }
  const ImageF before = color;
  FillHoles(confidence, &color);
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      if (confidence.at(x, y) > 0.f) {
        EXPECT_EQ(color.at(x, y, 1), before.at(x, y, 1));
      } else if (x < 44) {
        // Inside the small hole: close to the ramp it interrupts.
        EXPECT_NEAR(color.at(x, y, 0), 0.2f + 0.01f * x, 0.06f) << x << ", " << y;
      } else {
        // The unknown third continues the known edge's colours, never black.
        EXPECT_GT(color.at(x, y, 0), 0.4f) << x << ", " << y;
        EXPECT_LT(color.at(x, y, 0), 0.64f) << x << ", " << y;
      }
    }
  }
  ImageF none(N, N, 1), untouched = before;
  FillHoles(none, &untouched);
  EXPECT_EQ(untouched.data, before.data);
}

TEST_F(PhotonGatherTest, BadOptionsAndParticlesAreRefused) {
  GatherOptions options;
  options.neighbours = 0;
  EXPECT_THROW(GatherParticles({}, *texels_, *charts_, options), InvalidInputError);
  Particle p;
  p.uv = Eigen::Vector2f(0.5f, 0.5f);
  p.color = Eigen::Vector3f::Ones();
  p.chart = 1 << 20;
  EXPECT_THROW(GatherParticles({p}, *texels_, *charts_, GatherOptions()), InvalidInputError);
  p.chart = 0;
  p.color.x() = NAN;
  EXPECT_THROW(GatherParticles({p}, *texels_, *charts_, GatherOptions()), InvalidInputError);
}

TEST_F(PhotonGatherTest, ComparisonUndoesAChannelGainAndScoresAFlatTextureLow) {
  const int N = texels_->size;
  const std::vector<uint8_t> mask = FaceRegionMask(*rig_, *texels_);
  int64_t in_face = 0;
  for (uint8_t m : mask) in_face += m;
  ASSERT_GT(in_face, 100);
  ImageF truth(N, N, 3), captured(N, N, 3), confidence(N, N, 1, 1.f);
  const Eigen::Vector3f gain(0.5f, 0.8f, 1.25f);
  for (int y = 0; y < N; ++y) {
    for (int x = 0; x < N; ++x) {
      const Eigen::Vector3f c = KnownColor(texels_->position[static_cast<size_t>(y) * N + x]);
      for (int k = 0; k < 3; ++k) {
        truth.at(x, y, k) = c[k];
        captured.at(x, y, k) = c[k] * gain[k];
      }
    }
  }
  TextureComparison same = CompareTextures(captured, confidence, truth, mask);
  EXPECT_EQ(same.face_texels, in_face);
  EXPECT_DOUBLE_EQ(same.coverage, 1.);
  EXPECT_NEAR(same.gain[0], 2., 1e-4);
  EXPECT_NEAR(same.gain[2], 0.8, 1e-4);
  EXPECT_GT(same.psnr_db, 60.);
  EXPECT_LT(same.psnr_flat_db, 25.);
  // Half the region uncovered: coverage halves, the score over what is covered stays.
  int64_t dropped = 0;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (mask[i] && (dropped++ % 2 == 0)) confidence.data[i] = 0.f;
  }
  TextureComparison half = CompareTextures(captured, confidence, truth, mask);
  EXPECT_NEAR(half.coverage, 0.5, 0.01);
  EXPECT_GT(half.psnr_db, 60.);
}

// A texture of small blobs, shifted by (dx, dy) texels (bilinear between texels) and scaled.
ImageF Blobs(int n, double dx, double dy, double scale) {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> where(0., n);
  std::vector<Eigen::Vector2d> centres(n * n / 16);
  for (auto& c : centres) c = Eigen::Vector2d(where(random), where(random));
  ImageF image(n, n, 3);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      double v = 0.2;
      for (const auto& c : centres) {
        v += 0.5 * std::exp(-(Eigen::Vector2d(x - dx, y - dy) - c).squaredNorm() / 4.);
      }
      for (int k = 0; k < 3; ++k) image.at(x, y, k) = static_cast<float>(scale * v * (1. + 0.2 * k));
    }
  }
  return image;
}

TEST(CornerAlignmentTest, MeasuresTheShiftOfTheDetailAndNothingOnAFlatTexture) {
  const int n = 64;
  const ImageF truth = Blobs(n, 0., 0., 1.);
  const std::vector<Eigen::Vector2f> points = {{0.3f, 0.4f}, {0.5f, 0.5f}, {0.7f, 0.65f}};
  const CornerAlignment same = MeasureCornerAlignment(truth, truth, points, 5, 6);
  EXPECT_EQ(same.found, 3);
  EXPECT_LT(same.mean_shift_texels, 0.1);  // the parabola through an asymmetric peak
  for (double c : same.correlation) EXPECT_NEAR(c, 1., 1e-9);
  // Shifted by (3, -2) and darkened: the shift, not the gain, is measured.
  const CornerAlignment shifted = MeasureCornerAlignment(Blobs(n, 3., -2., 0.6), truth, points, 5, 6);
  EXPECT_EQ(shifted.found, 3);
  for (double d : shifted.shift_texels) EXPECT_NEAR(d, std::hypot(3., 2.), 0.2);
  // A fraction of a texel is resolved.
  const CornerAlignment half = MeasureCornerAlignment(Blobs(n, 1.5, 0., 1.), truth, points, 5, 6);
  for (double d : half.shift_texels) EXPECT_NEAR(d, 1.5, 0.25);
  // A flat capture has no detail to find: every corner counts as shifted by the search radius.
  const ImageF flat(n, n, 3, 0.4f);
  const CornerAlignment none = MeasureCornerAlignment(flat, truth, points, 5, 6);
  EXPECT_EQ(none.found, 0);
  EXPECT_DOUBLE_EQ(none.mean_shift_texels, 6.);
  EXPECT_THROW(MeasureCornerAlignment(flat, Blobs(32, 0., 0., 1.), points, 5, 6), InvalidInputError);
  EXPECT_THROW(MeasureCornerAlignment(flat, truth, points, 20, 20), InvalidInputError);
}

TEST_F(PhotonGatherTest, CornerLandmarksHaveTextureCoordinates) {
  const std::vector<Eigen::Vector2f> uvs = LandmarkUVs(*rig_, CornerLandmarks());
  ASSERT_EQ(uvs.size(), 6u);
  for (const auto& uv : uvs) {
    EXPECT_GE(uv.minCoeff(), 0.f);
    EXPECT_LE(uv.maxCoeff(), 1.f);
  }
  // The two corners of the mouth are distinct texture points.
  EXPECT_GT((uvs[4] - uvs[5]).norm(), 0.01f);
  EXPECT_THROW(LandmarkUVs(*rig_, {68}), InvalidInputError);
}

// Frames rendered from a known texture, each under its own light (a gain per channel and a
// direction): that texture explains them exactly, a shifted copy and a flat colour far less
// well; masked pixels do not count.
TEST(RerenderScoreTest, TheTrueTextureExplainsFramesUnderAnyLight) {
  const int n = 64;
  const ImageF truth = Blobs(n, 0., 0., 1.), shifted = Blobs(n, 4., 0., 1.);
  RerenderScore score({&truth, &shifted});
  const int size = 32;
  for (int frame = 0; frame < 3; ++frame) {
    const Eigen::Vector3f light = Eigen::Vector3f(0.5f * frame - 0.5f, 0.3f, 1.f).normalized();
    ImageF image(size, size, 3), uv(size, size, 3), normals(size, size, 3), mask(size, size, 1, 1.f);
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const float u = 0.2f + 0.6f * x / size, v = 0.8f - 0.6f * y / size;
        uv.at(x, y, 0) = u;
        uv.at(x, y, 1) = v;
        uv.at(x, y, 2) = x < size - 4 ? 1.f : 0.f;  // the last columns are background
        const Eigen::Vector3f normal = Eigen::Vector3f(x - 16.f, y - 16.f, 20.f).normalized();
        for (int k = 0; k < 3; ++k) normals.at(x, y, k) = normal[k];
        const float shade = 0.4f + 0.5f * std::max(0.f, normal.dot(light));
        const Eigen::Vector3f c = render::SampleBilinear(truth, u, v);
        for (int k = 0; k < 3; ++k) image.at(x, y, k) = c[k] * shade * (0.5f + 0.2f * frame + 0.1f * k);
        if (x < size - 4 && y == 0) {
          image.at(x, y, 0) = 1.f;  // a masked-out pixel far from the texture
          mask.at(x, y) = 0.f;
        }
      }
    }
    score.AddFrame(image, uv, normals, mask);
  }
  EXPECT_EQ(score.frames(), 3);
  EXPECT_EQ(score.pixels(), 3 * (size - 4) * (size - 1));
  EXPECT_GT(score.PsnrDb(0), 60.);
  EXPECT_LT(score.PsnrDb(1), score.PsnrDb(0) - 20.);
  EXPECT_LT(score.FlatPsnrDb(), score.PsnrDb(0) - 20.);
  EXPECT_THROW(RerenderScore({nullptr}), InvalidInputError);
}

}  // namespace
}  // namespace facecap::appearance
