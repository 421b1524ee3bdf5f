// facecap render --mesh-out: the rig posed at the render's pose and weights, to OBJ and glTF.
#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "stages/render_stage.h"
#include "stages/rig_stage.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

constexpr float kDegToRad = static_cast<float>(M_PI / 180.0);

// The expected mesh: S(w) rotated by the render's angles about the rig's origin.
rig::Vertices Expected(const rig::Rig& rig, float pitch_deg, float yaw_deg,
                       const std::vector<std::pair<std::string, float>>& weights) {
  Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
  for (const auto& [name, value] : weights) {
    const int s = rig.ShapeIndex(name);
    EXPECT_GE(s, 0) << name;
    if (s >= 0) w[s] = value;
  }
  rig::RigidPose pose;
  pose.pitch = pitch_deg * kDegToRad;
  pose.yaw = yaw_deg * kDegToRad;
  pose.translation.setZero();
  rig::Vertices out;
  rig::EvaluatePosed(rig, pose, w, &out);
  return out;
}

class RenderMeshOut : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_path_ = dir_.File("rig.h5");
    RigDemoOptions demo_rig;
    demo_rig.out = rig_path_;
    RunInProcess(RunRigDemo, demo_rig, "rig.demo");
    rig_ = io::ReadRigFile(rig_path_);
  }
  std::string Render(const std::string& args) {
    return "render --rig " + rig_path_ + " --size 64 --out " + dir_.File("face.png") + " " + args;
  }
  // Render's options in-process: the rig at 64 pixels to face.png, as Render's command line.
  RenderStageOptions RenderOptions() {
    RenderStageOptions o;
    o.rig = rig_path_;
    o.size = 64;
    o.out = dir_.File("face.png");
    return o;
  }

  testing::TempDir dir_;
  std::string rig_path_;
  rig::Rig rig_;
};

TEST_F(RenderMeshOut, ObjHoldsTheRigAtTheRenderedPoseAndWeights) {
  const std::string obj = dir_.File("posed.obj");
  RenderStageOptions o = RenderOptions();
  o.yaw_deg = 30.f;
  o.pitch_deg = -10.f;
  o.weights = {"jawOpen=1", "eyeBlinkLeft=1"};
  o.mesh_out = obj;
  RunInProcess(RunRender, o, "render");
  EXPECT_TRUE(std::ifstream(dir_.File("face.png")).good()) << "the image is still written";
  const io::Mesh mesh = io::ReadMeshObj(obj);
  const rig::Vertices expected =
      Expected(rig_, -10.f, 30.f, {{"jawOpen", 1.f}, {"eyeBlinkLeft", 1.f}});
  ASSERT_EQ(mesh.vertices.rows(), expected.rows());
  EXPECT_LT((mesh.vertices - expected).cwiseAbs().maxCoeff(), 1e-3f);
  EXPECT_EQ(mesh.triangles, rig_.triangles);
  EXPECT_EQ(mesh.uv_triangles, rig_.uv_triangles);
  EXPECT_LT((mesh.uvs - rig_.uvs).cwiseAbs().maxCoeff(), 1e-6f);
  // Not the neutral: the jaw is open and the head turned.
  EXPECT_GT((mesh.vertices - rig_.neutral).cwiseAbs().maxCoeff(), 1.f);
}

TEST_F(RenderMeshOut, GlbAndGltfReimportAsTheSameStaticMesh) {
  const rig::Vertices expected = Expected(rig_, 0.f, -30.f, {{"jawOpen", 0.5f}});
  for (const char* name : {"posed.glb", "posed.gltf"}) {
    const std::string path = dir_.File(name);
    RenderStageOptions o = RenderOptions();
    o.yaw_deg = -30.f;
    o.weights = {"jawOpen=0.5"};
    o.mesh_out = path;
    RunInProcess(RunRender, o, "render");
    const rig::Rig back = io::ImportRigFromGltf(path);
    EXPECT_EQ(back.NumShapes(), 0) << name;
    EXPECT_EQ(back.triangles.rows(), rig_.triangles.rows()) << name;
    // Seam-split vertices weld back; every imported vertex is a posed one (cm after import).
    for (int v = 0; v < back.NumVertices(); v += 37) {
      const float nearest =
          (expected.rowwise() - back.neutral.row(v)).rowwise().norm().minCoeff();
      EXPECT_LT(nearest, 1e-3f) << name << " vertex " << v;
    }
    EXPECT_LT((back.neutral.colwise().maxCoeff() - expected.colwise().maxCoeff()).norm(), 1e-3f);
    EXPECT_LT((back.neutral.colwise().minCoeff() - expected.colwise().minCoeff()).norm(), 1e-3f);
  }
}

TEST_F(RenderMeshOut, OtherExtensionsAndSheetsAreUsageErrors) {
  auto bad = RunFacecap(Render("--mesh-out " + dir_.File("posed.stl")));
  EXPECT_EQ(bad.code, kExitUsage) << bad.output;
  EXPECT_NE(bad.output.find("mesh_out '" + dir_.File("posed.stl") + "' must end in .obj, .glb, .gltf"),
            std::string::npos)
      << bad.output;
  RenderStageOptions sheet = RenderOptions();
  sheet.sheet = true;
  sheet.mesh_out = dir_.File("posed.obj");
  EXPECT_THROW(RunInProcess(RunRender, sheet, "render"), InvalidInputError);
  EXPECT_FALSE(std::ifstream(dir_.File("posed.obj")).good());
}

}  // namespace
}  // namespace facecap::stages
