#include "assets/secondary_parts.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "assets/person_rig.h"
#include "assets/scan_database.h"
#include "assets/template_shapes.h"
#include "rig/demo_head.h"
#include "util/errors.h"

namespace facecap::assets {
namespace {

struct Template {
  rig::Rig head;
  LinearShapes shapes;
  PartSet generic;
};

const Template& SmallTemplate() {
  static const Template t = [] {
    rig::DemoHeadOptions o;
    o.resolution = 60;
    o.num_identity_modes = 24;
    Template out;
    out.head = rig::MakeDemoHead(o);
    out.shapes = MakeTemplateShapes(out.head);
    out.generic = MakeGenericParts(out.head, out.shapes);
    return out;
  }();
  return t;
}

TEST(SecondaryParts, EveryPartOfThePaperIsThereWithADeltaPerShape) {
  const Template& t = SmallTemplate();
  for (const char* name : {"left_eyeball", "right_eyeball", "left_cornea", "left_upper_lashes",
                           "left_lower_lashes", "left_lacrimal", "upper_teeth", "lower_teeth",
                           "upper_gums", "lower_gums", "tongue"}) {
    const int k = t.generic.PartIndex(name);
    ASSERT_GE(k, 0) << name;
    const SecondaryPart& p = t.generic.parts[k];
    EXPECT_GT(p.triangles.rows(), 10) << name;
    EXPECT_EQ(p.deltas.rows(), 3 * p.NumVertices()) << name;
    EXPECT_EQ(p.deltas.cols(), t.shapes.NumShapes()) << name;
    EXPECT_TRUE(p.neutral.allFinite() && p.deltas.allFinite()) << name;
    EXPECT_LT(p.triangles.maxCoeff(), p.NumVertices()) << name;
  }
  // The lower teeth follow jawOpen, the upper ones stay with the skull; the eyeballs turn with
  // eyeLookUp; the upper lashes come down with a blink.
  const int open = t.shapes.ShapeIndex("jawOpen"), look = t.shapes.ShapeIndex("eyeLookUpLeft");
  const int blink = t.shapes.ShapeIndex("eyeBlinkLeft");
  EXPECT_GT(t.generic.parts[t.generic.PartIndex("lower_teeth")].deltas.col(open).cwiseAbs().maxCoeff(), 0.3f);
  EXPECT_EQ(t.generic.parts[t.generic.PartIndex("upper_teeth")].deltas.cwiseAbs().maxCoeff(), 0.f);
  EXPECT_GT(t.generic.parts[t.generic.PartIndex("left_eyeball")].deltas.col(look).cwiseAbs().maxCoeff(), 0.2f);
  const Eigen::VectorXf lash = t.generic.parts[t.generic.PartIndex("left_upper_lashes")].deltas.col(blink);
  float mean_dy = 0.f;
  for (int k = 0; k < lash.size() / 3; ++k) mean_dy += lash[3 * k + 1] / (lash.size() / 3);
  EXPECT_LT(mean_dy, -0.2f);
}

TEST(SecondaryParts, TheTemplatesOwnNeutralAndShapesFitWithZeroResidual) {
  const Template& t = SmallTemplate();
  AssemblyReport report;
  const PartSet fitted = AssembleParts(t.generic, t.shapes, t.shapes, AssemblyOptions(), &report);
  EXPECT_LT(report.placement_rms_cm, 1e-5f);
  for (float r : report.fit_rms_cm) EXPECT_LT(r, 1e-4f);
  ASSERT_EQ(fitted.parts.size(), t.generic.parts.size());
  for (size_t k = 0; k < fitted.parts.size(); ++k) {
    EXPECT_LT((fitted.parts[k].neutral - t.generic.parts[k].neutral).cwiseAbs().maxCoeff(), 1e-4f)
        << fitted.parts[k].name;
    EXPECT_LT((fitted.parts[k].deltas - t.generic.parts[k].deltas).cwiseAbs().maxCoeff(), 1e-4f)
        << fitted.parts[k].name;
  }
}

TEST(SecondaryParts, AnotherPersonsEyeballsAndLashesLandOnTheirFace) {
  const Template& t = SmallTemplate();
  const rig::Rig person_rig = PersonRig(t.head, rig::WithIdentity(t.head, 7, 1.5f).neutral);
  const LinearShapes person = MakeTemplateShapes(person_rig);
  const PartSet fitted = AssembleParts(t.generic, t.shapes, person);
  const FaceParts where = FindFaceParts(person_rig);
  // The eyeball part is the person's eyeball sphere, made larger by the clearance.
  const SecondaryPart& ball = fitted.parts[fitted.PartIndex("left_eyeball")];
  std::vector<int> all(ball.NumVertices());
  for (int k = 0; k < ball.NumVertices(); ++k) all[k] = k;
  const Sphere part = FitSphere(ball.neutral, all), face = FitSphere(person.neutral, where.eyeball[0]);
  const Sphere generic_face = FitSphere(t.head.neutral, where.eyeball[0]);
  EXPECT_GT((face.centre - generic_face.centre).norm(), 0.1f);  // the person's eyes moved
  EXPECT_LT((part.centre - face.centre).norm(), 1e-3f);
  EXPECT_NEAR(part.radius, face.radius + 0.01f, 1e-3f);
  const AssemblyChecks checks = CheckAssembly(fitted, person, where, person_rig.triangles, 50, 3, JawShapes(t.head, person));
  EXPECT_LT(checks.lash_root_mean_mm, 0.01f);
  EXPECT_LT(checks.penetration_max_mm, 0.1f);
  EXPECT_EQ(checks.jaw_shapes, 4);  // jawOpen, jawForward, jawLeft, jawRight
  EXPECT_LT(checks.teeth_jaw_max_deg, 0.5f);
  // jawOpen turns the lower teeth by the rig's jaw angle.
  const SecondaryPart& teeth = fitted.parts[fitted.PartIndex("lower_teeth")];
  const rig::Vertices open = teeth.Evaluate(Eigen::VectorXf::Unit(person.NumShapes(), person.ShapeIndex("jawOpen")));
  Eigen::Matrix3Xf a = teeth.neutral.transpose(), b = open.transpose();
  const Eigen::Matrix3f r = Eigen::umeyama(a, b, false).topLeftCorner<3, 3>();
  const float degrees = std::acos(std::min(1.f, 0.5f * (r.trace() - 1.f))) * 180.f / 3.14159265f;
  EXPECT_NEAR(degrees, rig::DemoHeadOptions().jaw_open_degrees, 0.1f);
}

TEST(SecondaryParts, ALidPushedIntoTheEyeballIsFoundAsPenetration) {
  const Template& t = SmallTemplate();
  const FaceParts where = FindFaceParts(t.head);
  LinearShapes face = t.shapes;
  const AssemblyChecks clean = CheckAssembly(t.generic, face, where, t.head.triangles, 20, 1, {});
  EXPECT_LT(clean.penetration_max_mm, 0.1f);
  // Move the upper lid margin of the left eye 1 mm towards the eyeball centre in one shape.
  const int blink = face.ShapeIndex("eyeBlinkLeft");
  const SecondaryPart& ball = t.generic.parts[t.generic.PartIndex("left_eyeball")];
  const Eigen::Vector3f centre = ball.neutral.colwise().mean().transpose();
  const int v = where.upper_margin[0][where.upper_margin[0].size() / 2];
  const Eigen::Vector3f posed = face.neutral.row(v).transpose() + face.deltas.block<3, 1>(3 * v, blink);
  const float clearance = (posed - centre).norm() - 1.21f;
  face.deltas.block<3, 1>(3 * v, blink) -= (clearance + 0.1f) * (posed - centre).normalized();
  const AssemblyChecks bad = CheckAssembly(t.generic, face, where, t.head.triangles, 0, 1, {});
  EXPECT_GT(bad.penetration_max_mm, 0.5f);
}

TEST(SecondaryParts, IrisesAreDistinctAndMatchedByTheAlbedo) {
  const Template& t = SmallTemplate();
  const auto& colors = IrisColors();
  ASSERT_GE(colors.size(), 8u);
  const ImageF tex = IrisTexture(9, 64);
  EXPECT_NEAR(tex.at(32, 32, 0), 0.01f, 1e-6f);  // pupil
  // An albedo painted with iris k's colour matches iris k.
  for (int k : {0, 5, 9}) {
    ImageF albedo(64, 64, 3);
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 64; ++x) {
        for (int c = 0; c < 3; ++c) albedo.at(x, y, c) = colors[k][c];
      }
    }
    EXPECT_EQ(MatchIris(t.head, albedo), k);
  }
  EXPECT_THROW(IrisTexture(static_cast<int>(colors.size()), 64), InvalidInputError);
}

}  // namespace
}  // namespace facecap::assets
