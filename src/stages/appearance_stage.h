// facecap appearance: the person's texture from images of their head (paper 000 Sec. 5).
//   turntable  renders of a rig over a pitch x yaw grid (Sec. 5.2), framed as ingest crops
//              footage, each with its U(I) image, triangle ids and depth; spread across ranks,
//              identical for any rank count, resumable
//   frames     tracked footage as views for gathering: each frame's image (ingest's crop) with
//              the tracked rig's U(I), triangle ids and depth in its camera, laid out as the
//              turntable's; spread across ranks, resumable
//   gather     the colours of images of those views (the turntable's own renders, or their
//              translations by a deepfake) gathered into a texture (Sec. 5.4)
#ifndef FACECAP_STAGES_APPEARANCE_STAGE_H_
#define FACECAP_STAGES_APPEARANCE_STAGE_H_

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "appearance/photon_gather.h"
#include "face/align.h"
#include "io/config.h"
#include "stages/stage.h"
#include "stages/stage_paths.h"

namespace facecap::stages {

// The rounds, threads and contact sheet of a stage that makes views (turntable, frames).
struct ViewRunOptions {
  int batch = 16;           // views per rank per round (a checkpoint per round)
  int threads = 0;          // OpenMP threads per rank (0: cores / ranks on the node)
  std::string sheet = "";   // contact sheet PNG ("": OUT with _sheet.png; "none")
  int sheet_count = 40;     // views in the sheet, evenly spread

  template <class V>
  void Visit(V&& v) {
    v("batch", batch, "views per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    v("sheet", sheet, "contact sheet PNG of the views (\"\": OUT with _sheet.png; none: no sheet)");
    v("sheet_count", sheet_count, "views in the contact sheet, evenly spread");
  }
  bool Check(std::string* why) const {
    if (batch < 1 || threads < 0 || sheet_count < 1) {
      *why = "batch and sheet_count must be positive, threads >= 0";
      return false;
    }
    return true;
  }
  // The sheet's path for output `out`, or "none".
  std::string SheetPath(const std::string& out) const {
    return sheet.empty() ? WithSuffix(out, "_sheet.png") : sheet;
  }
  void DerivedOutputs(const std::string& out, std::vector<NamedPath>* outputs) const {
    if (sheet != "none") outputs->push_back({"sheet", SheetPath(out), OutputKind::kImage});
  }
};

// [appearance.turntable]
struct AppearanceTurntableOptions {
  std::string rig = "person.h5";      // the person's rig (person fit), or any rig file
  std::string out = "turntable.h5";   // output file
  int views = 200;                    // number of views
  double pitch_min_deg = -25.;        // pitch range of the grid (deg)
  double pitch_max_deg = 25.;
  double yaw_min_deg = -70.;          // yaw range of the grid (deg)
  double yaw_max_deg = 70.;
  int size = 128;                     // render width and height (pixels)
  double fov_deg = 20.;               // vertical field of view of the camera that films the head
  double fill = 0.7;                  // fraction of the frame height the face spans when frontal
  double crop_padding = 0.4;          // ingest's crop_padding of the crops the views imitate
  double crop_raise = 0.04;           // ingest's crop_raise
  std::string texture = "";           // albedo texture file ("": a plain albedo)
  std::string texture_dataset = "/texture/albedo";  // its dataset (io/texture_file.h)
  std::string lighting = "lit";       // lit: ambient and a key light; none: the albedo itself
  bool video = false;                 // also an mp4 of the views in turntable order
  ViewRunOptions run;                 // rounds, threads, contact sheet

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "the person's rig file (HDF5, person fit's output or any rig file)");
    v("out", out, "output file (HDF5)");
    v("views", views, "number of views over the pitch x yaw grid (paper: about 200)");
    v("pitch_min_deg", pitch_min_deg, "lowest pitch of the grid (deg)");
    v("pitch_max_deg", pitch_max_deg, "highest pitch of the grid (deg)");
    v("yaw_min_deg", yaw_min_deg, "lowest yaw of the grid (deg)");
    v("yaw_max_deg", yaw_max_deg, "highest yaw of the grid (deg)");
    v("size", size, "render width and height (pixels); the deepfake's crop size");
    v("fov_deg", fov_deg, "vertical field of view of the camera that films the head (deg)");
    v("fill", fill, "fraction of the frame height the face spans when frontal");
    v("crop_padding", crop_padding, "ingest's crop_padding: views are framed as its crops");
    v("crop_raise", crop_raise, "ingest's crop_raise");
    v("texture", texture, "albedo texture file (\"\": a plain skin-coloured albedo)");
    v("texture_dataset", texture_dataset, "the texture's dataset in that file");
    v("lighting", lighting, "lit: ambient light and a key light; none: the albedo itself");
    v("video", video, "also an mp4 of the views in turntable order (OUT with .mp4, 25 fps)");
    run.Visit(v);
  }
  bool Check(std::string* why) const {
    if (views < 1) { *why = "views must be at least 1"; return false; }
    if (!(pitch_min_deg <= pitch_max_deg) || !(yaw_min_deg <= yaw_max_deg)) {
      *why = "the pitch and yaw ranges need min <= max";
      return false;
    }
    if (std::max(std::abs(pitch_min_deg), std::abs(pitch_max_deg)) >= 90. ||
        std::max(std::abs(yaw_min_deg), std::abs(yaw_max_deg)) >= 90.) {
      *why = "pitch and yaw must stay within (-90, 90) deg";
      return false;
    }
    if (size < 16) { *why = "size must be at least 16"; return false; }
    if (!(fov_deg > 1. && fov_deg < 120.)) { *why = "fov_deg must be in (1, 120)"; return false; }
    if (!(fill > 0. && fill <= 1.)) { *why = "fill must be in (0, 1]"; return false; }
    if (lighting != "lit" && lighting != "none") {
      *why = "lighting must be lit or none, not " + lighting;
      return false;
    }
    face::CropOptions crop{size, crop_padding, crop_raise};
    return crop.Check(why) && run.Check(why);
  }
  void DerivedOutputs(std::vector<NamedPath>* outputs) const {
    run.DerivedOutputs(out, outputs);
    if (video) outputs->push_back({"video", WithSuffix(out, ".mp4"), OutputKind::kVideo});
  }
};

// [appearance.frames]
struct AppearanceFramesOptions {
  std::string frames = "frames.h5";   // ingest output (crops), or a synthetic clip
  std::string dataset = "";           // image dataset ("": /frames/crop, else /frames/image)
  std::string track = "track.h5";     // track output of those frames
  std::string rig = "person.h5";      // the rig that was tracked
  std::string out = "frame_views.h5"; // output file
  ViewRunOptions run;                 // rounds, threads, contact sheet

  template <class V>
  void Visit(V&& v) {
    v("frames", frames, "ingest output (its crops), or a synthetic clip tracked in its own camera");
    v("dataset", dataset, "image dataset (\"\": /frames/crop, else /frames/image)");
    v("track", track, "track output of those frames");
    v("rig", rig, "the rig that was tracked (person fit's output)");
    v("out", out, "output file (HDF5), laid out as appearance turntable's");
    run.Visit(v);
  }
  bool Check(std::string* why) const { return run.Check(why); }
  void DerivedOutputs(std::vector<NamedPath>* outputs) const { run.DerivedOutputs(out, outputs); }
};

// [appearance.gather]
struct AppearanceGatherOptions {
  std::string views = "turntable.h5";  // appearance turntable output: U(I) of every view
  std::string images = "";             // images of those views ("": the turntable's own)
  std::string dataset = "";            // their dataset ("": /frames/translated, else /frames/image)
  std::string out = "texture.h5";      // output file
  int texture_size = 512;              // texture width and height (texels)
  int edge_margin_px = 2;              // pixels this close to the silhouette are not splatted
  int holdout_every = 0;               // views i % n == n - 1 are not splatted (0: none)
  appearance::GatherOptions gather;
  std::string exr = "";                // linear EXR of the texture ("": OUT with .exr; none)
  std::string png = "";                // sRGB PNG of the texture ("": OUT with .png; none)

  template <class V>
  void Visit(V&& v) {
    v("views", views, "appearance turntable output: U(I) and triangle ids of every view");
    v("images", images, "file with an image of every view, e.g. deepfake infer's translations "
                        "(\"\": the turntable's own renders)");
    v("dataset", dataset, "image dataset in that file (\"\": /frames/translated, else /frames/image)");
    v("out", out, "output file (HDF5), a textured rig: the views' rig under /rig, "
                  "/texture/albedo (holes filled by push-pull), /texture/confidence (0 in the "
                  "holes), /texture/particles; render, rig export and export gltf use its texture");
    v("texture_size", texture_size, "texture width and height (texels)");
    v("edge_margin_px", edge_margin_px,
      "pixels within this distance of the head's silhouette are not splatted (grazing angles, "
      "background bleeding into a translation's face)");
    v("holdout_every", holdout_every,
      "views i % n == n - 1 are not splatted, kept for evaluation (eval rerender), as deepfake "
      "train's b_holdout_every keeps them from B (0: every view is splatted)");
    v("neighbours", gather.neighbours, "particles each texel gathers (k)");
    v("max_radius_texels", gather.max_radius_texels,
      "a texel whose k-th nearest particle is farther than this stays empty (texels)");
    v("min_distance_texels", gather.min_distance_texels,
      "inverse-distance weights 1 / max(d, this): nearer particles count alike (texels)");
    v("exr", exr, "linear EXR of the texture (\"\": OUT with .exr; none: no EXR)");
    v("png", png, "sRGB PNG of the texture (\"\": OUT with .png; none: no PNG)");
  }
  bool Check(std::string* why) const {
    if (texture_size < 8 || texture_size > 8192) {
      *why = "texture_size must be in [8, 8192]";
      return false;
    }
    if (edge_margin_px < 0 || edge_margin_px > 32) {
      *why = "edge_margin_px must be in [0, 32]";
      return false;
    }
    if (holdout_every < 0 || holdout_every == 1) {
      *why = "holdout_every must be 0 (none) or at least 2";
      return false;
    }
    return gather.Check(why);
  }
  std::string ExrPath() const { return exr.empty() ? WithSuffix(out, ".exr") : exr; }
  std::string PngPath() const { return png.empty() ? WithSuffix(out, ".png") : png; }
  void DerivedOutputs(std::vector<NamedPath>* outputs) const {
    if (exr != "none") outputs->push_back({"exr", ExrPath(), OutputKind::kImage});
    if (png != "none") outputs->push_back({"png", PngPath(), OutputKind::kImage});
  }
};

// Renders the turntable's views on every rank of ctx.comm (collective): the summary counts the
// views of the output and those this run rendered (0 when the output was up to date).
StageSummary RunAppearanceTurntable(const AppearanceTurntableOptions& options,
                                    const StageContext& ctx, const io::Config& resolved);

// Renders the tracked frames' views on every rank of ctx.comm (collective): the summary counts
// the views (one per frame) and those this run rendered (0 when the output was up to date).
StageSummary RunAppearanceFrames(const AppearanceFramesOptions& options, const StageContext& ctx,
                                 const io::Config& resolved);

// Runs appearance gather on rank 0 (the other ranks return at once, with an empty summary):
// the summary counts one file, the texture, computed by this run.
StageSummary RunAppearanceGather(const AppearanceGatherOptions& options, const StageContext& ctx,
                                 const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_APPEARANCE_STAGE_H_
