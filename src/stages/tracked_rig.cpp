#include "stages/tracked_rig.h"

#include <algorithm>
#include <cmath>

#include "io/hdf5.h"
#include "io/camera_file.h"
#include "util/errors.h"

namespace facecap::stages {

namespace {

// Whether every value of frame `f` (a row of a row-major [n, cols] matrix) is finite.
template <typename Matrix>
bool RowFinite(const Matrix& m, int64_t f) {
  return m.row(static_cast<Eigen::Index>(f)).allFinite();
}

}  // namespace

TrackedRig::TrackedRig(const std::string& path, const rig::Rig& rig) : num_rig_shapes_(rig.NumShapes()) {
  io::H5File track = io::H5File::OpenRead(path);
  const auto fail = [&](const std::string& what) { throw FileIOError(path + ": " + what); };
  const std::vector<std::string> names = track.ReadStrings("/track/shape_names");
  // The frame count is /track/pose's; every per-frame dataset has as many rows, and
  // /track/weights one column per tracked shape name.
  const int64_t n = track.CheckShape("/track/pose", {-1, 3})[0];
  pose_ = track.ReadMatrix<float>("/track/pose", n, 3);
  translation_ = track.ReadMatrix<float>("/track/translation", n, 3);
  scale_ = track.ReadVector<float>("/track/scale", n);
  weights_ = track.ReadMatrix<float>("/track/weights", n, static_cast<int64_t>(names.size()));
  if (track.Exists("/track/termination")) termination_ = track.ReadVector<int32_t>("/track/termination", n);
  for (int64_t f = 0; f < n; ++f) {
    if (!RowFinite(pose_, f) || !RowFinite(translation_, f) || !std::isfinite(scale_[f]) ||
        !(scale_[f] > 0.f) || !RowFinite(weights_, f)) {
      fail("frame " + std::to_string(f) +
           " has a pose, translation, scale or weight that is not finite (or a scale <= 0)");
    }
  }
  shape_of_.resize(names.size());
  for (size_t t = 0; t < names.size(); ++t) {
    if (std::find(names.begin(), names.begin() + t, names[t]) != names.begin() + t) {
      fail("/track/shape_names names shape '" + names[t] + "' twice");
    }
    shape_of_[t] = rig.ShapeIndex(names[t]);
  }
  const io::CameraRecord camera = io::ReadCamera(track);
  intrinsics_ = {camera.fx, camera.fy, camera.cx, camera.cy};
  // Pixel quantities beyond 1e9 are not those of an image; the scaled cameras stay finite.
  const auto within = [](double x) { return std::isfinite(x) && std::abs(x) <= 1e9; };
  if (!std::all_of(intrinsics_.begin(), intrinsics_.end(), within) || !(intrinsics_[0] > 0.) ||
      !(intrinsics_[1] > 0.)) {
    fail("/camera/intrinsics (fx, fy, cx, cy) must be finite pixels with positive focal lengths");
  }
  has_width_ = camera.width.has_value();
  if (track.HasAttribute("/track", "fps")) fps_ = track.GetDoubleAttribute("/track", "fps");
  if (!std::isfinite(fps_) || fps_ < 0.) fps_ = 0.;
  if (track.Exists("/track/source_index")) {
    source_index_ = track.ReadVector<int64_t>("/track/source_index", n);
    timecode_ = track.ReadVector<double>("/track/timecode", n);
    for (int64_t f = 0; f < n; ++f) {
      if (source_index_[f] < 0 || !std::isfinite(timecode_[f])) {
        fail("frame " + std::to_string(f) + " has source index " +
             std::to_string(source_index_[f]) + " and timecode " +
             std::to_string(timecode_[f]) + " (expected an index >= 0 and a finite time)");
      }
    }
  }
  width_ = camera.width.value_or(2.0 * intrinsics_[2]);
  if (!(width_ >= 1. && width_ <= 1e9)) {
    fail(has_width_ ? "/camera/intrinsics@width " + std::to_string(width_) + " is not a width in pixels"
                    : "/camera/intrinsics has no width attribute and its cx " +
                          std::to_string(intrinsics_[2]) + " is not half a width in pixels");
  }
}

rig::RigidPose TrackedRig::Pose(int64_t frame) const {
  rig::RigidPose p;
  p.pitch = pose_(frame, 0);
  p.yaw = pose_(frame, 1);
  p.roll = pose_(frame, 2);
  p.translation = translation_.row(frame).transpose();
  p.scale = scale_[frame];
  return p;
}

Eigen::VectorXf TrackedRig::Weights(int64_t frame) const {
  Eigen::VectorXf w = Eigen::VectorXf::Zero(num_rig_shapes_);
  for (size_t t = 0; t < shape_of_.size(); ++t) {
    if (shape_of_[t] >= 0) w[shape_of_[t]] = weights_(frame, static_cast<Eigen::Index>(t));
  }
  return w;
}

render::Camera TrackedRig::CameraForWidth(int width, int height) const {
  const double s = width / width_;
  render::Camera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = static_cast<float>(intrinsics_[0] * s);
  camera.fy = static_cast<float>(intrinsics_[1] * s);
  camera.cx = static_cast<float>(intrinsics_[2] * s);
  camera.cy = static_cast<float>(intrinsics_[3] * s);
  return camera;
}

}  // namespace facecap::stages
