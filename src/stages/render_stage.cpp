// facecap render: a rig at a given pose and weights to PNG/EXR (and, with --mesh-out, the posed
// mesh to OBJ or glTF), or a contact sheet of the neutral and expressions (segmentation and
// shaded side by side).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "stages/render_stage.h"

#include "io/dynamic_texture_file.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "render/contact_sheet.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/rasterizer.h"
#include "render/shading.h"
#include "rig/evaluate.h"
#include "stages/rig_texture.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

constexpr float kDegToRad = static_cast<float>(M_PI / 180.0);

// Parses "name=value" items into a weight vector; names must be shapes of the rig.
Eigen::VectorXf ParseWeights(const rig::Rig& rig, const std::vector<std::string>& items) {
  Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    const std::string name = item.substr(0, eq);
    const int index = rig.ShapeIndex(name);
    if (index < 0) throw InvalidInputError("[render] weights: the rig has no shape '" + name + "'");
    float value = 1.f;
    if (eq != std::string::npos) {
      try {
        value = std::stof(item.substr(eq + 1));
      } catch (const std::exception&) {
        throw InvalidInputError("[render] weights: '" + item + "' is not name=number");
      }
    }
    if (!(value >= 0.f && value <= 1.f)) {
      throw InvalidInputError("[render] weights: " + name + " must be in [0, 1]");
    }
    w[index] = value;
  }
  return w;
}

// Camera and pose that frame the rig's neutral head in the image.
struct Framing {
  render::Camera camera;
  rig::RigidPose pose;
};

Framing FrameHead(const rig::Rig& rig, int size, float fov_deg, float pitch, float yaw,
                  float roll) {
  Framing f;
  f.camera = render::Camera::FromFov(size, size, fov_deg);
  f.pose = render::FramedPose(rig, render::FramingDistance(rig, f.camera, 0.55f), pitch, yaw, roll);
  return f;
}

// Skin-like albedo per region, chosen by the region's name, for shaded previews.
std::vector<Eigen::Vector3f> PreviewAlbedo(const rig::Rig& rig) {
  std::vector<Eigen::Vector3f> albedo;
  for (const rig::Region& r : rig.regions) {
    const std::string& n = r.name;
    auto has = [&](const char* s) { return n.find(s) != std::string::npos; };
    Eigen::Vector3f a(0.72f, 0.50f, 0.40f);  // skin
    if (has("lip")) a = {0.62f, 0.25f, 0.25f};
    if (has("mouth") || has("inner") || has("cavity")) a = {0.25f, 0.06f, 0.07f};
    if (has("brow")) a = {0.20f, 0.13f, 0.08f};
    if (has("hair") || has("scalp")) a = {0.10f, 0.07f, 0.05f};
    if (has("sclera") || (has("eye") && !has("lid") && !has("brow"))) a = {0.85f, 0.83f, 0.80f};
    if (has("iris") || has("pupil")) a = {0.18f, 0.25f, 0.35f};
    if (has("teeth")) a = {0.90f, 0.88f, 0.80f};
    albedo.push_back(a);
  }
  return albedo;
}

class Renderer {
 public:
  // texture: the rig file's own albedo texture (empty: none).
  Renderer(const rig::Rig& rig, const ImageF& texture, int threads)
      : rig_(rig), evaluator_(rig), texture_(texture) {
    raster_.num_threads = threads;
    shading_.num_threads = threads;
    shading_.albedo_source = render::AlbedoSource::kPerRegion;
    shading_.region_albedo = PreviewAlbedo(rig);
    shading_.background_color = {0.05f, 0.05f, 0.06f};
    lighting_.ambient = {0.25f, 0.25f, 0.25f};
    // A textured rig is shown with its texture. Else a rig with UVs and the 68 landmarks is
    // shown with the procedural skin albedo of the wild clips (skin tone, blotches, pores,
    // redder cheeks, lips, brows, lash lines).
    if (!texture_.empty()) {
      shading_.albedo_source = render::AlbedoSource::kTexture;
    } else if (rig.uvs.rows() > 0 && rig.uv_triangles.rows() == rig.triangles.rows() &&
               rig.landmarks.size() == 68) {
      try {
        texture_ = GenericSkinTexture(rig);
        shading_.albedo_source = render::AlbedoSource::kTexture;
      } catch (const InvalidInputError& e) {
        FC_WARN("render: no skin texture for this rig ({}); shaded per region", e.what());
      }
    }
  }

  // Replaces the albedo texture (a dynamic texture at the next pose's weights).
  void SetTexture(ImageF texture) {
    texture_ = std::move(texture);
    shading_.albedo_source = render::AlbedoSource::kTexture;
  }

  void Pose(const Framing& f, const Eigen::VectorXf& weights) {
    camera_ = f.camera;
    evaluator_.EvaluatePosed(f.pose, weights, &posed_);
    render::Rasterize(posed_, rig_.triangles, camera_, &gbuffer_, raster_);
  }
  Image8 Segmentation() {
    Image8 image;
    render::RenderSegmentation(gbuffer_, rig_.triangle_region, rig_.regions,
                               Eigen::Vector3f::Zero(), &image);
    return image;
  }
  Image8 Shaded() {
    render::VertexNormals(posed_, rig_.triangles, &normals_);
    ImageF linear;
    render::RenderShaded(gbuffer_, posed_, normals_, rig_, lighting_, shading_,
                         texture_.empty() ? nullptr : &texture_, nullptr, &linear);
    Image8 image;
    render::LinearToImage8(linear, true, &image);
    return image;
  }
  ImageF UV() {
    ImageF image;
    render::RenderUVImage(gbuffer_, rig_.uvs, rig_.uv_triangles, &image);
    return image;
  }
  ImageF Depth() {
    ImageF image;
    render::RenderDepthImage(gbuffer_, 0.f, &image);
    return image;
  }

 private:
  const rig::Rig& rig_;
  rig::RigEvaluator evaluator_;
  render::RasterizeOptions raster_;
  render::ShadingOptions shading_;
  render::Lighting lighting_;
  render::Camera camera_;
  render::GBuffer gbuffer_;
  rig::Vertices posed_, normals_;
  ImageF texture_;  // albedo texture (empty: per-region albedo)
};

// The sheet's cells: a caption and weights by shape name (absent shapes are skipped).
struct SheetCell {
  std::string caption;
  std::vector<std::pair<std::string, float>> weights;
  float yaw_deg = 0.f;
};

std::vector<SheetCell> SheetCells() {
  return {
      {"neutral", {}},
      {"jawOpen", {{"jawOpen", 1.f}}},
      {"eyeBlinkLeft+Right", {{"eyeBlinkLeft", 1.f}, {"eyeBlinkRight", 1.f}}},
      {"mouthSmileLeft+Right", {{"mouthSmileLeft", 1.f}, {"mouthSmileRight", 1.f}}},
      {"browInnerUp", {{"browInnerUp", 1.f}}},
      {"browDownLeft+Right", {{"browDownLeft", 1.f}, {"browDownRight", 1.f}}},
      {"mouthFunnel", {{"mouthFunnel", 1.f}}},
      {"mouthPucker", {{"mouthPucker", 1.f}}},
      {"jawLeft", {{"jawLeft", 1.f}}},
      {"mouthFrownLeft+Right", {{"mouthFrownLeft", 1.f}, {"mouthFrownRight", 1.f}}},
      {"eyeWideLeft+Right", {{"eyeWideLeft", 1.f}, {"eyeWideRight", 1.f}}},
      {"cheekPuff", {{"cheekPuff", 1.f}}},
      {"noseSneerLeft+Right", {{"noseSneerLeft", 1.f}, {"noseSneerRight", 1.f}}},
      {"jawOpen+mouthClose", {{"jawOpen", 0.6f}, {"mouthClose", 0.6f}}},
      {"eyeLookOutLeft+InRight", {{"eyeLookOutLeft", 1.f}, {"eyeLookInRight", 1.f}}},
      {"neutral, yaw 35", {}, 35.f},
      {"jawOpen+smile, yaw -35", {{"jawOpen", 0.5f}, {"mouthSmileLeft", 1.f}, {"mouthSmileRight", 1.f}}, -35.f},
      {"tongueOut", {{"jawOpen", 0.5f}, {"tongueOut", 1.f}}},
  };
}

}  // namespace

StageSummary RunRender(const RenderStageOptions& o, const StageContext& ctx,
                       const io::Config& /*resolved*/) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  Renderer renderer(rig, io::ReadRigTexture(o.rig), o.threads);
  // A dynamic texture library draws each render with the strain texture's albedo at its weights.
  int dynamic_size = 0;
  const std::unique_ptr<textures::RigStrainTexture> dynamic =
      o.dynamic_texture ? ReadRigDynamicTexture(o.rig, rig, &dynamic_size) : nullptr;
  auto pose = [&](const Framing& framing, const Eigen::VectorXf& w) {
    if (dynamic) {
      const std::vector<float> maps = dynamic->Evaluate(std::vector<float>(w.data(), w.data() + w.size()));
      renderer.SetTexture(io::SkinMapLayer(maps, dynamic_size, 0, 3));
    }
    renderer.Pose(framing, w);
  };
  if (!o.sheet) {
    const Eigen::VectorXf w = ParseWeights(rig, o.weights);
    const Framing framing = FrameHead(rig, o.size, o.fov_deg, o.pitch_deg * kDegToRad,
                                      o.yaw_deg * kDegToRad, o.roll_deg * kDegToRad);
    pose(framing, w);
    if (!o.mesh_out.empty()) {
      rig::RigidPose rotation = framing.pose;  // the render's rotation, at the rig's origin
      rotation.translation.setZero();
      rotation.scale = 1.f;
      rig::Vertices posed;
      rig::EvaluatePosed(rig, rotation, w, &posed);
      io::ExportPosedMesh(rig, posed, o.mesh_out);
      FC_INFO("render: posed mesh ({} vertices) -> {}", posed.rows(), o.mesh_out);
      summary.items += 1;
    }
    if (o.mode == "segmentation") io::WriteImage(o.out, renderer.Segmentation());
    if (o.mode == "shaded") io::WriteImage(o.out, renderer.Shaded());
    if (o.mode == "uv") io::WriteImage(o.out, renderer.UV());
    if (o.mode == "depth") io::WriteImage(o.out, renderer.Depth());
    FC_INFO("render: {} {}x{} -> {}", o.mode, o.size, o.size, o.out);
    summary.items += 1;
    summary.computed = summary.items;
    return summary;
  }
  const int cell = std::min(o.size, 256);
  std::vector<Image8> tiles;
  std::ostringstream captions;
  int index = 0;
  for (const SheetCell& c : SheetCells()) {
    Eigen::VectorXf w = Eigen::VectorXf::Zero(rig.NumShapes());
    bool complete = true;
    for (const auto& [name, value] : c.weights) {
      const int s = rig.ShapeIndex(name);
      if (s < 0) complete = false; else w[s] = value;
    }
    if (!complete) continue;
    pose(FrameHead(rig, cell, o.fov_deg, o.pitch_deg * kDegToRad, (o.yaw_deg + c.yaw_deg) * kDegToRad,
                   o.roll_deg * kDegToRad),
         w);
    tiles.push_back(renderer.Segmentation());
    tiles.push_back(renderer.Shaded());
    const int cell_index = index++;
    captions << "cell " << cell_index << " (row " << cell_index / 3 << ", pair " << cell_index % 3
             << "): " << c.caption << "\n";
  }
  render::ContactSheetOptions sheet_options;
  sheet_options.columns = 6;
  sheet_options.border = 2;
  sheet_options.border_value = {40, 40, 40};
  const Image8 sheet = render::ContactSheet(tiles, sheet_options);
  io::WriteImage(o.out, sheet);
  std::ofstream(o.out + ".txt") << "segmentation | shaded pairs, 3 pairs per row, left to right:\n"
                                << captions.str();
  FC_INFO("render --sheet: {} expressions -> {} (captions in {}.txt)", tiles.size() / 2, o.out,
          o.out);
  summary.items = summary.computed = 2;  // the sheet and its captions
  return summary;
}

}  // namespace facecap::stages
