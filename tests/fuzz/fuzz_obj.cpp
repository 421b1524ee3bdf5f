// Fuzz target: the OBJ reader, io::ReadMeshObj, and the OBJ rig folder import on top of it.
//
// Feeds: the input's bytes, unchanged, as an OBJ file; then the same bytes as neutral.obj of a
// rig folder that also holds them as the shape smile.obj (io::ImportRigFromObjFolder).
// Failure: a crash, a sanitizer report, an exception other than FileIOError, a FileIOError
// that does not name the file, or a mesh that is returned but breaks ReadMeshObj's promises:
// at least one vertex, every coordinate finite, every triangle and texture triangle index in
// range, one texture triangle per triangle when there are texture coordinates.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "fuzz_support.h"
#include "io/mesh_io.h"

namespace facecap::fuzz {
namespace {

void WriteBytes(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) Fail("cannot write " + path);
}

void CheckMesh(const io::Mesh& mesh) {
  const Eigen::Index V = mesh.vertices.rows(), T = mesh.uvs.rows();
  if (V == 0) Fail("a mesh without vertices was returned");
  if (!mesh.vertices.allFinite() || !mesh.uvs.allFinite()) Fail("non-finite coordinates");
  if ((mesh.triangles.array() < 0).any() || (mesh.triangles.array() >= V).any()) {
    Fail("triangle index out of range");
  }
  if (T > 0 || mesh.uv_triangles.rows() > 0) {
    if (mesh.uv_triangles.rows() != mesh.triangles.rows()) Fail("uv_triangles rows differ");
    if ((mesh.uv_triangles.array() < 0).any() || (mesh.uv_triangles.array() >= T).any()) {
      Fail("texture triangle index out of range");
    }
  }
}

}  // namespace
}  // namespace facecap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facecap;
  using namespace facecap::fuzz;
  const std::string path = ScratchPath("mesh.obj");
  WriteBytes(path, data, size);
  try {
    CheckMesh(io::ReadMeshObj(path));
  } catch (const FileIOError& e) {
    ExpectNamesFile(e, path);
  }

  const std::string dir = ScratchPath("rig");
  std::filesystem::create_directories(dir);
  const std::string neutral = dir + "/neutral.obj";
  WriteBytes(neutral, data, size);
  WriteBytes(dir + "/smile.obj", data, size);
  try {
    const rig::Rig rig = io::ImportRigFromObjFolder(dir);
    std::string why;
    if (!rig.Check(&why)) Fail("imported rig fails Check: " + why);
  } catch (const FileIOError& e) {
    if (std::string(e.what()).find(dir) == std::string::npos) {
      Fail(std::string("error does not name the rig folder's file: ") + e.what());
    }
  }
  return 0;
}
