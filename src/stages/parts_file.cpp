#include "stages/parts_file.h"

#include <set>

#include "assets/secondary_parts.h"
#include "io/parts_io.h"
#include "render/shading.h"
#include "util/errors.h"

namespace facecap::stages {

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
  if (!io::HasParts(path)) return out;
  ImageF iris;
  const rig::PartSet parts = io::ReadParts(path, face.NumShapes(), &iris);
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
  for (const rig::SecondaryPart& p : parts.parts) {
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
