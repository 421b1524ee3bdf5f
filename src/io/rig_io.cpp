#include "io/rig_io.h"

#include "util/errors.h"

namespace facecap::io {

void WriteRig(const rig::Rig& rig, H5File* file, const std::string& group) {
  const std::string g = group + "/";
  const int64_t V = rig.NumVertices(), S = rig.NumShapes();
  file->WriteMatrix(g + "neutral", rig.neutral);
  file->SetAttribute(g + "neutral", "units", std::string("cm"));
  file->WriteMatrix(g + "triangles", rig.triangles);
  file->WriteMatrix(g + "uvs", rig.uvs);
  file->WriteMatrix(g + "uv_triangles", rig.uv_triangles);
  file->Write<int32_t>(g + "triangle_region", {rig.triangle_region.size()},
                       rig.triangle_region.data());
  std::vector<std::string> region_names;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> colors(rig.regions.size(), 3);
  for (size_t r = 0; r < rig.regions.size(); ++r) {
    region_names.push_back(rig.regions[r].name);
    colors.row(r) = rig.regions[r].color.transpose();
  }
  file->WriteStrings(g + "regions/names", region_names);
  file->WriteMatrix(g + "regions/colors", colors);
  file->Write<float>(g + "jaw/weights", {V}, rig.jaw_weights.data());
  file->Write<float>(g + "jaw/pivot", {3}, rig.jaw_pivot.data());
  file->SetAttribute(g + "jaw/pivot", "units", std::string("cm"));

  std::vector<std::string> names;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> euler(S, 3), translation(S, 3);
  std::vector<int64_t> row_offsets{0};
  std::vector<int32_t> vertex;
  std::vector<float> offset;
  for (int s = 0; s < S; ++s) {
    const rig::Shape& shape = rig.shapes[s];
    names.push_back(shape.name);
    euler.row(s) = shape.jaw_euler.transpose();
    translation.row(s) = shape.jaw_translation.transpose();
    for (size_t k = 0; k < shape.delta.vertex.size(); ++k) {
      vertex.push_back(shape.delta.vertex[k]);
      for (int c = 0; c < 3; ++c) offset.push_back(shape.delta.offset[k][c]);
    }
    row_offsets.push_back(static_cast<int64_t>(vertex.size()));
  }
  file->WriteStrings(g + "shapes/names", names);
  file->WriteMatrix(g + "shapes/jaw_euler", euler);
  file->SetAttribute(g + "shapes/jaw_euler", "units", std::string("rad"));
  file->WriteMatrix(g + "shapes/jaw_translation", translation);
  file->WriteVector(g + "shapes/deltas/row_offsets", row_offsets);
  file->WriteVector(g + "shapes/deltas/vertex", vertex);
  file->Write<float>(g + "shapes/deltas/offset", {static_cast<int64_t>(vertex.size()), 3},
                     offset.data());
  file->Write<int32_t>(g + "landmarks", {rig.landmarks.size()}, rig.landmarks.data());
  file->SetAttribute(g + "landmarks", "order", std::string("iBUG 300-W 68 points"));
  const int64_t K = static_cast<int64_t>(rig.identity_modes.size());
  std::vector<float> modes;
  modes.reserve(K * V * 3);
  for (const auto& m : rig.identity_modes) modes.insert(modes.end(), m.data(), m.data() + V * 3);
  file->Write<float>(g + "identity_modes", {K, V, 3}, modes.data());
}

rig::Rig ReadRig(const H5File& file, const std::string& group) {
  const std::string g = group + "/";
  rig::Rig rig;
  auto neutral = file.ReadMatrix<float>(g + "neutral", -1, 3);
  rig.neutral = neutral;
  const int64_t V = rig.neutral.rows();
  rig.triangles = file.ReadMatrix<int32_t>(g + "triangles", -1, 3);
  const int64_t F = rig.triangles.rows();
  rig.uvs = file.ReadMatrix<float>(g + "uvs", -1, 2);
  rig.uv_triangles = file.ReadMatrix<int32_t>(g + "uv_triangles", rig.uvs.rows() ? F : 0, 3);
  auto region = file.ReadVector<int32_t>(g + "triangle_region", F);
  rig.triangle_region = Eigen::Map<Eigen::VectorXi>(region.data(), F);
  auto region_names = file.ReadStrings(g + "regions/names");
  auto colors = file.ReadMatrix<float>(g + "regions/colors", region_names.size(), 3);
  for (size_t r = 0; r < region_names.size(); ++r) {
    rig.regions.push_back({region_names[r], colors.row(r).transpose()});
  }
  auto jaw = file.ReadVector<float>(g + "jaw/weights", V);
  rig.jaw_weights = Eigen::Map<Eigen::VectorXf>(jaw.data(), V);
  auto pivot = file.ReadVector<float>(g + "jaw/pivot", 3);
  rig.jaw_pivot = Eigen::Vector3f(pivot[0], pivot[1], pivot[2]);

  auto names = file.ReadStrings(g + "shapes/names");
  const int64_t S = static_cast<int64_t>(names.size());
  auto euler = file.ReadMatrix<float>(g + "shapes/jaw_euler", S, 3);
  auto translation = file.ReadMatrix<float>(g + "shapes/jaw_translation", S, 3);
  auto row_offsets = file.ReadVector<int64_t>(g + "shapes/deltas/row_offsets", S + 1);
  auto vertex = file.ReadVector<int32_t>(g + "shapes/deltas/vertex");
  auto offset = file.Read<float>(g + "shapes/deltas/offset",
                                 {static_cast<int64_t>(vertex.size()), 3});
  for (int64_t s = 0; s < S; ++s) {
    rig::Shape shape;
    shape.name = names[s];
    shape.jaw_euler = euler.row(s).transpose();
    shape.jaw_translation = translation.row(s).transpose();
    const int64_t begin = row_offsets[s], end = row_offsets[s + 1];
    if (begin < 0 || end < begin || end > static_cast<int64_t>(vertex.size())) {
      throw FileIOError(file.path() + ": " + g + "shapes/deltas/row_offsets is inconsistent at shape " +
                        shape.name);
    }
    for (int64_t k = begin; k < end; ++k) {
      shape.delta.vertex.push_back(vertex[k]);
      shape.delta.offset.emplace_back(offset[3 * k], offset[3 * k + 1], offset[3 * k + 2]);
    }
    rig.shapes.push_back(std::move(shape));
  }
  auto landmarks = file.ReadVector<int32_t>(g + "landmarks");
  rig.landmarks = Eigen::Map<Eigen::VectorXi>(landmarks.data(), landmarks.size());
  Shape mode_shape;
  auto modes = file.Read<float>(g + "identity_modes", {-1, V, 3}, &mode_shape);
  for (int64_t k = 0; k < mode_shape[0]; ++k) {
    rig::Vertices m(V, 3);
    std::copy(modes.begin() + k * V * 3, modes.begin() + (k + 1) * V * 3, m.data());
    rig.identity_modes.push_back(std::move(m));
  }
  std::string why;
  if (!rig.Check(&why)) throw FileIOError(file.path() + ": rig in " + group + " is invalid: " + why);
  return rig;
}

rig::Rig ReadRigFile(const std::string& path, const std::string& group) {
  H5File file = H5File::OpenRead(path);
  return ReadRig(file, group);
}

}  // namespace facecap::io
