// A tracking output (track.h5, from `facecap track`) read back as rig poses: per frame the
// rigid pose, the weights in a rig's own shape order (matched by name), whether the frame was
// solved, and the tracking camera scaled to the images it is drawn on.
#ifndef FACECAP_STAGES_TRACKED_RIG_H_
#define FACECAP_STAGES_TRACKED_RIG_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::stages {

class TrackedRig {
 public:
  // Reads /track/{shape_names, pose, translation, scale, weights, termination} and
  // /camera/intrinsics of `path`; tracked shapes the rig lacks are ignored. FileIOError names
  // the file and what is wrong: a missing dataset, a per-frame dataset whose rows differ from
  // /track/pose's, weights whose columns differ from the shape names, a name given twice, a
  // non-finite pose or weight, a scale <= 0, a camera without finite positive focal lengths
  // and a positive width, a negative source index or a non-finite timecode.
  TrackedRig(const std::string& path, const rig::Rig& rig);

  int64_t NumFrames() const { return static_cast<int64_t>(scale_.size()); }
  rig::RigidPose Pose(int64_t frame) const;
  // The frame's weights in the rig's shape order (0 for shapes that were not tracked).
  Eigen::VectorXf Weights(int64_t frame) const;
  // False for a frame the tracker had no face to solve (termination 3: the last solution held).
  bool Solved(int64_t frame) const { return termination_.empty() || termination_[frame] != 3; }
  // Whether /camera/intrinsics records the tracked images' width (older files do not).
  bool HasCameraWidth() const { return has_width_; }
  // The tracking camera scaled to images `width` pixels wide (tracking may have run on smaller
  // targets); without a recorded width the principal point is taken as central.
  render::Camera CameraForWidth(int width, int height) const;
  // The frame rate the track records (its source video's or the synthetic clip's; 0: none).
  double fps() const { return fps_; }
  // Whether the track was made of crops of footage (track --frames): its camera is then the
  // source video's, and each frame knows its source frame index and timecode.
  bool InSourceCamera() const { return !source_index_.empty(); }
  int64_t SourceIndex(int64_t frame) const { return source_index_[frame]; }
  double Timecode(int64_t frame) const { return timecode_[frame]; }

 private:
  int num_rig_shapes_ = 0;
  std::vector<int> shape_of_;  // tracked column -> rig shape, -1 when the rig lacks it
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> weights_;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> pose_, translation_;
  std::vector<float> scale_;
  std::vector<int32_t> termination_;
  std::vector<double> intrinsics_;
  double width_ = 0.;
  double fps_ = 0.;
  std::vector<int64_t> source_index_;
  std::vector<double> timecode_;
  bool has_width_ = false;
};

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TRACKED_RIG_H_
