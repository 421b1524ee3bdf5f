#include "stages/ingested_frames.h"

#include <algorithm>
#include <cmath>

#include "io/hdf5.h"
#include "io/frames_file.h"
#include "util/errors.h"

namespace facecap::stages {

namespace {
// Coordinates beyond this (in source or crop pixels) are not those of an image.
constexpr float kMaxPixels = 1e9f;
}  // namespace

IngestedFrames IngestedFrames::Read(const std::string& path) {
  io::H5File f = io::H5File::OpenRead(path);
  IngestedFrames r;
  r.path_ = path;
  if (!f.Exists(io::frames::kCropTransform) || !f.Exists(io::frames::kFound)) {
    throw FileIOError(path + ": not an ingest output (no /frames/crop_transform and /frames/found)");
  }
  if (!f.Exists("/camera/fov_deg")) {
    throw FileIOError(path + ": no /camera/fov_deg (written by an older facecap ingest): rerun "
                      "ingest to record the camera");
  }
  const io::Shape crop = f.CheckShape(io::frames::kCrop, {-1, -1, -1, 3});
  const int64_t n = crop[0];
  if (crop[1] != crop[2] || crop[1] <= 0 || crop[1] > (1 << 16)) {
    throw FileIOError(path + ": dataset /frames/crop has shape " + io::ShapeToString(crop) +
                      ", expected square crops [*, S, S, 3] with S > 0");
  }
  r.crop_size_ = static_cast<int>(crop[2]);
  f.CheckShape(io::frames::kFound, {n});
  f.CheckShape(io::frames::kCropTransform, {n, 2, 3});
  f.CheckShape(io::frames::kLandmarks, {n, 68, 2});
  f.CheckShape(io::frames::kImageSize, {n, 2});
  f.CheckShape(io::frames::kSourceIndex, {n});
  f.CheckShape(io::frames::kTimecode, {n});
  f.CheckShape("/camera/fov_deg", {1});
  r.found_ = f.ReadVector<uint8_t>(io::frames::kFound, n);
  r.source_index_ = f.ReadVector<int64_t>(io::frames::kSourceIndex, n);
  r.timecode_ = f.ReadVector<double>(io::frames::kTimecode, n);
  r.image_size_ = f.Read<int32_t>(io::frames::kImageSize, {n, 2});
  r.crop_transform_ = f.Read<float>(io::frames::kCropTransform, {n, 2, 3});
  r.landmarks_ = f.Read<float>(io::frames::kLandmarks, {n, 68, 2});
  r.fov_deg_ = f.ReadVector<double>("/camera/fov_deg", 1)[0];
  if (!(r.fov_deg_ > 1. && r.fov_deg_ < 170.)) {
    throw FileIOError(path + ": /camera/fov_deg " + std::to_string(r.fov_deg_) + " is not in (1, 170)");
  }
  if (f.HasAttribute("/sources/files", "fps")) r.fps_ = f.GetDoubleAttribute("/sources/files", "fps");
  if (!std::isfinite(r.fps_) || r.fps_ < 0.) r.fps_ = 0.;
  for (int64_t k = 0; k < n; ++k) {
    const std::string frame = path + ": frame " + std::to_string(k);
    if (r.source_index_[k] < 0 || !std::isfinite(r.timecode_[k])) {
      throw FileIOError(frame + " has source index " + std::to_string(r.source_index_[k]) +
                        " and timecode " + std::to_string(r.timecode_[k]) +
                        " (expected an index >= 0 and a finite time)");
    }
    if (!r.found_[k]) continue;
    if (r.image_size_[2 * k] <= 0 || r.image_size_[2 * k + 1] <= 0) {
      throw FileIOError(frame + " has a face but no image size");
    }
    // A face's crop is a similarity with a scale in [1e-6, 1e6] and a translation within
    // kMaxPixels, its landmarks are within kMaxPixels: the cameras and landmarks derived from
    // them stay finite.
    const float* t = &r.crop_transform_[6 * k];
    const auto within = [](float x) { return std::isfinite(x) && std::abs(x) <= kMaxPixels; };
    const double det = static_cast<double>(t[0]) * t[4] - static_cast<double>(t[1]) * t[3];
    if (!std::all_of(t, t + 6, within) || !(det >= 1e-12 && det <= 1e12)) {
      throw FileIOError(frame + " has a face but its /frames/crop_transform is not a "
                        "similarity with a scale in [1e-6, 1e6]");
    }
    const float* l = &r.landmarks_[136 * k];
    if (!std::all_of(l, l + 136, within)) {
      throw FileIOError(frame + " has a face but landmarks that are not finite or beyond 1e9 "
                        "pixels");
    }
  }
  return r;
}

render::Camera IngestedFrames::SourceCamera(int64_t frame) const {
  return render::Camera::FromFov(image_size_[2 * frame], image_size_[2 * frame + 1],
                                 static_cast<float>(fov_deg_));
}

render::CropView IngestedFrames::CropCamera(int64_t frame, int out_size) const {
  const Eigen::Map<const Eigen::Matrix<float, 2, 3, Eigen::RowMajor>> m(&crop_transform_[6 * frame]);
  return render::CameraOfCrop(SourceCamera(frame), m, crop_size_, out_size);
}

Eigen::Matrix<float, 68, 2, Eigen::RowMajor> IngestedFrames::SourceLandmarks(int64_t frame) const {
  return Eigen::Map<const Eigen::Matrix<float, 68, 2, Eigen::RowMajor>>(&landmarks_[136 * frame]);
}

Eigen::Matrix<float, 68, 2, Eigen::RowMajor> IngestedFrames::CropLandmarks(int64_t frame,
                                                                           int out_size) const {
  const Eigen::Matrix<float, 68, 2, Eigen::RowMajor> p = SourceLandmarks(frame);
  Eigen::Matrix<float, 68, 2, Eigen::RowMajor> q;
  for (int l = 0; l < 68; ++l) q.row(l) = CropPoint(frame, p.row(l).transpose(), out_size).transpose();
  return q;
}

Eigen::Vector2f IngestedFrames::CropPoint(int64_t frame, const Eigen::Vector2f& source, int out_size) const {
  const Eigen::Map<const Eigen::Matrix<float, 2, 3, Eigen::RowMajor>> m(&crop_transform_[6 * frame]);
  const float k = static_cast<float>(out_size) / static_cast<float>(crop_size_);
  return k * (m.leftCols<2>() * source + m.col(2) + Eigen::Vector2f(0.5f, 0.5f));
}

namespace {
Eigen::Matrix3f Turn(float roll) { return rig::EulerToMatrix(Eigen::Vector3f(0.f, 0.f, roll)); }
}  // namespace

rig::RigidPose PoseInCrop(const rig::RigidPose& source_pose, const render::CropView& view) {
  rig::RigidPose p = source_pose;
  p.roll += view.roll;
  p.translation = Turn(view.roll) * source_pose.translation;
  return p;
}

rig::RigidPose PoseInSource(const rig::RigidPose& crop_pose, const render::CropView& view) {
  rig::RigidPose p = crop_pose;
  p.roll -= view.roll;
  p.translation = Turn(-view.roll) * crop_pose.translation;
  return p;
}

}  // namespace facecap::stages
