// facecap export livelink | gltf | overlay: tracked animation out to the formats of the tools
// that use it: a Live Link Face CSV (Unreal Engine, MetaHuman), a glTF of the rig with its
// morph-target animation, and an mp4 of the tracked rig drawn over the frames.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "render/rasterizer.h"
#include "rig/arkit.h"
#include "rig/evaluate.h"
#include "synth/appearance.h"
#include "stages/cli.h"
#include "stages/registry.h"
#include "stages/tracked_rig.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// The tracked animation: per frame pose and weights by name.
struct TrackedAnimation {
  std::vector<std::string> shape_names;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> weights;  // F x S
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> pose;                  // pitch, yaw, roll
};

// Where the animation lives in the tracking output.
struct TrackDatasets {
  std::string weights = "/track/weights";          // [F, S] in [0, 1]
  std::string shape_names = "/track/shape_names";  // [S]
  std::string pose = "/track/pose";                // [F, 3] pitch, yaw, roll (rad)

  template <class V>
  void Visit(V&& v) {
    v("weights_dataset", weights, "dataset of per-frame shape weights [frames, shapes]");
    v("shape_names_dataset", shape_names, "dataset of the shape names [shapes]");
    v("pose_dataset", pose, "dataset of per-frame head rotation [frames, 3]: pitch, yaw, roll in rad");
  }
};

TrackedAnimation ReadAnimation(const std::string& path, const TrackDatasets& d) {
  io::H5File f = io::H5File::OpenRead(path);
  TrackedAnimation a;
  a.shape_names = f.ReadStrings(d.shape_names);
  a.weights = f.ReadMatrix<float>(d.weights, -1, static_cast<int64_t>(a.shape_names.size()));
  a.pose = f.ReadMatrix<float>(d.pose, a.weights.rows(), 3);
  return a;
}

// [export.livelink]
struct ExportLiveLinkOptions {
  std::string track = "track.h5";   // tracking output
  std::string out = "take.csv";     // CSV file
  float fps = 30.f;                 // frame rate of the take
  float eye_look_deg = 25.f;        // eye rotation at eyeLook* weight 1
  TrackDatasets datasets;

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5) with per-frame weights and pose");
    v("out", out, "Live Link Face CSV file");
    v("fps", fps, "frame rate of the take (frames per second, for the timecodes)");
    v("eye_look_deg", eye_look_deg, "eye rotation in degrees at an eyeLook* weight of 1, for the "
                                    "eye yaw and pitch columns");
    datasets.Visit(v);
  }
  bool Check(std::string* why) const {
    if (!(fps > 0.f && fps <= 1000.f)) { *why = "fps must be in (0, 1000]"; return false; }
    return true;
  }
};

// [export.gltf]
struct ExportGltfOptions {
  std::string track = "track.h5";  // tracking output
  std::string rig = "rig.h5";      // the rig that was tracked
  std::string out = "take.glb";    // .glb or .gltf
  float fps = 30.f;
  TrackDatasets datasets;

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5) with per-frame weights");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("out", out, "glTF file (.glb binary or .gltf text)");
    v("fps", fps, "frame rate of the morph-target animation");
    datasets.Visit(v);
  }
  bool Check(std::string* why) const {
    if (!(fps > 0.f && fps <= 1000.f)) { *why = "fps must be in (0, 1000]"; return false; }
    return true;
  }
};

// "eyeBlinkLeft" -> "EyeBlinkLeft", as Live Link Face names its columns.
std::string LiveLinkName(const std::string& arkit) {
  std::string n = arkit;
  if (!n.empty()) n[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(n[0])));
  return n;
}

// Live Link Face's 61 value columns: the 52 ARKit shapes in its order, then head and eyes.
const std::vector<std::string>& LiveLinkShapeOrder() {
  static const std::vector<std::string> order = {
      "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
      "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
      "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
      "jawRight", "jawLeft", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthRight",
      "mouthLeft", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
      "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight",
      "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft",
      "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
      "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
      "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
      "noseSneerRight", "tongueOut"};
  return order;
}

std::string Timecode(int64_t frame, float fps) {
  const double seconds = frame / static_cast<double>(fps);
  const int64_t whole = static_cast<int64_t>(std::floor(seconds));
  const int frames_in_second = static_cast<int>(std::floor((seconds - whole) * fps + 1e-6));
  std::ostringstream os;
  os << std::setfill('0') << std::setw(2) << whole / 3600 << ":" << std::setw(2)
     << (whole / 60) % 60 << ":" << std::setw(2) << whole % 60 << ":" << std::setw(2)
     << frames_in_second << ".000";
  return os.str();
}

void RunExportLiveLink(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<ExportLiveLinkOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  const TrackedAnimation a = ReadAnimation(o.track, o.datasets);
  std::vector<int> column_of;  // value column -> shape index in the track, -1 when absent
  std::vector<std::string> missing;
  for (const std::string& name : LiveLinkShapeOrder()) {
    int index = -1;
    for (size_t s = 0; s < a.shape_names.size(); ++s) {
      if (a.shape_names[s] == name || a.shape_names[s] == LiveLinkName(name)) index = static_cast<int>(s);
    }
    if (index < 0) missing.push_back(name);
    column_of.push_back(index);
  }
  if (missing.size() == column_of.size()) {
    throw FileIOError(o.track + ": none of the 52 ARKit shape names is among the tracked shapes");
  }
  if (!missing.empty()) {
    FC_WARN("export livelink: {} ARKit shapes are not tracked and are written as 0 (first: {})",
            missing.size(), missing[0]);
  }
  auto weight = [&](int64_t f, const char* name) {
    for (size_t s = 0; s < a.shape_names.size(); ++s) {
      if (a.shape_names[s] == name) return a.weights(f, s);
    }
    return 0.f;
  };
  const float eye = o.eye_look_deg * static_cast<float>(M_PI / 180.0);
  const std::string tmp = o.out + ".partial";
  {
    std::ofstream csv(tmp);
    if (!csv) throw OutputError(o.out + ": cannot write");
    csv << "Timecode,BlendShapeCount";
    for (const std::string& name : LiveLinkShapeOrder()) csv << "," << LiveLinkName(name);
    csv << ",HeadYaw,HeadPitch,HeadRoll,LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,"
           "RightEyePitch,RightEyeRoll\n";
    csv << std::setprecision(6);
    for (int64_t f = 0; f < a.weights.rows(); ++f) {
      csv << Timecode(f, o.fps) << ",61";
      for (int index : column_of) csv << "," << (index < 0 ? 0.f : a.weights(f, index));
      // Head rotation as Live Link Face writes it: yaw, pitch, roll in radians.
      csv << "," << a.pose(f, 1) << "," << a.pose(f, 0) << "," << a.pose(f, 2);
      // Eye rotations from the eyeLook shapes (out/in: yaw, up/down: pitch).
      const float left_yaw = eye * (weight(f, "eyeLookOutLeft") - weight(f, "eyeLookInLeft"));
      const float left_pitch = eye * (weight(f, "eyeLookUpLeft") - weight(f, "eyeLookDownLeft"));
      const float right_yaw = eye * (weight(f, "eyeLookInRight") - weight(f, "eyeLookOutRight"));
      const float right_pitch = eye * (weight(f, "eyeLookUpRight") - weight(f, "eyeLookDownRight"));
      csv << "," << left_yaw << "," << left_pitch << ",0," << right_yaw << "," << right_pitch
          << ",0\n";
    }
    if (!csv) throw OutputError(o.out + ": write failed");
  }
  std::filesystem::rename(tmp, o.out);
  FC_INFO("export livelink: {} frames, 61 values per frame -> {}", a.weights.rows(), o.out);
}

void RunExportGltf(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<ExportGltfOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  const TrackedAnimation a = ReadAnimation(o.track, o.datasets);
  // Weights in the rig's shape order, matched by name.
  std::vector<std::vector<float>> animation(a.weights.rows(),
                                            std::vector<float>(rig.NumShapes(), 0.f));
  int matched = 0;
  for (int s = 0; s < rig.NumShapes(); ++s) {
    for (size_t t = 0; t < a.shape_names.size(); ++t) {
      if (a.shape_names[t] != rig.shapes[s].name) continue;
      ++matched;
      for (int64_t f = 0; f < a.weights.rows(); ++f) animation[f][s] = a.weights(f, t);
    }
  }
  if (matched == 0) {
    throw FileIOError(o.track + ": no tracked shape name matches a shape of " + o.rig);
  }
  io::ExportRigToGltf(rig, o.out, &animation, o.fps);
  FC_INFO("export gltf: {} morph targets ({} animated), {} frames at {} fps -> {}",
          rig.NumShapes(), matched, animation.size(), o.fps, o.out);
}

// [export.overlay]
struct ExportOverlayOptions {
  std::string track = "track.h5";    // tracking output (pose, translation, scale, weights)
  std::string rig = "rig.h5";        // the rig that was tracked
  std::string frames = "clip.h5";    // the frames that were tracked
  std::string frames_dataset = "";   // image dataset ("": /frames/image, then /frames/crop)
  std::string out = "overlay.mp4";   // mp4 file
  float fps = 30.f;                  // frame rate of the video
  float opacity = 0.45f;             // opacity of the segmentation colours over the frame
  int scale = 2;                     // magnification of the video (nearest neighbour)
  int count = 0;                     // frames to draw from the first (0: all tracked frames)

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5): /track/pose, translation, scale, weights");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("frames", frames, "file of the frames that were tracked (a wild clip or an ingest file)");
    v("frames_dataset", frames_dataset,
      "image dataset of the frames (empty: /frames/image, then /frames/crop)");
    v("out", out, "mp4 file: each frame with the tracked rig drawn over it");
    v("fps", fps, "frame rate of the video");
    v("opacity", opacity, "opacity of the rig's segmentation colours over the frame, in [0, 1]");
    v("scale", scale, "magnification of the video (nearest neighbour), 1 to 8");
    v("count", count, "frames to draw from the first (0: all tracked frames)");
  }
  bool Check(std::string* why) const {
    if (!(fps > 0.f && fps <= 1000.f)) { *why = "fps must be in (0, 1000]"; return false; }
    if (!(opacity >= 0.f && opacity <= 1.f)) { *why = "opacity must be in [0, 1]"; return false; }
    if (scale < 1 || scale > 8) { *why = "scale must be in [1, 8]"; return false; }
    if (count < 0) { *why = "count must be >= 0"; return false; }
    return true;
  }
};

// The frame with the posed rig drawn over it: its segmentation colours blended in at
// `opacity`, and its region borders and silhouette in white.
Image8 DrawOverlay(const Image8& frame, const render::GBuffer& g, const rig::Rig& rig,
                   float opacity) {
  Image8 out = frame;
  auto region_at = [&](int x, int y) {
    const int t = g.triangle[g.PixelIndex(x, y)];
    return t < 0 ? -1 : rig.triangle_region[t];
  };
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      const int r = region_at(x, y);
      if (r < 0) continue;
      const bool border = (x + 1 < g.width && region_at(x + 1, y) != r) ||
                          (y + 1 < g.height && region_at(x, y + 1) != r) ||
                          (x > 0 && region_at(x - 1, y) < 0) || (y > 0 && region_at(x, y - 1) < 0);
      const Eigen::Vector3f c = border ? Eigen::Vector3f::Ones() : rig.regions[r].color;
      const float a = border ? 1.f : opacity;
      for (int k = 0; k < 3; ++k) {
        const float v = (1.f - a) * frame.at(x, y, k) + a * 255.f * c[k];
        out.at(x, y, k) = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
      }
    }
  }
  return out;
}

void RunExportOverlay(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<ExportOverlayOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("export overlay: " + why);
  const rig::Rig rig = io::ReadRigFile(o.rig);
  const TrackedRig track(o.track, rig);
  const int64_t tracked = track.NumFrames();

  io::H5File frames_file = io::H5File::OpenRead(o.frames);
  std::string dataset = o.frames_dataset;
  if (dataset.empty()) {
    for (const char* name : {"/frames/image", "/frames/crop"}) {
      if (frames_file.Exists(name)) {
        dataset = name;
        break;
      }
    }
    if (dataset.empty()) {
      throw FileIOError(o.frames + ": neither /frames/image nor /frames/crop; name the dataset "
                        "with frames_dataset");
    }
  }
  const io::Shape shape = frames_file.CheckShape(dataset, {-1, -1, -1, 3});
  const int64_t count = std::min<int64_t>(o.count > 0 ? o.count : tracked, std::min(tracked, shape[0]));
  if (count < 1) throw FileIOError(o.track + ": no tracked frame to draw");
  const int H = static_cast<int>(shape[1]), W = static_cast<int>(shape[2]);
  // The tracking camera, scaled to the frames (tracking may have run on smaller targets).
  const render::Camera camera = track.CameraForWidth(W, H);

  const rig::RigEvaluator evaluator(rig);
  rig::Vertices posed;
  render::GBuffer g;
  render::RasterizeOptions raster;
  raster.barycentrics = false;
  std::vector<Image8> video;
  video.reserve(count);
  Image8 frame(W, H, 3);
  for (int64_t f = 0; f < count; ++f) {
    frames_file.ReadFrames<uint8_t>(dataset, f, 1, frame.data.data());
    if (!track.Solved(f)) {  // no face to solve there: the frame without the rig
      video.push_back(synth::UpscaleNearest(frame, o.scale));
      continue;
    }
    evaluator.EvaluatePosed(track.Pose(f), track.Weights(f), &posed);
    render::Rasterize(posed, rig.triangles, camera, &g, raster);
    video.push_back(synth::UpscaleNearest(DrawOverlay(frame, g, rig, o.opacity), o.scale));
  }
  std::filesystem::path parent = std::filesystem::path(o.out).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  const std::string codec = synth::WriteVideo(o.out, video, o.fps);
  FC_INFO("export overlay: {} frames ({}x{}, {}) -> {}", count, W * o.scale, H * o.scale, codec,
          o.out);
}

}  // namespace

void RegisterExport(CLI::App* app, AppState* state) {
  CLI::App* exp = app->add_subcommand("export", "Tracked animation to other tools' formats");
  exp->require_subcommand(1);
  AddStage<ExportLiveLinkOptions>(
      exp, state, "livelink", "export.livelink", "export livelink",
      "Live Link Face CSV: Timecode, BlendShapeCount, then 61 values per frame (the 52 ARKit "
      "shapes matched by name, head yaw/pitch/roll, eye yaw/pitch/roll)",
      RunExportLiveLink);
  AddStage<ExportGltfOptions>(
      exp, state, "gltf", "export.gltf", "export gltf",
      "glTF (.glb/.gltf) of the rig with one morph target per shape and the tracked weights as "
      "a morph-target animation",
      RunExportGltf);
  AddStage<ExportOverlayOptions>(
      exp, state, "overlay", "export.overlay", "export overlay",
      "mp4 of the tracked rig drawn over the frames it was tracked on: segmentation colours "
      "blended in, region borders and silhouette in white",
      RunExportOverlay);
}

}  // namespace facecap::stages
