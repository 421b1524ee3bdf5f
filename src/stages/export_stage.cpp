// facecap export livelink | gltf: tracked animation out to the formats of the tools that use
// it: a Live Link Face CSV (Unreal Engine, MetaHuman) and a glTF of the rig with its morph-target
// animation.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "rig/arkit.h"
#include "stages/cli.h"
#include "stages/registry.h"
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
}

}  // namespace facecap::stages
