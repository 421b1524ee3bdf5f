#include "io/parts_io.h"

#include "io/texture_file.h"
#include "util/errors.h"

namespace facecap::io {

void WriteParts(H5File* f, const rig::PartSet& parts, const ImageF& iris_texture) {
  std::vector<std::string> names;
  for (const auto& p : parts.parts) names.push_back(p.name);
  f->WriteStrings("/parts/names", names);
  f->WriteStrings("/parts/shape_names", parts.shape_names);
  f->SetAttribute(kPartsGroup, "iris", static_cast<int64_t>(parts.iris));
  if (!iris_texture.empty()) WriteColorTexture(f, "/parts/iris_texture", iris_texture);
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
  if (!H5File::IsHdf5(path)) return false;
  return H5File::OpenRead(path).Exists("/parts/names");
}

rig::PartSet ReadParts(const std::string& path, int num_shapes, ImageF* iris_texture) {
  const H5File f = H5File::OpenRead(path);
  if (!f.Exists("/parts/names")) throw FileIOError(path + ": no secondary parts (/parts); run facecap assemble");
  rig::PartSet out;
  out.shape_names = f.ReadStrings("/parts/shape_names");
  if (static_cast<int>(out.shape_names.size()) != num_shapes) {
    throw FileIOError(path + ": /parts/shape_names has " + std::to_string(out.shape_names.size()) +
                      " shapes, the rig " + std::to_string(num_shapes));
  }
  out.iris = static_cast<int>(f.GetIntAttribute(kPartsGroup, "iris"));
  if (iris_texture) {
    *iris_texture = f.Exists("/parts/iris_texture") ? ReadColorTexture(path, "/parts/iris_texture") : ImageF();
  }
  for (const std::string& name : f.ReadStrings("/parts/names")) {
    const std::string g = std::string(kPartsGroup) + "/" + name;
    rig::SecondaryPart p;
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

}  // namespace facecap::io
