#include "io/mesh_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include "io/image_io.h"
#include "rig/evaluate.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

using rig::Rig;
using rig::Vertices;

// An open cylinder (8 columns around, 5 rows) whose texture wraps around with a seam, so that
// glTF export must split the seam vertices and import must weld them back.
Rig CylinderRig(bool with_jaw) {
  constexpr int kColumns = 8, kRows = 5;
  Rig rig;
  rig.neutral.resize(kColumns * kRows, 3);
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c < kColumns; ++c) {
      const float angle = 2.f * static_cast<float>(M_PI) * c / kColumns;
      rig.neutral.row(r * kColumns + c) << 5.f * std::sin(angle), 2.5f * r - 5.f,
          5.f * std::cos(angle);
    }
  }
  rig.uvs.resize((kColumns + 1) * kRows, 2);
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c <= kColumns; ++c) {
      rig.uvs.row(r * (kColumns + 1) + c) << static_cast<float>(c) / kColumns,
          static_cast<float>(r) / (kRows - 1);
    }
  }
  std::vector<Eigen::Vector3i> tris, uv_tris;
  for (int r = 0; r + 1 < kRows; ++r) {
    for (int c = 0; c < kColumns; ++c) {
      const int a = r * kColumns + c, b = r * kColumns + (c + 1) % kColumns;
      const int d = a + kColumns, e = b + kColumns;
      const int ua = r * (kColumns + 1) + c, ub = ua + 1, ud = ua + kColumns + 1, ue = ud + 1;
      tris.emplace_back(a, b, e);
      uv_tris.emplace_back(ua, ub, ue);
      tris.emplace_back(a, e, d);
      uv_tris.emplace_back(ua, ue, ud);
    }
  }
  rig.triangles.resize(static_cast<int>(tris.size()), 3);
  rig.uv_triangles.resize(static_cast<int>(tris.size()), 3);
  for (size_t f = 0; f < tris.size(); ++f) {
    rig.triangles.row(f) = tris[f].transpose();
    rig.uv_triangles.row(f) = uv_tris[f].transpose();
  }
  rig.regions = {{"skin", {0.8f, 0.6f, 0.5f}}};
  rig.triangle_region = Eigen::VectorXi::Zero(rig.triangles.rows());
  rig.jaw_weights = Eigen::VectorXf::Zero(rig.NumVertices());
  if (with_jaw) {
    for (int v = 0; v < 2 * kColumns; ++v) rig.jaw_weights[v] = v < kColumns ? 1.f : 0.5f;
    rig.jaw_pivot = Eigen::Vector3f(0.f, 3.f, -4.f);
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> offset(-1.f, 1.f);
  for (const char* name : {"browInnerUp", "jawOpen", "mouthSmile_L", "jawLeft"}) {
    rig::Shape shape;
    shape.name = name;
    if (shape.name != "jawLeft") {
      for (int v = 0; v < rig.NumVertices(); v += 1 + (v % 3)) {
        shape.delta.vertex.push_back(v);
        shape.delta.offset.emplace_back(offset(rng), offset(rng), offset(rng));
      }
    }
    rig.shapes.push_back(shape);
  }
  if (with_jaw) {
    rig.shapes[1].jaw_euler = Eigen::Vector3f(0.3f, 0.f, 0.02f);
    rig.shapes[1].jaw_translation = Eigen::Vector3f(0.f, -0.3f, 0.2f);
    rig.shapes[3].jaw_euler = Eigen::Vector3f(0.f, 0.2f, 0.f);
  }
  std::string why;
  EXPECT_TRUE(rig.Check(&why)) << why;
  return rig;
}

Vertices SingleShape(const Rig& rig, int shape) {
  Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
  if (shape >= 0) w[shape] = 1.f;
  Vertices out;
  rig::EvaluateShape(rig, w, &out);
  return out;
}

// Same vertices, triangles, per-corner texture coordinates, shape names and single-shape
// evaluations S(e_i).
void ExpectSameRig(const Rig& expected, const Rig& actual, float tolerance) {
  ASSERT_EQ(actual.NumVertices(), expected.NumVertices());
  ASSERT_EQ(actual.triangles.rows(), expected.triangles.rows());
  EXPECT_LT((actual.neutral - expected.neutral).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_EQ(actual.triangles, expected.triangles);
  ASSERT_EQ(actual.uv_triangles.rows(), expected.uv_triangles.rows());
  for (int f = 0; f < expected.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_LT((actual.uvs.row(actual.uv_triangles(f, c)) -
                 expected.uvs.row(expected.uv_triangles(f, c))).cwiseAbs().maxCoeff(), 1e-6f)
          << "triangle " << f << " corner " << c;
    }
  }
  ASSERT_EQ(actual.NumShapes(), expected.NumShapes());
  for (int s = 0; s < expected.NumShapes(); ++s) {
    EXPECT_EQ(actual.shapes[s].name, expected.shapes[s].name);
    EXPECT_LT((SingleShape(actual, s) - SingleShape(expected, s)).cwiseAbs().maxCoeff(), tolerance)
        << expected.shapes[s].name;
  }
  std::string why;
  EXPECT_TRUE(actual.Check(&why)) << why;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

template <typename Fn>
std::string ErrorOf(Fn&& fn) {
  try {
    fn();
  } catch (const FileIOError& e) {
    return e.what();
  }
  return "(no FileIOError thrown)";
}

TEST(ObjTest, RigFolderRoundTrip) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(false);
  ExportRigToObjFolder(rig, tmp.File("rig"));
  const Rig back = ImportRigFromObjFolder(tmp.File("rig"));
  ExpectSameRig(rig, back, 1e-5f);
  // Without a jaw the deltas come back with the same sparsity.
  for (int s = 0; s < rig.NumShapes(); ++s) {
    EXPECT_EQ(back.shapes[s].delta.vertex, rig.shapes[s].delta.vertex) << rig.shapes[s].name;
  }
  EXPECT_EQ(back.jaw_weights.size(), rig.NumVertices());
  EXPECT_EQ(back.regions.size(), 1u);
  EXPECT_EQ(back.regions[0].name, "skin");
  EXPECT_FALSE(std::filesystem::exists(tmp.File("rig/neutral.obj.tmp")));
}

TEST(ObjTest, JawShapesAreExportedWithTheirFullEffect) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  ExportRigToObjFolder(rig, tmp.File("rig"));
  const Rig back = ImportRigFromObjFolder(tmp.File("rig"));
  ExpectSameRig(rig, back, 1e-4f);
  // jawLeft has no delta in the rig but moves the jaw: the OBJ carries that motion.
  EXPECT_FALSE(back.shapes[3].delta.vertex.empty());
}

TEST(ObjTest, ShapesSortedByNameWithoutShapeList) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(false);
  ExportRigToObjFolder(rig, tmp.path());
  std::filesystem::remove(tmp.File("shapes.txt"));
  const Rig back = ImportRigFromObjFolder(tmp.path());
  ASSERT_EQ(back.NumShapes(), 4);
  EXPECT_EQ(back.shapes[0].name, "browInnerUp");
  EXPECT_EQ(back.shapes[1].name, "jawLeft");
  EXPECT_EQ(back.shapes[2].name, "jawOpen");
  EXPECT_EQ(back.shapes[3].name, "mouthSmile_L");
}

TEST(ObjTest, DifferentVertexCountRejectedNamingTheFile) {
  testing::TempDir tmp;
  WriteText(tmp.File("neutral.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
  WriteText(tmp.File("mouthClose.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find("mouthClose.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("expected 4 vertices, got 3"), std::string::npos) << error;
}

TEST(ObjTest, DifferentFacesRejectedNamingTheFace) {
  testing::TempDir tmp;
  WriteText(tmp.File("neutral.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
  WriteText(tmp.File("cheekPuff.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\nf 1 2 3\nf 2 3 4\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find("cheekPuff.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("face 1"), std::string::npos) << error;
}

TEST(ObjTest, NaNRejectedWithFileAndLine) {
  testing::TempDir tmp;
  WriteText(tmp.File("neutral.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  WriteText(tmp.File("eyeBlink_L.obj"), "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find("eyeBlink_L.obj:2"), std::string::npos) << error;
  EXPECT_NE(error.find("vertex 1 is not finite"), std::string::npos) << error;
}

TEST(ObjTest, MissingNeutralRejected) {
  testing::TempDir tmp;
  WriteText(tmp.File("jawOpen.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find("neutral.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("missing"), std::string::npos) << error;
  EXPECT_NE(ErrorOf([&] { ImportRigFromObjFolder(tmp.File("nowhere")); }).find("nowhere"),
            std::string::npos);
}

TEST(ObjTest, DegenerateNeutralTriangleRejected) {
  testing::TempDir tmp;
  WriteText(tmp.File("neutral.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find("neutral.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("triangle 1 is degenerate"), std::string::npos) << error;
}

TEST(ObjTest, ReadsPolygonsNegativeIndicesAndCornerForms) {
  testing::TempDir tmp;
  WriteText(tmp.File("quad.obj"),
            "# a quad and a triangle\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
            "f 1/1/1 2/2/1 3/3/1 4/4/1\nf -4/-4 -2/-2 -1/-1\n");
  const Mesh mesh = ReadMeshObj(tmp.File("quad.obj"));
  ASSERT_EQ(mesh.vertices.rows(), 4);
  ASSERT_EQ(mesh.triangles.rows(), 3);
  EXPECT_EQ(mesh.triangles.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(mesh.triangles.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(mesh.triangles.row(2), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(mesh.uv_triangles.row(2), Eigen::RowVector3i(0, 2, 3));
  WriteText(tmp.File("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
  const std::string error = ErrorOf([&] { ReadMeshObj(tmp.File("bad.obj")); });
  EXPECT_NE(error.find("bad.obj:3"), std::string::npos) << error;
  EXPECT_NE(error.find("vertex 7"), std::string::npos) << error;
}

TEST(ObjTest, EmptyFileOrNoVerticesIsAnErrorNamingTheFile) {
  testing::TempDir tmp;
  WriteText(tmp.File("empty.obj"), "");
  std::string error = ErrorOf([&] { ReadMeshObj(tmp.File("empty.obj")); });
  EXPECT_NE(error.find(tmp.File("empty.obj") + ": no vertices"), std::string::npos) << error;
  WriteText(tmp.File("comments.obj"), "# only a comment\nvt 0 0\n\n");
  error = ErrorOf([&] { ReadMeshObj(tmp.File("comments.obj")); });
  EXPECT_NE(error.find(tmp.File("comments.obj") + ": no vertices"), std::string::npos) << error;
}

TEST(ObjTest, EmptyNeutralIsReportedAsNoVerticesNotAsATopologyMismatch) {
  testing::TempDir tmp;
  WriteText(tmp.File("neutral.obj"), "");
  WriteText(tmp.File("jawOpen.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string error = ErrorOf([&] { ImportRigFromObjFolder(tmp.path()); });
  EXPECT_NE(error.find(tmp.File("neutral.obj") + ": no vertices"), std::string::npos) << error;
  EXPECT_EQ(error.find("topology"), std::string::npos) << error;
}

// Indices beyond the int range wrapped around to valid vertices (4294967298 became vertex 2),
// and relative texture indices before the first one made a face silently lose its uvs.
TEST(ObjTest, IndicesOutsideTheFileAreErrorsNotWrappedOrDropped) {
  testing::TempDir tmp;
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"f 1 2 4294967298\n", "vertex 4294967298"},
      {"f 1 2 99999999999999999999999\n", "face vertex index 99999999999999999999999 is out of range"},
      {"f -1 -2 -4\n", "vertex -4 but only 3 precede it"},
      {"f 1/-2 2/-2 3/-2\n", "texture coordinate -2 but only 1 precede it"},
      {"f 1 2 -9223372036854775808\n", "vertex"},
  };
  for (const auto& [face, expected] : cases) {
    WriteText(tmp.File("bad.obj"), v + face);
    const std::string error = ErrorOf([&] { ReadMeshObj(tmp.File("bad.obj")); });
    EXPECT_NE(error.find(tmp.File("bad.obj") + ":5:"), std::string::npos) << face << error;
    EXPECT_NE(error.find(expected), std::string::npos) << face << error;
  }
}

TEST(ObjTest, NulByteInsideANumberIsAnError) {
  testing::TempDir tmp;
  const char kText[] = "v 0 0 0\nv 1\0junk 0 0\nv 0 1 0\nf 1 2 3\n";
  WriteText(tmp.File("nul.obj"), std::string(kText, sizeof(kText) - 1));
  const std::string error = ErrorOf([&] { ReadMeshObj(tmp.File("nul.obj")); });
  EXPECT_NE(error.find(tmp.File("nul.obj") + ":2: bad vertex coordinate"), std::string::npos)
      << error;
}

TEST(ObjTest, ExportRefusesForeignObjFilesAndBadNames) {
  testing::TempDir tmp;
  WriteText(tmp.File("someone_else.obj"), "v 0 0 0\n");
  EXPECT_THROW(ExportRigToObjFolder(CylinderRig(false), tmp.path()), OutputError);
  Rig rig = CylinderRig(false);
  rig.shapes[0].name = "../escape";
  EXPECT_THROW(ExportRigToObjFolder(rig, tmp.File("other")), InvalidInputError);
}

TEST(GltfTest, GlbRoundTripWeldsSeams) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  ExportRigToGltf(rig, tmp.File("face.glb"));
  const Rig back = ImportRigFromGltf(tmp.File("face.glb"));
  ExpectSameRig(rig, back, 1e-4f);
}

TEST(GltfTest, GltfRoundTripWithAnimation) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  std::vector<std::vector<float>> animation;
  for (int f = 0; f < 10; ++f) {
    animation.push_back({0.1f * f, 0.f, 1.f - 0.1f * f, 0.05f * f});
  }
  ExportRigToGltf(rig, tmp.File("face.gltf"), &animation, 24.f);
  std::ifstream in(tmp.File("face.gltf"));
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"targetNames\":[\"browInnerUp\",\"jawOpen\""), std::string::npos);
  EXPECT_NE(json.find("\"path\":\"weights\""), std::string::npos);
  const Rig back = ImportRigFromGltf(tmp.File("face.gltf"));
  ExpectSameRig(rig, back, 1e-4f);

  std::vector<std::vector<float>> wrong = {{1.f, 2.f}};
  EXPECT_THROW(ExportRigToGltf(rig, tmp.File("bad.gltf"), &wrong), InvalidInputError);
}

// A texture embedded into a .glb: assimp finds one PNG, the material's base colour points at it,
// and the PNG decodes to the very pixels given; the mesh still round-trips.
TEST(GltfTest, GlbEmbedsTheBaseColourTexture) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  Image8 texture(5, 4, 3);
  for (size_t i = 0; i < texture.data.size(); ++i) texture.data[i] = static_cast<uint8_t>(13 * i);
  ExportRigToGltf(rig, tmp.File("face.glb"), nullptr, 30.f, &texture);

  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(tmp.File("face.glb"), 0);
  ASSERT_NE(scene, nullptr) << importer.GetErrorString();
  ASSERT_EQ(scene->mNumTextures, 1u);
  const aiTexture* embedded = scene->mTextures[0];
  EXPECT_EQ(embedded->mHeight, 0u);  // compressed: the PNG's bytes
  EXPECT_TRUE(embedded->CheckFormat("png"));
  ASSERT_EQ(scene->mNumMeshes, 1u);
  const aiMaterial* material = scene->mMaterials[scene->mMeshes[0]->mMaterialIndex];
  aiString where;
  ASSERT_EQ(material->GetTexture(aiTextureType_DIFFUSE, 0, &where), aiReturn_SUCCESS);
  EXPECT_STREQ(where.C_Str(), "*0");
  WriteText(tmp.File("embedded.png"),
            std::string(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth));
  const Image8 back = ReadImage8(tmp.File("embedded.png"));
  EXPECT_EQ(back.width, 5);
  EXPECT_EQ(back.height, 4);
  EXPECT_EQ(back.data, texture.data);
  ExpectSameRig(rig, ImportRigFromGltf(tmp.File("face.glb")), 1e-4f);

  const Image8 gray(4, 4, 1);
  EXPECT_THROW(ExportRigToGltf(rig, tmp.File("bad.glb"), nullptr, 30.f, &gray), InvalidInputError);
  Rig no_uvs = CylinderRig(false);
  no_uvs.uvs.resize(0, 2);
  no_uvs.uv_triangles.resize(0, 3);
  EXPECT_THROW(ExportRigToGltf(no_uvs, tmp.File("bad.glb"), nullptr, 30.f, &texture),
               InvalidInputError);
}

// Extra meshes (secondary parts) become meshes of their own with the face's morph targets, a
// material each (a textured one and an alpha-blended one), and the animation drives them all.
TEST(GltfTest, ExtraMeshesCarryTheirOwnTargetsMaterialsAndAnimation) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  const int S = rig.NumShapes();
  Image8 iris(4, 4, 3, 200);
  std::vector<GltfExtraMesh> extra(2);
  for (int k = 0; k < 2; ++k) {
    GltfExtraMesh& m = extra[k];
    m.name = k == 0 ? "left_eyeball" : "left_cornea";
    m.neutral.resize(3, 3);
    m.neutral << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    m.triangles.resize(1, 3);
    m.triangles << 0, 1, 2;
    m.uvs.resize(3, 2);
    m.uvs << 0, 0, 1, 0, 0, 1;
    m.deltas = Eigen::MatrixXf::Zero(9, S);
    m.deltas(1, 0) = 2.f;  // vertex 0 moves 2 cm up in the first shape
  }
  extra[0].texture = &iris;
  extra[1].base_color = {1.f, 1.f, 1.f, 0.1f};
  extra[1].blend = true;
  std::vector<std::vector<float>> animation = {std::vector<float>(S, 0.f), std::vector<float>(S, 1.f)};
  ExportRigToGltf(rig, tmp.File("assembled.gltf"), &animation, 30.f, nullptr, &extra);

  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(tmp.File("assembled.gltf"), 0);
  ASSERT_NE(scene, nullptr) << importer.GetErrorString();
  ASSERT_EQ(scene->mNumMeshes, 3u);
  const aiMesh* eye = nullptr;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    if (std::string(scene->mMeshes[k]->mName.C_Str()) == "left_eyeball") eye = scene->mMeshes[k];
  }
  ASSERT_NE(eye, nullptr);
  ASSERT_EQ(eye->mNumAnimMeshes, static_cast<unsigned>(S));
  EXPECT_NEAR(eye->mAnimMeshes[0]->mVertices[0].y - eye->mVertices[0].y, 0.02f, 1e-6f);  // metres
  aiString where;
  EXPECT_EQ(scene->mMaterials[eye->mMaterialIndex]->GetTexture(aiTextureType_DIFFUSE, 0, &where), aiReturn_SUCCESS);
  std::ifstream in(tmp.File("assembled.gltf"));
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"alphaMode\":\"BLEND\""), std::string::npos);
  EXPECT_NE(json.find("{\"sampler\":0,\"target\":{\"node\":2,\"path\":\"weights\"}}"), std::string::npos);
  // The face is still the rig that imports (the mesh with the most targets and vertices).
  ExpectSameRig(rig, ImportRigFromGltf(tmp.File("assembled.gltf")), 1e-4f);

  extra[1].deltas.resize(9, S - 1);
  EXPECT_THROW(ExportRigToGltf(rig, tmp.File("bad.gltf"), nullptr, 30.f, nullptr, &extra), InvalidInputError);
}

TEST(GltfTest, MissingOrBrokenFileRejected) {
  testing::TempDir tmp;
  EXPECT_NE(ErrorOf([&] { ImportRigFromGltf(tmp.File("none.glb")); }).find("none.glb"),
            std::string::npos);
  WriteText(tmp.File("broken.gltf"), "{\"asset\": ");
  EXPECT_NE(ErrorOf([&] { ImportRigFromGltf(tmp.File("broken.gltf")); }).find("broken.gltf"),
            std::string::npos);
}

// One pose of the cylinder rig: the jaw shape at 0.8, rotated and moved.
Vertices PosedCylinder(const Rig& rig) {
  Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
  w[1] = 0.8f;
  rig::RigidPose pose;
  pose.yaw = 0.4f;
  pose.pitch = -0.2f;
  pose.translation = Eigen::Vector3f(1.f, 2.f, -3.f);
  Vertices posed;
  rig::EvaluatePosed(rig, pose, w, &posed);
  return posed;
}

TEST(PosedMeshTest, ObjHoldsThePosedVerticesWithTheRigsTrianglesAndUvs) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  const Vertices posed = PosedCylinder(rig);
  ExportPosedMesh(rig, posed, tmp.File("posed.OBJ"));
  const Mesh mesh = ReadMeshObj(tmp.File("posed.OBJ"));
  ASSERT_EQ(mesh.vertices.rows(), posed.rows());
  EXPECT_LT((mesh.vertices - posed).cwiseAbs().maxCoeff(), 1e-5f);
  EXPECT_EQ(mesh.triangles, rig.triangles);
  EXPECT_EQ(mesh.uv_triangles, rig.uv_triangles);
  EXPECT_LT((mesh.uvs - rig.uvs).cwiseAbs().maxCoeff(), 1e-6f);
}

TEST(PosedMeshTest, GltfHoldsThePosedVerticesWithoutMorphTargets) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(true);
  const Vertices posed = PosedCylinder(rig);
  for (const char* name : {"posed.glb", "posed.gltf"}) {
    ExportPosedMesh(rig, posed, tmp.File(name));
    const Rig back = ImportRigFromGltf(tmp.File(name));
    EXPECT_EQ(back.NumShapes(), 0) << name;
    ASSERT_EQ(back.NumVertices(), rig.NumVertices()) << name;  // seams welded back
    EXPECT_LT((back.neutral - posed).cwiseAbs().maxCoeff(), 1e-4f) << name;
    EXPECT_EQ(back.triangles, rig.triangles) << name;
  }
  std::ifstream in(tmp.File("posed.gltf"));
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(json.find("\"targets\""), std::string::npos);
}

TEST(PosedMeshTest, CollapsedTrianglesAreWritten) {
  // A closed eyelid collapses triangles; the pose is still a valid mesh to write.
  testing::TempDir tmp;
  const Rig rig = CylinderRig(false);
  Vertices flat = rig.neutral;
  flat.col(1).setZero();  // every triangle between two rows now has zero area
  EXPECT_NO_THROW(ExportPosedMesh(rig, flat, tmp.File("flat.glb")));
  EXPECT_NO_THROW(ExportPosedMesh(rig, flat, tmp.File("flat.obj")));
}

TEST(PosedMeshTest, BadExtensionVertexCountOrValuesRejected) {
  testing::TempDir tmp;
  const Rig rig = CylinderRig(false);
  EXPECT_THROW(ExportPosedMesh(rig, rig.neutral, tmp.File("posed.stl")), InvalidInputError);
  EXPECT_THROW(ExportPosedMesh(rig, rig.neutral, tmp.File("posed")), InvalidInputError);
  EXPECT_THROW(ExportPosedMesh(rig, rig.neutral.topRows(3), tmp.File("posed.obj")),
               InvalidInputError);
  Vertices broken = rig.neutral;
  broken(2, 1) = std::nanf("");
  EXPECT_THROW(ExportPosedMesh(rig, broken, tmp.File("posed.glb")), InvalidInputError);
  EXPECT_FALSE(std::filesystem::exists(tmp.File("posed.obj")));
  EXPECT_FALSE(std::filesystem::exists(tmp.File("posed.glb")));
}

}  // namespace
}  // namespace facecap::io
