// facecap render: a rig at a given pose and shape weights (segmentation, shaded, UV or depth)
// to PNG/EXR (and, with mesh_out, the posed mesh to OBJ or glTF), or with sheet a contact
// sheet of the neutral and expressions (segmentation and shaded side by side). A textured rig
// is drawn with its texture, a dynamic texture library with the texture of its weights.
#ifndef FACECAP_STAGES_RENDER_STAGE_H_
#define FACECAP_STAGES_RENDER_STAGE_H_

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [render]
struct RenderStageOptions {
  std::string rig = "rig.h5";            // rig file
  std::string out = "render.png";        // image file (.png, .jpg, .exr, .tif)
  std::string mode = "shaded";           // segmentation, shaded, uv or depth
  int size = 512;                        // image width and height in pixels
  float fov_deg = 20.f;                  // vertical field of view
  float pitch_deg = 0.f;                 // head pitch (positive: face down)
  float yaw_deg = 0.f;                   // head yaw (positive: towards the head's left)
  float roll_deg = 0.f;                  // head roll
  std::vector<std::string> weights;      // shape weights as name=value
  bool sheet = false;                    // contact sheet of neutral + expressions
  bool dynamic_texture = true;           // a library's texture follows the weights (strain texture)
  std::string mesh_out;                  // posed mesh (.obj, .glb, .gltf); empty: none
  int threads = 0;                       // OpenMP threads (0: all)

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5) from `facecap rig demo` or `facecap rig import`, or a textured rig "
                  "(appearance gather's output), drawn with its texture, or a dynamic texture library "
                  "(textures library), drawn with the texture of its weights (the strain texture, paper 001 Sec. 5.3)");
    v("out", out, "output image; the extension picks the format (.png, .jpg, .exr, .tif)");
    v("mode", mode, "what to draw: segmentation, shaded, uv or depth");
    v("size", size, "image width and height in pixels");
    v("fov_deg", fov_deg, "vertical field of view in degrees; the head is framed to fit");
    v("pitch_deg", pitch_deg, "head pitch in degrees (positive tilts the face down)");
    v("yaw_deg", yaw_deg, "head yaw in degrees (positive turns the face to the head's left)");
    v("roll_deg", roll_deg, "head roll in degrees");
    v("weights", weights, "shape weights as name=value, e.g. jawOpen=0.7,eyeBlinkLeft=1");
    v("sheet", sheet, "write a contact sheet: the neutral and expressions, segmentation and "
                      "shaded side by side");
    v("dynamic_texture", dynamic_texture,
      "a dynamic texture library is drawn with the albedo of each render's weights (the strain texture); false: with its "
      "static neutral albedo, to compare the two");
    v("mesh_out", mesh_out,
      "also write the posed mesh (the weights' expression rotated by pitch, yaw and roll about "
      "the rig's origin, without the camera's translation) to .obj (cm), .glb or .gltf (m); "
      "empty: none");
    v("threads", threads, "OpenMP threads for rendering (0: all available)");
  }
  bool Check(std::string* why) const {
    if (mode != "segmentation" && mode != "shaded" && mode != "uv" && mode != "depth") {
      *why = "mode must be segmentation, shaded, uv or depth, got '" + mode + "'";
      return false;
    }
    if (size < 16 || size > 8192) { *why = "size must be in [16, 8192]"; return false; }
    if (!(fov_deg > 1.f && fov_deg < 120.f)) { *why = "fov_deg must be in (1, 120)"; return false; }
    if (std::abs(pitch_deg) > 90.f || std::abs(yaw_deg) > 180.f || std::abs(roll_deg) > 180.f) {
      *why = "pose out of range (|pitch| <= 90, |yaw| <= 180, |roll| <= 180 degrees)";
      return false;
    }
    if (!mesh_out.empty()) {
      std::string extension = std::filesystem::path(mesh_out).extension().string();
      std::transform(extension.begin(), extension.end(), extension.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (extension != ".obj" && extension != ".glb" && extension != ".gltf") {
        *why = "mesh_out must end in .obj, .glb or .gltf, got '" + mesh_out + "'";
        return false;
      }
      if (sheet) {
        *why = "mesh_out writes the mesh of one render; it does not go with sheet";
        return false;
      }
    }
    return true;
  }
};

// render, rank 0 alone: the image (or the sheet) to options.out. The summary counts the files
// written on rank 0: the image, the posed mesh with mesh_out, the captions (out + .txt) with
// sheet; 0 on the other ranks, which do nothing.
StageSummary RunRender(const RenderStageOptions& options, const StageContext& ctx,
                       const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RENDER_STAGE_H_
