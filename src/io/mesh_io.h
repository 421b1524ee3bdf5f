// Meshes and rigs in OBJ and glTF 2.0.
//
// OBJ: one mesh per file (v, vt, f; polygons fan-triangulated; normals ignored), read and
// written here so that vertex order is kept exactly. A rig folder holds neutral.obj plus one
// <shape>.obj per shape with the neutral's vertices and faces; the shape's name is the file
// stem. An optional shapes.txt (one name a line) fixes the shape order; otherwise shapes are
// sorted by name.
//
// glTF: one mesh with morph targets (read through assimp, written here). Positions in a glTF
// file are metres (the glTF convention); rigs are centimetres, so import multiplies by 100 and
// export divides by 100. Texture v is flipped (glTF's origin is top-left, OBJ's and the rig's
// bottom-left).
//
// Errors: FileIOError names the file and what is wrong; InvalidInputError for bad arguments;
// OutputError when a file cannot be written. Every file is written under path + ".tmp" and
// renamed when complete.
#ifndef FACECAP_IO_MESH_IO_H_
#define FACECAP_IO_MESH_IO_H_

#include <string>
#include <vector>

#include "rig/rig.h"
#include "util/image.h"

namespace facecap::io {

// A triangle mesh as read from one file. uv_triangles has one row per triangle when uvs is
// not empty.
struct Mesh {
  rig::Vertices vertices;
  rig::Triangles triangles;
  rig::UVs uvs;
  rig::Triangles uv_triangles;
};

// Reads an OBJ file; FileIOError on malformed lines, out-of-range indices, non-finite values,
// or a file without vertices ("FILE: no vertices", also for an empty file).
Mesh ReadMeshObj(const std::string& path);

// Writes an OBJ (v, vt when uvs is given, f v/vt). uvs and uv_triangles are both null or both
// set, with uv_triangles->rows() == triangles.rows().
void ExportMeshObj(const rig::Vertices& vertices, const rig::Triangles& triangles,
                   const rig::UVs* uvs, const rig::Triangles* uv_triangles,
                   const std::string& path);

// Builds a rig from dir/neutral.obj and dir/<shape>.obj. Deltas D_i = shape - neutral are
// kept sparsely (entries with every |component| <= 1e-6 cm are dropped). Jaw weights are 0
// (OBJ has no skinning), one region "skin" covers every triangle, no landmarks. Rejects a
// shape whose vertex count or faces differ from the neutral's, non-finite coordinates, and
// degenerate neutral triangles, naming the file and the index.
rig::Rig ImportRigFromObjFolder(const std::string& dir);

// Writes dir/neutral.obj (with uvs), dir/<shape>.obj for every shape and dir/shapes.txt.
// A shape file holds the shape's full effect S(e_i) (jaw skinning applied), so that the
// folder re-imports as a jaw-free rig whose single-shape evaluations match this rig's.
// Creates dir when missing; refuses (OutputError) a dir holding other .obj files, which
// ImportRigFromObjFolder would take for shapes.
void ExportRigToObjFolder(const rig::Rig& rig, const std::string& dir);

// Reads a .gltf or .glb with morph targets. The mesh with the most morph targets is used
// (ties: the most vertices); its node's transform is applied. Target names come from the
// mesh's extras.targetNames, else the target's own name, else "shape_<i>". glTF splits
// vertices along texture seams; vertices that coincide in the base mesh and in every target
// are welded back into one rig vertex (first occurrence kept, order otherwise kept), texture
// coordinates stay per glTF vertex through uv_triangles. Jaw weights 0, one region "skin".
rig::Rig ImportRigFromGltf(const std::string& path);

// A mesh written beside a rig's face in glTF (a secondary part: eyes, teeth, ...): its own
// vertices (cm), triangles, per-vertex uvs (or none), one morph target per rig shape
// (deltas: 3#V by at least the rig's shape count, vertices interleaved, cm), and its material.
struct GltfExtraMesh {
  std::string name;
  std::string material;                          // material name (empty: the mesh's name)
  rig::Vertices neutral;
  rig::Triangles triangles;
  rig::UVs uvs;
  Eigen::MatrixXf deltas;
  Eigen::Vector4f base_color = Eigen::Vector4f::Ones();  // linear RGBA factor
  const Image8* texture = nullptr;               // base colour texture (8-bit sRGB), or none
  float roughness = 0.5f;
  bool blend = false;                            // alpha blended (cornea, lacrimal fluid)
};

// Writes glTF 2.0: a .glb (binary container) when path ends in ".glb", else a .gltf with its
// buffer embedded as a base64 data URI. One mesh, one primitive, positions (+ TEXCOORD_0 when
// the rig has uvs), one morph target per shape holding the shape's full effect S(e_i) - N:
// jaw skinning is baked into the targets because glTF morph targets are linear (a viewer
// mixing jaw shapes therefore mixes their jaw displacements linearly, not their angles).
// Target names go to mesh.extras.targetNames. When animation_weights is given (one row per
// frame, one weight per shape), a linear morph-weight animation at fps frames per second is
// added. When base_color is given (8-bit sRGB, row 0 at v = 1 as io/texture_file.h stores
// textures), it is embedded as a PNG and the primitive gets a material with it as its base
// colour texture; InvalidInputError when the rig has no UVs or the image is not RGB.
// `extra_meshes` become further nodes and meshes, each with the face's morph target names and
// its own material; the animation drives every node's weights. InvalidInputError names a
// malformed extra mesh.
void ExportRigToGltf(const rig::Rig& rig, const std::string& path,
                     const std::vector<std::vector<float>>* animation_weights = nullptr,
                     float fps = 30.f, const Image8* base_color = nullptr,
                     const std::vector<GltfExtraMesh>* extra_meshes = nullptr);

// Writes one pose of a rig as a static mesh: `posed` (#V x 3, cm, e.g. from RigEvaluator)
// with the rig's triangles and texture coordinates. The path's extension picks the format:
// .obj (as ExportMeshObj, centimetres), .glb or .gltf (as ExportRigToGltf, metres, without
// morph targets). Triangles that the pose collapses (closed eyelids) are written as they are.
// InvalidInputError for another extension, a vertex count other than the rig's, or non-finite
// positions.
void ExportPosedMesh(const rig::Rig& rig, const rig::Vertices& posed, const std::string& path);

}  // namespace facecap::io

#endif  // FACECAP_IO_MESH_IO_H_
