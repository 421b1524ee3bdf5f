#include "stages/tracked_rig.h"

#include "io/hdf5.h"

namespace facecap::stages {

TrackedRig::TrackedRig(const std::string& path, const rig::Rig& rig) : num_rig_shapes_(rig.NumShapes()) {
  io::H5File track = io::H5File::OpenRead(path);
  const std::vector<std::string> names = track.ReadStrings("/track/shape_names");
  const int64_t n = track.DatasetShape("/track/pose")[0];
  pose_ = track.ReadMatrix<float>("/track/pose", n, 3);
  translation_ = track.ReadMatrix<float>("/track/translation", n, 3);
  scale_ = track.ReadVector<float>("/track/scale", n);
  weights_ = track.ReadMatrix<float>("/track/weights", n, static_cast<int64_t>(names.size()));
  if (track.Exists("/track/termination")) termination_ = track.ReadVector<int32_t>("/track/termination", n);
  shape_of_.resize(names.size());
  for (size_t t = 0; t < names.size(); ++t) shape_of_[t] = rig.ShapeIndex(names[t]);
  intrinsics_ = track.ReadVector<double>("/camera/intrinsics", 4);
  has_width_ = track.HasAttribute("/camera/intrinsics", "width");
  if (track.HasAttribute("/track", "fps")) fps_ = track.GetDoubleAttribute("/track", "fps");
  if (track.Exists("/track/source_index")) {
    source_index_ = track.ReadVector<int64_t>("/track/source_index", n);
    timecode_ = track.ReadVector<double>("/track/timecode", n);
  }
  width_ = has_width_ ? track.GetDoubleAttribute("/camera/intrinsics", "width") : 2.0 * intrinsics_[2];
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
