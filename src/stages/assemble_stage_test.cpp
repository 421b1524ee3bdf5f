// facecap assemble and eval assembly end to end: the demo head and a tiny scan database's
// people get their secondary parts, which glTF export writes as meshes of their own, and the
// held-out people's parts meet the checks that generic parts fail.
#include <cstdlib>
#include <string>

#include <assimp/Importer.hpp>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/rig_io.h"
#include "stages/assemble_stage.h"
#include "stages/rig_stage.h"
#include "stages/scans_stage.h"
#include "testing/testing.h"

namespace facecap::stages {
namespace {

using testing::ReadText;
using testing::RunFacecap;

double Nested(const std::string& json, const std::string& object, const std::string& key) {
  return testing::NestedJsonNumber(json, object, key);
}

TEST(AssembleStage, TheDemoHeadGetsItsPartsAndExportsThemAsMeshes) {
  testing::TempDir tmp;
  RigDemoOptions demo_rig;
  demo_rig.num_identity_modes = 0;
  demo_rig.out = tmp.File("head.h5");
  RunInProcess(RunRigDemo, demo_rig, "rig.demo");
  auto r = RunFacecap("assemble --head-resolution 100 --rig " + tmp.File("head.h5") + " --out " +
                      tmp.File("assembled.h5"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("assemble: "), std::string::npos) << r.output;
  const io::H5File f = io::H5File::OpenRead(tmp.File("assembled.h5"));
  EXPECT_TRUE(f.Exists("/rig"));
  const auto names = f.ReadStrings("/parts/names");
  EXPECT_GE(names.size(), 15u);  // 2 x (eyeball, cornea, 2 lashes, lacrimal) + 4 arches + tongue
  const auto shape = f.DatasetShape("/parts/upper_teeth/deltas");
  ASSERT_EQ(shape.size(), 3u);
  EXPECT_EQ(shape[0], 52);  // one delta per shape of the rig
  EXPECT_EQ(f.GetIntAttribute("/parts", "iris"), 0);  // no albedo to match: the first iris

  RigExportOptions rig_export;
  rig_export.rig = tmp.File("assembled.h5");
  rig_export.gltf = tmp.File("assembled.glb");
  RunInProcess(RunRigExport, rig_export, "rig.export");
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(tmp.File("assembled.glb"), 0);
  ASSERT_NE(scene, nullptr) << importer.GetErrorString();
  EXPECT_EQ(scene->mNumMeshes, 1u + names.size());
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) EXPECT_EQ(scene->mMeshes[k]->mNumAnimMeshes, 52u);
  EXPECT_EQ(scene->mNumTextures, 1u);  // the iris

  // A rig of another topology is refused, naming the file and the way out.
  r = RunFacecap("assemble --head-resolution 60 --rig " + tmp.File("head.h5") + " --out " + tmp.File("bad.h5"));
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("head.h5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("head_resolution"), std::string::npos) << r.output;
}

TEST(AssembleStage, HeldOutPeoplesPartsClearTheLidsAndFollowTheJaw) {
  testing::TempDir tmp;
  ScansSynthOptions scans;
  scans.people = 4;
  scans.test_people = 2;
  scans.texture_size = 0;
  scans.threads = 1;
  scans.out = tmp.File("scans.h5");
  RunInProcess(RunScansSynth, scans, "scans.synth");
  EvalAssemblyOptions eval;
  eval.scans = tmp.File("scans.h5");
  eval.combinations = 200;
  eval.json = true;
  eval.out = tmp.File("assembly.json");
  RunInProcess(RunEvalAssembly, eval, "eval.assembly");
  const std::string text = ReadText(eval.out);
  const std::string json = text.substr(text.find("{\"people\""));
  // Assembled: lash roots on the lids, no lid inside an eyeball, lower teeth with the jaw.
  EXPECT_LT(Nested(json, "assembled", "lash_root_mean_mm"), 0.2);
  EXPECT_LT(Nested(json, "assembled", "penetration_max_mm"), 0.1);
  EXPECT_LT(Nested(json, "assembled", "teeth_jaw_max_deg"), 0.5);
  // The generic parts, not fitted to the person, leave the lashes off the lids.
  EXPECT_GT(Nested(json, "generic_parts", "lash_root_mean_mm"), 0.2);
}

}  // namespace
}  // namespace facecap::stages
