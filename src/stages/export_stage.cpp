// facecap export livelink | gltf | overlay: tracked animation out to the formats of the tools
// that use it: a Live Link Face CSV (Unreal Engine, MetaHuman), a glTF of the rig with its
// morph-target animation, and an mp4 of the tracked rig drawn over the frames.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "stages/export_stage.h"

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/dynamic_texture_file.h"
#include "io/image_io.h"
#include "io/texture_file.h"
#include "io/rig_io.h"
#include "face/frame_source.h"
#include "render/contact_sheet.h"
#include "render/landmarks.h"
#include "io/frames_file.h"
#include "stages/ingested_frames.h"
#include "render/rasterizer.h"
#include "render/shading.h"
#include "rig/arkit.h"
#include "rig/evaluate.h"
#include "synth/appearance.h"
#include "stages/parts_file.h"
#include "stages/rig_texture.h"
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

TrackedAnimation ReadAnimation(const std::string& path, const TrackDatasets& d) {
  io::H5File f = io::H5File::OpenRead(path);
  TrackedAnimation a;
  a.shape_names = f.ReadStrings(d.shape_names);
  a.weights = f.ReadMatrix<float>(d.weights, -1, static_cast<int64_t>(a.shape_names.size()));
  a.pose = f.ReadMatrix<float>(d.pose, a.weights.rows(), 3);
  return a;
}

// The frame rate of an export: the option, else the track's own, else 30.
float ExportFps(float option, const std::string& track_path) {
  if (option > 0.f) return option;
  io::H5File f = io::H5File::OpenRead(track_path);
  if (f.HasAttribute("/track", "fps")) {
    const double fps = f.GetDoubleAttribute("/track", "fps");
    if (fps > 0. && fps <= 1000.) return static_cast<float>(fps);
  }
  return 30.f;
}

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

// HH:MM:SS:FF.mmm of a time in seconds at `fps`, as Live Link Face writes it.
std::string TimecodeAt(double seconds, float fps) {
  const int64_t whole = static_cast<int64_t>(std::floor(seconds));
  const int frames_in_second = static_cast<int>(std::floor((seconds - whole) * fps + 1e-6));
  std::ostringstream os;
  os << std::setfill('0') << std::setw(2) << whole / 3600 << ":" << std::setw(2)
     << (whole / 60) % 60 << ":" << std::setw(2) << whole % 60 << ":" << std::setw(2)
     << frames_in_second << ".000";
  return os.str();
}

std::string Timecode(int64_t frame, float fps) { return TimecodeAt(frame / static_cast<double>(fps), fps); }

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

// The frame with the rig's shaded image (linear RGB, the G-buffer's size) blended in at
// `opacity` where the rig covers it.
Image8 DrawTexturedOverlay(const Image8& frame, const render::GBuffer& g, const ImageF& shaded, float opacity) {
  Image8 out = frame;
  Image8 srgb;
  render::LinearToImage8(shaded, true, &srgb);
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      if (g.triangle[g.PixelIndex(x, y)] < 0) continue;
      for (int k = 0; k < 3; ++k) {
        const float v = (1.f - opacity) * frame.at(x, y, k) + opacity * srgb.at(x, y, k);
        out.at(x, y, k) = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
      }
    }
  }
  return out;
}

// What `export overlay --texture` shades the rig with: the rig file's dynamic texture library
// at each frame's weights, else its static texture.
class OverlayTexture {
 public:
  OverlayTexture(const std::string& path, const rig::Rig& rig) : rig_(rig) {
    int size = 0;
    dynamic_ = ReadRigDynamicTexture(path, rig, &size);
    size_ = size;
    if (!dynamic_) {
      texture_ = io::ReadRigTexture(path);
      if (texture_.empty()) {
        throw FileIOError(path + ": no texture (/texture/albedo) to draw with --texture; give a textured rig "
                          "(appearance gather, textures library or infer) or draw its segmentation");
      }
    }
    lighting_.ambient = {0.35f, 0.35f, 0.35f};
    shading_.albedo_source = render::AlbedoSource::kTexture;
  }

  // The rig posed in `posed` (camera space) and rasterized with barycentrics into `g`, shaded.
  ImageF Shade(const render::GBuffer& g, const rig::Vertices& posed, const Eigen::VectorXf& weights) {
    if (dynamic_) {
      const std::vector<float> maps = dynamic_->Evaluate(std::vector<float>(weights.data(), weights.data() + weights.size()));
      texture_ = io::SkinMapLayer(maps, size_, 0, 3);
    }
    render::VertexNormals(posed, rig_.triangles, &normals_);
    ImageF linear;
    render::RenderShaded(g, posed, normals_, rig_, lighting_, shading_, &texture_, nullptr, &linear);
    return linear;
  }

 private:
  const rig::Rig& rig_;
  std::unique_ptr<textures::RigStrainTexture> dynamic_;
  int size_ = 0;
  ImageF texture_;
  rig::Vertices normals_;
  render::Lighting lighting_;
  render::ShadingOptions shading_;
};

// Reads the frames a track was made of: the source video's frames (or images) at the
// track's source indices, or an image dataset of the frames file.
class OverlayFrames {
 public:
  OverlayFrames(const std::string& path, const std::string& dataset, const TrackedRig& track) {
    file_ = io::H5File::OpenRead(path);
    dataset_ = dataset;
    const bool ingested = file_.Exists(io::frames::kCropTransform) && file_.Exists("/sources/files");
    if (dataset_.empty() && track.InSourceCamera() && ingested) {
      files_ = file_.ReadStrings("/sources/files");
      file_id_ = file_.ReadVector<int32_t>(io::frames::kSourceFileId);
      for (int32_t id : file_id_) {
        if (id < 0 || id >= static_cast<int32_t>(files_.size())) {
          throw FileIOError(path + ": /frames/source_file_id holds " + std::to_string(id) +
                            ", but /sources/files names " + std::to_string(files_.size()) +
                            " files");
        }
      }
      if (files_.size() == 1 && file_.GetDoubleAttribute("/sources/files", "fps") > 0.) {
        video_ = face::FrameSource::OpenVideo(files_[0], kMaxPixels);
      }
      return;
    }
    if (dataset_.empty()) {
      for (const char* name : {io::frames::kImage, io::frames::kCrop}) {
        if (file_.Exists(name)) {
          dataset_ = name;
          break;
        }
      }
      if (dataset_.empty()) {
        throw FileIOError(path + ": neither /frames/image nor /frames/crop; name the dataset "
                          "with frames_dataset");
      }
    }
    const io::Shape shape = file_.CheckShape(dataset_, {-1, -1, -1, 3});
    frames_ = shape[0];
    buffer_ = Image8(static_cast<int>(shape[2]), static_cast<int>(shape[1]), 3);
    // A track of crops drawn over the crops: each frame in its crop's camera.
    if (track.InSourceCamera() && ingested && dataset_ == io::frames::kCrop) {
      ingested_ = std::make_unique<IngestedFrames>(IngestedFrames::Read(path));
    }
  }
  bool FromSource() const { return !files_.empty(); }
  int64_t NumFrames() const { return FromSource() ? static_cast<int64_t>(file_id_.size()) : frames_; }
  // Frame `f` (the k-th tracked frame, with its source index); empty when unreadable.
  Image8 Read(int64_t f, int64_t source_index) {
    if (!FromSource()) {
      file_.ReadFrames<uint8_t>(dataset_, f, 1, buffer_.data.data());
      return buffer_;
    }
    const face::DecodedFrame d =
        video_ ? video_->Read(source_index) : face::ReadImageFile(files_.at(file_id_[f]), kMaxPixels);
    return d.ok ? d.image : Image8();
  }
  // The camera frame `f` is drawn with, and the pose of the track moved into it.
  render::Camera Camera(const TrackedRig& track, int64_t f, const Image8& image,
                        rig::RigidPose* pose) const {
    if (ingested_) {
      const render::CropView view = ingested_->CropCamera(f, image.width);
      *pose = PoseInCrop(*pose, view);
      return view.camera;
    }
    return track.CameraForWidth(image.width, image.height);
  }

 private:
  static constexpr int64_t kMaxPixels = 40000000;
  io::H5File file_;
  std::string dataset_;
  int64_t frames_ = 0;
  Image8 buffer_;
  std::vector<std::string> files_;
  std::vector<int32_t> file_id_;
  std::unique_ptr<face::FrameSource> video_;
  std::unique_ptr<IngestedFrames> ingested_;
};

}  // namespace

StageSummary RunExportLiveLink(const ExportLiveLinkOptions& o, const StageContext& ctx,
                               const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "frames", 0, 0};
  const TrackedAnimation a = ReadAnimation(o.track, o.datasets);
  const float fps = ExportFps(o.fps, o.track);
  // Timecodes of the source video's frames when the track has them (a stride or a time range
  // of ingest keeps them right), else frame / fps.
  std::vector<double> seconds;
  {
    io::H5File f = io::H5File::OpenRead(o.track);
    if (f.Exists("/track/timecode")) seconds = f.ReadVector<double>("/track/timecode", a.weights.rows());
  }
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
      csv << (seconds.empty() || seconds[f] < 0. ? Timecode(f, fps) : TimecodeAt(seconds[f], fps))
          << ",61";
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
  return StageSummary{o.out, "frames", a.weights.rows(), a.weights.rows()};
}

StageSummary RunExportGltf(const ExportGltfOptions& o, const StageContext& ctx,
                           const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "frames", 0, 0};
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
  const float fps = ExportFps(o.fps, o.track);
  const Image8 texture = ReadRigTextureSrgb(o.rig);
  const PartMeshes parts = ReadPartMeshes(o.rig, rig);
  io::ExportRigToGltf(parts.face, o.out, &animation, fps, texture.empty() ? nullptr : &texture, &parts.meshes);
  FC_INFO("export gltf: {} morph targets ({} animated), {} frames at {} fps{}{} -> {}",
          rig.NumShapes(), matched, animation.size(), fps,
          texture.empty() ? "" : ", the rig file's texture",
          parts.meshes.empty() ? "" : ", " + std::to_string(parts.meshes.size()) + " secondary parts", o.out);
  const int64_t frames = static_cast<int64_t>(animation.size());
  return StageSummary{o.out, "frames", frames, frames};
}

StageSummary RunExportOverlay(const ExportOverlayOptions& o, const StageContext& ctx,
                              const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "frames", 0, 0};
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("export overlay: " + why);
  const rig::Rig rig = io::ReadRigFile(o.rig);
  const TrackedRig track(o.track, rig);
  const int64_t tracked = track.NumFrames();
  OverlayFrames source(o.frames, o.frames_dataset, track);
  const int64_t count =
      std::min<int64_t>(o.count > 0 ? o.count : tracked, std::min(tracked, source.NumFrames()));
  if (count < 1) throw FileIOError(o.track + ": no tracked frame to draw");

  const rig::RigEvaluator evaluator(rig);
  rig::Vertices posed;
  render::GBuffer g;
  render::RasterizeOptions raster;
  raster.barycentrics = o.texture;
  std::unique_ptr<OverlayTexture> shade = o.texture ? std::make_unique<OverlayTexture>(o.rig, rig) : nullptr;
  std::vector<Image8> video;
  video.reserve(count);
  int factor = o.scale;
  int width = 0, height = 0;
  for (int64_t f = 0; f < count; ++f) {
    Image8 frame = source.Read(f, track.InSourceCamera() ? track.SourceIndex(f) : f);
    if (frame.empty()) {  // unreadable: a black frame of the video's size
      frame = Image8(std::max(width, 1), std::max(height, 1), 3);
    }
    if (width == 0) {
      width = frame.width;
      height = frame.height;
      if (factor == 0) factor = std::max(width, height) < 256 ? 2 : 1;
    }
    if (frame.width != width || frame.height != height) {
      throw FileIOError(o.frames + ": frame " + std::to_string(f) + " is " +
                        std::to_string(frame.width) + "x" + std::to_string(frame.height) +
                        ", the first was " + std::to_string(width) + "x" + std::to_string(height) +
                        ": an mp4 needs frames of one size");
    }
    if (track.Solved(f)) {  // else no face to solve there: the frame without the rig
      rig::RigidPose pose = track.Pose(f);
      const render::Camera camera = source.Camera(track, f, frame, &pose);
      evaluator.EvaluatePosed(pose, track.Weights(f), &posed);
      render::Rasterize(posed, rig.triangles, camera, &g, raster);
      frame = shade ? DrawTexturedOverlay(frame, g, shade->Shade(g, posed, track.Weights(f)), o.opacity)
                    : DrawOverlay(frame, g, rig, o.opacity);
    }
    video.push_back(synth::UpscaleNearest(frame, factor));
  }
  std::filesystem::path parent = std::filesystem::path(o.out).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  const float fps = ExportFps(o.fps, o.track);
  const std::string codec = synth::WriteVideo(o.out, video, fps);
  FC_INFO("export overlay: {} frames ({}x{}, {}, {} fps) -> {}", count, width * factor,
          height * factor, codec, fps, o.out);
  if (!o.sheet.empty()) {
    std::vector<Image8> tiles;
    const int n = static_cast<int>(std::min<int64_t>(o.sheet_count, count));
    for (int k = 0; k < n; ++k) tiles.push_back(video[(count - 1) * k / std::max(1, n - 1)]);
    io::WriteImage(o.sheet, render::ContactSheet(tiles));
    FC_INFO("export overlay: contact sheet of {} frames -> {}", n, o.sheet);
  }
  return StageSummary{o.out, "frames", count, count};
}

StageSummary RunExportLandmarks(const ExportLandmarksOptions& o, const StageContext& ctx,
                                const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "frames", 0, 0};
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("export landmarks: " + why);
  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (rig.landmarks.size() != 68) throw FileIOError(o.rig + ": the rig has no 68 landmarks");
  const TrackedRig track(o.track, rig);
  const IngestedFrames frames = IngestedFrames::Read(o.frames);
  if (!track.InSourceCamera()) {
    throw FileIOError(o.track + ": not a track of an ingest output's crops (made without "
                      "track --frames), so its camera is not the source video's");
  }
  if (track.NumFrames() != frames.NumFrames()) {
    throw FileIOError(o.track + " has " + std::to_string(track.NumFrames()) + " frames, " +
                      o.frames + " has " + std::to_string(frames.NumFrames()));
  }
  const rig::RigEvaluator evaluator(rig);
  rig::Vertices posed;
  render::GBuffer g;
  render::RasterizeOptions raster;
  raster.barycentrics = false;
  std::vector<render::Landmark2D> projected;
  const std::string tmp = o.out + ".partial";
  int64_t written = 0;
  {
    std::ofstream csv(tmp);
    if (!csv) throw OutputError(o.out + ": cannot write");
    csv << "source_index,timecode";
    for (const char* axis : {"x", "y", "visible"}) {
      for (int l = 0; l < 68; ++l) csv << "," << axis << "_" << l;
    }
    csv << "\n" << std::fixed;
    for (int64_t f = 0; f < frames.NumFrames(); ++f) {
      csv << frames.SourceIndex(f) << "," << std::setprecision(4) << frames.Timecode(f);
      if (!frames.Found(f) || !track.Solved(f)) {
        for (int k = 0; k < 3 * 68; ++k) csv << ",";
        csv << "\n";
        continue;
      }
      const render::Camera camera = frames.SourceCamera(f);
      evaluator.EvaluatePosed(track.Pose(f), track.Weights(f), &posed);
      render::Rasterize(posed, rig.triangles, camera, &g, raster);
      render::ProjectLandmarks(posed, rig.triangles, rig.landmarks, camera, g, &projected);
      csv << std::setprecision(3);
      // Camera coordinates put pixel centres at i + 0.5; the CSV at i, as ingest's landmarks.
      for (int axis = 0; axis < 2; ++axis) {
        for (int l = 0; l < 68; ++l) csv << "," << projected[l].position[axis] - 0.5f;
      }
      for (int l = 0; l < 68; ++l) csv << "," << (projected[l].visible ? 1 : 0);
      csv << "\n";
      ++written;
    }
    if (!csv) throw OutputError(o.out + ": write failed");
  }
  std::filesystem::rename(tmp, o.out);
  FC_INFO("export landmarks: {} frames ({} with landmarks) -> {}", frames.NumFrames(), written, o.out);
  return StageSummary{o.out, "frames", frames.NumFrames(), frames.NumFrames()};
}

}  // namespace facecap::stages
