// Scan database, geometry images, deformation transfer, example-based rigging and the bounded
// least squares, each against a known truth.
#include <cmath>

#include <gtest/gtest.h>

#include "assets/bounded_least_squares.h"
#include "assets/deformation_transfer.h"
#include "assets/example_based_rigging.h"
#include "assets/geometry_image.h"
#include "assets/scan_database.h"
#include "assets/template_shapes.h"
#include "rig/demo_head.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::assets {
namespace {

const rig::Rig& SmallHead() {
  static const rig::Rig head = [] {
    rig::DemoHeadOptions o;
    o.resolution = 60;
    o.num_identity_modes = 8;
    return rig::MakeDemoHead(o);
  }();
  return head;
}

const LinearShapes& Template() {
  static const LinearShapes t = MakeTemplateShapes(SmallHead());
  return t;
}

TEST(TemplateShapes, FiftyFiveShapesAndTheDefaultFacsTableCoversThem) {
  const LinearShapes& t = Template();
  ASSERT_EQ(t.NumShapes(), 55);
  EXPECT_EQ(t.names[52], "browInnerUpLeft");
  for (int i = 0; i < t.NumShapes(); ++i) EXPECT_GT(t.deltas.col(i).norm(), 0.f) << t.names[i];
  const Eigen::MatrixXf alpha = FacsWeights(ParseFacsTable(DefaultFacsTable()), t.names, true);
  EXPECT_EQ(alpha.rows(), 24);
  // The brow halves are asymmetric: the left one moves nothing at x << 0.
  const int left = t.ShapeIndex("browInnerUpLeft");
  for (int v = 0; v < t.NumVertices(); ++v) {
    if (t.neutral(v, 0) < -1.f) {
      ASSERT_EQ((t.deltas.block<3, 1>(3 * v, left).norm()), 0.f);
    }
  }
  EXPECT_THROW(FacsWeights(ParseFacsTable({"a=nothing"}), t.names, false), InvalidInputError);
  EXPECT_THROW(FacsWeights(ParseFacsTable({"a=jawOpen"}), t.names, true), InvalidInputError);
  EXPECT_THROW(ParseFacsTable({"broken"}), InvalidInputError);
}

TEST(BoundedLeastSquares, MatchesTheUnconstrainedSolutionInsideAndRespectsBounds) {
  Rng rng(3, 0);
  Eigen::MatrixXf basis(40, 5);
  for (int i = 0; i < basis.size(); ++i) basis.data()[i] = static_cast<float>(rng.Normal());
  const Eigen::VectorXf truth = (Eigen::VectorXf(5) << 0.2f, 0.5f, 0.9f, 0.1f, 0.7f).finished();
  BoundedLeastSquares solver(basis, BoundedLeastSquaresOptions());
  Eigen::VectorXf w;
  BoundedLeastSquaresSummary summary;
  solver.Solve(basis * truth, Eigen::VectorXf(), &w, &summary);
  EXPECT_TRUE(summary.converged);
  EXPECT_LT((w - truth).norm(), 1e-4f);
  const Eigen::VectorXf outside = (Eigen::VectorXf(5) << -0.5f, 1.5f, 0.5f, 0.5f, 0.5f).finished();
  w.resize(0);
  solver.Solve(basis * outside, Eigen::VectorXf(), &w);
  EXPECT_GE(w.minCoeff(), 0.f);
  EXPECT_LE(w.maxCoeff(), 1.f);
  EXPECT_NEAR(w[0], 0.f, 1e-6f);
  EXPECT_NEAR(w[1], 1.f, 1e-6f);
}

TEST(GeometryImage, RoundTripErrorIsBelowAMillimetre) {
  const rig::Rig& head = SmallHead();
  const std::vector<int> chart = ChartVertices(head, MovingVertices(Template()));
  ASSERT_GT(chart.size(), 500u);
  for (int size : {32, 64}) {
    GeometryImageOptions o;
    o.size = size;
    const GeometryImageLayout layout(head, chart, o);
    const RoundTripError e = GeometryImageRoundTrip(layout, head.neutral);
    RecordProperty("round_trip_mean_cm_" + std::to_string(size), std::to_string(e.mean_cm));
    std::printf("geometry image %d px: round trip mean %.4f cm, max %.4f cm over %zu vertices\n",
                size, e.mean_cm, e.max_cm, chart.size());
    EXPECT_LT(e.mean_cm, size == 64 ? 0.05 : 0.1);
  }
}

TEST(DeformationTransfer, ReproducesTheTemplateWhenTheNeutralIsTheTemplates) {
  const LinearShapes& t = Template();
  const DeformationTransfer transfer(t.neutral, t.neutral, SmallHead().triangles);
  const Eigen::MatrixXf moved = transfer.TransferDeltas(t.deltas);
  EXPECT_LT((moved - t.deltas).cwiseAbs().maxCoeff(), 1e-4f);
}

TEST(DeformationTransfer, KeepsShapesCloseOnAnotherPerson) {
  const LinearShapes& t = Template();
  const rig::Rig person = rig::WithIdentity(SmallHead(), 5);
  const DeformationTransfer transfer(t.neutral, person.neutral, SmallHead().triangles);
  const Eigen::MatrixXf moved = transfer.TransferDeltas(t.deltas);
  const double relative = (moved - t.deltas).norm() / t.deltas.norm();
  EXPECT_GT(relative, 1e-4);  // the person's geometry changes the shapes
  EXPECT_LT(relative, 0.5);
}

TEST(ExampleBasedRigging, RecoversKnownShapesFromExpressionsMadeWithThem) {
  // 6 shapes, 12 scans with generic weights: the shapes are determined by the scans.
  Rng rng(11, 0);
  const int V = 50, N = 6, K = 12;
  Eigen::VectorXf neutral(3 * V);
  Eigen::MatrixXf truth(3 * V, N), prior(3 * V, N), weights(K, N);
  for (int i = 0; i < neutral.size(); ++i) neutral[i] = static_cast<float>(rng.Normal());
  for (int i = 0; i < truth.size(); ++i) truth.data()[i] = static_cast<float>(rng.Normal());
  prior = truth + 0.3f * Eigen::MatrixXf::Random(3 * V, N);
  for (int i = 0; i < weights.size(); ++i) weights.data()[i] = static_cast<float>(rng.Uniform(0.05, 0.95));
  const Eigen::MatrixXf expressions = (truth * weights.transpose()).colwise() + neutral;
  std::vector<int> vertices(V);
  for (int v = 0; v < V; ++v) vertices[v] = v;
  ExampleBasedOptions o;
  o.shape_regularization = 1e-5f;
  o.weight_regularization = 0.f;
  o.iterations = 3;
  const ExampleBasedResult r = FitExampleBasedRig(neutral, expressions, weights, prior, truth, vertices, o);
  EXPECT_LT((r.deltas - truth).cwiseAbs().maxCoeff(), 1e-3f);
  const Eigen::VectorXd errors = ReconstructionErrors(neutral, r.deltas, expressions, vertices);
  EXPECT_LT(errors.maxCoeff(), 1e-3);
}

TEST(ScanDatabase, PeopleAreDeterministicPersonalAndNoisy) {
  const LinearShapes& t = Template();
  const std::vector<int> chart = ChartVertices(SmallHead(), MovingVertices(t));
  const Eigen::MatrixXf alpha = FacsWeights(ParseFacsTable(DefaultFacsTable()), t.names, true);
  ScanSynthOptions o;
  const ScanPerson a = SynthesizeScanPerson(SmallHead(), t, chart, alpha, 0, o);
  const ScanPerson again = SynthesizeScanPerson(SmallHead(), t, chart, alpha, 0, o);
  const ScanPerson b = SynthesizeScanPerson(SmallHead(), t, chart, alpha, 1, o);
  EXPECT_EQ(a.expressions, again.expressions);
  EXPECT_GT((a.true_deltas - t.deltas).norm(), 0.05f * t.deltas.norm());
  EXPECT_GT((a.true_deltas - b.true_deltas).norm(), 0.f);
  EXPECT_NE(a.true_weights, alpha);  // unwanted motion
  // The true shapes reconstruct their scans to the noise level.
  const Eigen::VectorXd errors = ReconstructionErrors(a.neutral, a.true_deltas, a.expressions, chart);
  EXPECT_LT(errors.mean(), 0.03);
}

// The stored factors are the ones the shapes were made with: without the personal noise the
// global factors stay and every personal vertex's motion is the noisy one over (1 + e_ij).
TEST(ScanDatabase, StoredFactorsAreTheTermsOfTheShapes) {
  const LinearShapes& t = Template();
  const std::vector<int> chart = ChartVertices(SmallHead(), MovingVertices(t));
  const Eigen::MatrixXf alpha = FacsWeights(ParseFacsTable(DefaultFacsTable()), t.names, true);
  ScanSynthOptions o;
  o.personal_noise = 0.1f;
  const ScanPerson noisy = SynthesizeScanPerson(SmallHead(), t, chart, alpha, 2, o);
  o.personal_noise = 0.f;
  const ScanPerson clean = SynthesizeScanPerson(SmallHead(), t, chart, alpha, 2, o);
  const int N = t.NumShapes();
  ASSERT_EQ(noisy.global_factors.size(), N);
  ASSERT_EQ(noisy.personal_factors.size(), N);
  EXPECT_EQ(noisy.global_factors, clean.global_factors);
  EXPECT_EQ(clean.personal_factors, Eigen::VectorXf::Zero(N));
  EXPECT_GT(noisy.personal_factors.cwiseAbs().maxCoeff(), 0.02f);
  EXPECT_GT(noisy.global_factors.maxCoeff() - noisy.global_factors.minCoeff(), 0.1f);
  for (int i = 0; i < N; ++i) {
    for (int v : chart) {
      const Eigen::Vector3f a = noisy.true_deltas.block<3, 1>(3 * v, i);
      const Eigen::Vector3f b = (1.f + noisy.personal_factors[i]) * clean.true_deltas.block<3, 1>(3 * v, i);
      ASSERT_LT((a - b).norm(), 1e-5f * (1.f + b.norm())) << "shape " << i << " vertex " << v;
    }
  }
}

}  // namespace
}  // namespace facecap::assets
