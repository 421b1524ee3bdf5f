#include "rig/perturb.h"

#include <cmath>

#include <gtest/gtest.h>

#include "rig/demo_head.h"
#include "util/errors.h"

namespace facecap::rig {
namespace {

TEST(PerturbTest, TheFieldHasTheAskedRmsIsSmoothAndDependsOnTheSeedAlone) {
  const Rig rig = MakeDemoHead();
  PerturbOptions o;  // 3 mm RMS, 2 cm scale
  const Rig a = PerturbNeutral(rig, o);
  const Vertices d = a.neutral - rig.neutral;
  EXPECT_NEAR(std::sqrt(d.squaredNorm() / rig.NumVertices()), 0.3, 1e-4);
  // Smooth: along the mesh's edges the displacement changes far less than it is large (noise
  // drawn per vertex would change by about 1.4 times its RMS).
  double edge_change = 0.;
  int edges = 0;
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      edge_change += (d.row(rig.triangles(f, c)) - d.row(rig.triangles(f, (c + 1) % 3))).norm();
      ++edges;
    }
  }
  EXPECT_LT(edge_change / edges, 0.2 * 0.3);
  EXPECT_EQ(PerturbNeutral(rig, o).neutral, a.neutral);
  o.seed = 2;
  EXPECT_GT((PerturbNeutral(rig, o).neutral - a.neutral).norm(), 1.);
  // Everything but the neutral is kept.
  EXPECT_EQ(a.triangles, rig.triangles);
  EXPECT_EQ(a.landmarks, rig.landmarks);
  ASSERT_EQ(a.NumShapes(), rig.NumShapes());
  EXPECT_EQ(a.shapes[3].delta.vertex, rig.shapes[3].delta.vertex);
  EXPECT_EQ(a.shapes[3].delta.offset, rig.shapes[3].delta.offset);
  o.rms_cm = 0.;
  EXPECT_EQ(PerturbNeutral(rig, o).neutral, rig.neutral);
  o.wavelength_cm = 0.;
  EXPECT_THROW(PerturbNeutral(rig, o), InvalidInputError);
}

}  // namespace
}  // namespace facecap::rig
