// What later stages read of an ingest output (frames.h5): per frame whether the subject's
// face was found, its 68 landmarks in source pixels (pixel centres at integer coordinates, as
// dlib gives them), the similarity from source to crop pixels, the source image size and the
// source camera the pipeline assumes (a pinhole with ingest's vertical field of view fov_deg,
// principal point at the image centre), with the source frame index, timecode and rate.
#ifndef FACECAP_STAGES_INGESTED_FRAMES_H_
#define FACECAP_STAGES_INGESTED_FRAMES_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/pose.h"

namespace facecap::stages {

class IngestedFrames {
 public:
  // Reads and checks every dataset's shape; FileIOError names the file and what is wrong
  // (an ingest output written before ingest recorded its camera asks to rerun ingest). Also
  // refused: crops that are not square, a negative source index or non-finite timecode, and a
  // frame with a face whose image size is not positive, whose crop transform is not a
  // similarity with a scale in [1e-6, 1e6], or whose transform or landmarks are not finite
  // pixels within 1e9: every camera and landmark the accessors derive is finite.
  static IngestedFrames Read(const std::string& path);

  int64_t NumFrames() const { return static_cast<int64_t>(found_.size()); }
  int crop_size() const { return crop_size_; }
  double fov_deg() const { return fov_deg_; }
  double fps() const { return fps_; }  // 0 for a folder of images
  bool Found(int64_t frame) const { return found_[frame] != 0; }
  const std::vector<uint8_t>& found() const { return found_; }
  int64_t SourceIndex(int64_t frame) const { return source_index_[frame]; }
  double Timecode(int64_t frame) const { return timecode_[frame]; }  // s; -1 for a still
  const std::string& path() const { return path_; }

  // The source camera of a frame (its own image size).
  render::Camera SourceCamera(int64_t frame) const;
  // The crop of a frame seen as a camera, for an image of out_size pixels showing the crop.
  render::CropView CropCamera(int64_t frame, int out_size) const;
  // The detected landmarks in source pixels (68 x 2, pixel centres at integers).
  Eigen::Matrix<float, 68, 2, Eigen::RowMajor> SourceLandmarks(int64_t frame) const;
  // The detected landmarks in the camera coordinates of the crop shown at out_size pixels
  // (pixel centres at i + 0.5, as render::Camera projects).
  Eigen::Matrix<float, 68, 2, Eigen::RowMajor> CropLandmarks(int64_t frame, int out_size) const;
  // A point in source pixels (centres at integers) in the crop's coordinates at out_size
  // pixels, as CropLandmarks places the landmarks.
  Eigen::Vector2f CropPoint(int64_t frame, const Eigen::Vector2f& source, int out_size) const;

 private:
  std::string path_;
  int crop_size_ = 0;
  double fov_deg_ = 0.;
  double fps_ = 0.;
  std::vector<uint8_t> found_;
  std::vector<int64_t> source_index_;
  std::vector<double> timecode_;
  std::vector<int32_t> image_size_;   // 2 per frame: width, height
  std::vector<float> crop_transform_; // 6 per frame
  std::vector<float> landmarks_;      // 136 per frame
};

// A head pose seen by the crop camera `view`, from the pose in the source camera, and back.
rig::RigidPose PoseInCrop(const rig::RigidPose& source_pose, const render::CropView& view);
rig::RigidPose PoseInSource(const rig::RigidPose& crop_pose, const render::CropView& view);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_INGESTED_FRAMES_H_
