#include "stages/parts_file.h"

#include <set>

#include "io/texture_file.h"
#include "render/shading.h"
#include "util/errors.h"

namespace facecap::stages {

void WriteParts(io::H5File* f, const assets::PartSet& parts, const ImageF& iris_texture) {
  std::vector<std::string> names;
  for (const auto& p : parts.parts) names.push_back(p.name);
  f->WriteStrings("/parts/names", names);
  f->WriteStrings("/parts/shape_names", parts.shape_names);
  f->SetAttribute(kPartsGroup, "iris", static_cast<int64_t>(parts.iris));
  if (!iris_texture.empty()) io::WriteColorTexture(f, "/parts/iris_texture", iris_texture);
  const int64_t N = parts.NumShapes();
  for (const auto& p : parts.parts) {
    const std::string g = std::string(kPartsGroup) + "/" + p.name;
    const int64_t V = p.NumVertices();
    f->WriteMatrix(g + "/neutral", p.neutral);
    f->WriteMatrix(g + "/triangles", p.triangles);
    f->WriteMatrix(g + "/uvs", p.uvs);
    // deltas [N, V, 3]: shape-major, as the column-major 3V x N matrix is laid out.
    f->Write<float>(g + "/deltas", {N, V, 3}, p.deltas.data());
    f->WriteVector<int32_t>(g + "/follow", std::vector<int32_t>(p.follow.begin(), p.follow.end()));
    f->SetAttribute(g, "material", p.material);
    f->SetAttribute(g, "group", static_cast<int64_t>(p.group));
  }
}

bool HasParts(const std::string& path) {
  if (!io::H5File::IsHdf5(path)) return false;
  return io::H5File::OpenRead(path).Exists("/parts/names");
}

assets::PartSet ReadParts(const std::string& path, int num_shapes, ImageF* iris_texture) {
  const io::H5File f = io::H5File::OpenRead(path);
  if (!f.Exists("/parts/names")) throw FileIOError(path + ": no secondary parts (/parts); run facecap assemble");
  assets::PartSet out;
  out.shape_names = f.ReadStrings("/parts/shape_names");
  if (static_cast<int>(out.shape_names.size()) != num_shapes) {
    throw FileIOError(path + ": /parts/shape_names has " + std::to_string(out.shape_names.size()) +
                      " shapes, the rig " + std::to_string(num_shapes));
  }
  out.iris = static_cast<int>(f.GetIntAttribute(kPartsGroup, "iris"));
  if (iris_texture) {
    *iris_texture = f.Exists("/parts/iris_texture") ? io::ReadColorTexture(path, "/parts/iris_texture") : ImageF();
  }
  for (const std::string& name : f.ReadStrings("/parts/names")) {
    const std::string g = std::string(kPartsGroup) + "/" + name;
    assets::SecondaryPart p;
    p.name = name;
    p.material = f.GetStringAttribute(g, "material");
    p.group = static_cast<int>(f.GetIntAttribute(g, "group"));
    const io::Shape ns = f.CheckShape(g + "/neutral", {-1, 3});
    const int64_t V = ns[0];
    p.neutral = f.ReadMatrix<float>(g + "/neutral");
    const io::Shape ts = f.CheckShape(g + "/triangles", {-1, 3});
    p.triangles = f.ReadMatrix<int>(g + "/triangles");
    f.CheckShape(g + "/uvs", {V, 2});
    p.uvs = f.ReadMatrix<float>(g + "/uvs");
    const std::vector<float> deltas = f.Read<float>(g + "/deltas", {num_shapes, V, 3});
    p.deltas = Eigen::Map<const Eigen::MatrixXf>(deltas.data(), 3 * V, num_shapes);
    const std::vector<int32_t> follow = f.ReadVector<int32_t>(g + "/follow", V);
    p.follow.assign(follow.begin(), follow.end());
    if (!p.neutral.allFinite() || !p.uvs.allFinite() || !p.deltas.allFinite()) {
      throw FileIOError(path + ": " + g + " holds a value that is not finite");
    }
    if (ts[0] > 0 && (p.triangles.minCoeff() < 0 || p.triangles.maxCoeff() >= V)) {
      throw FileIOError(path + ": " + g + "/triangles has a vertex index outside [0, " + std::to_string(V) + ")");
    }
    out.parts.push_back(std::move(p));
  }
  return out;
}

namespace {

// Base colour factor (linear RGBA), roughness and blending of each kind of part.
void SetMaterial(const std::string& material, io::GltfExtraMesh* m) {
  m->material = material;
  if (material == "cornea") {
    m->base_color = {1.f, 1.f, 1.f, 0.08f}, m->roughness = 0.05f, m->blend = true;
  } else if (material == "lacrimal") {
    m->base_color = {0.9f, 0.9f, 1.f, 0.3f}, m->roughness = 0.1f, m->blend = true;
  } else if (material == "lashes") {
    m->base_color = {0.03f, 0.02f, 0.015f, 1.f}, m->roughness = 0.7f;
  } else if (material == "teeth") {
    m->base_color = {0.8f, 0.77f, 0.68f, 1.f}, m->roughness = 0.3f;
  } else if (material == "gums") {
    m->base_color = {0.6f, 0.22f, 0.22f, 1.f}, m->roughness = 0.4f;
  } else if (material == "tongue") {
    m->base_color = {0.55f, 0.18f, 0.18f, 1.f}, m->roughness = 0.45f;
  } else {
    m->roughness = 0.15f;  // eye: the iris texture
  }
}

}  // namespace

PartMeshes ReadPartMeshes(const std::string& path, const rig::Rig& face) {
  PartMeshes out;
  out.face = face;
  if (!HasParts(path)) return out;
  ImageF iris;
  const assets::PartSet parts = ReadParts(path, face.NumShapes(), &iris);
  if (!iris.empty()) {
    out.iris = std::make_unique<Image8>();
    render::LinearToImage8(iris, true, out.iris.get());
  }
  // The face's own eyeballs are hidden inside the parts' (or set back behind the lids): drop them.
  try {
    const assets::FaceParts where = assets::FindFaceParts(face);
    std::set<int> ball(where.eyeball[0].begin(), where.eyeball[0].end());
    ball.insert(where.eyeball[1].begin(), where.eyeball[1].end());
    std::vector<int> keep;
    for (int f = 0; f < face.triangles.rows(); ++f) {
      if (!(ball.count(face.triangles(f, 0)) && ball.count(face.triangles(f, 1)) && ball.count(face.triangles(f, 2)))) {
        keep.push_back(f);
      }
    }
    rig::Rig& r = out.face;
    rig::Triangles t(keep.size(), 3), uvt(r.uv_triangles.rows() ? keep.size() : 0, 3);
    Eigen::VectorXi region(r.triangle_region.size() ? keep.size() : 0);
    for (size_t k = 0; k < keep.size(); ++k) {
      t.row(k) = r.triangles.row(keep[k]);
      if (uvt.rows()) uvt.row(k) = r.uv_triangles.row(keep[k]);
      if (region.size()) region[k] = r.triangle_region[keep[k]];
    }
    r.triangles = t, r.uv_triangles = uvt, r.triangle_region = region;
  } catch (const InvalidInputError&) {
    // Not the demo head's topology: the face is written whole.
  }
  for (const assets::SecondaryPart& p : parts.parts) {
    io::GltfExtraMesh m;
    m.name = p.name;
    m.neutral = p.neutral;
    m.triangles = p.triangles;
    m.uvs = p.uvs;
    m.deltas = p.deltas;
    SetMaterial(p.material, &m);
    if (p.material == "eye" && out.iris) m.texture = out.iris.get();
    out.meshes.push_back(std::move(m));
  }
  return out;
}

}  // namespace facecap::stages
