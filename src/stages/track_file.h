// The layout of a track file (track, regress infer): per frame /track/{pose [3] (pitch, yaw,
// roll rad), translation [3] cm, scale, weights [S], cost, initial_cost, iterations,
// evaluations, termination, seconds}, and once /track/shape_names and /camera/intrinsics;
// for crops of footage also the source frame indices, timecodes and frame rate.
// TrackedRig (tracked_rig.h) reads it back.
#ifndef FACECAP_STAGES_TRACK_FILE_H_
#define FACECAP_STAGES_TRACK_FILE_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/hdf5.h"
#include "render/camera.h"
#include "stages/ingested_frames.h"

namespace facecap::stages {

// /track/termination of a frame without a face (Ceres's codes are 0-2).
constexpr int32_t kNoTarget = 3;

// The per-frame datasets of /track in a new or continued output.
void CreateTrackDatasets(io::H5File* f, int64_t frames, int num_shapes);

// The shape names and the camera the poses are in (a new output); `distance_cm` is the
// framing distance recorded with the camera.
void WriteTrackRecords(io::H5File* f, const std::vector<std::string>& shape_names,
                       const render::Camera& camera, float distance_cm);

// The source camera, frame indices, timecodes and frame rate of tracked footage crops.
void WriteSourceFrames(io::H5File* f, const IngestedFrames& ingested, const std::string& frames_path,
                       int64_t frames);


// What lip-sync reads of a track file: names, weights, poses and the time of every frame.
struct TrackTimeline {
  std::vector<std::string> names;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> weights;  // frames x names
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> pose;     // frames x 3 (pitch, yaw, roll)
  std::vector<int32_t> termination;   // kNoTarget: no face, the previous solution held
  std::vector<double> times;          // seconds from the start of the video
  std::vector<int64_t> source_index;  // the source video's frame of each row

  int64_t frames() const { return weights.rows(); }
  bool Solved(int64_t f) const { return termination[f] != kNoTarget; }
  int Column(const std::string& name) const;
};

// Reads a track file's timeline. FileIOError naming the file when a dataset is missing, the
// shapes disagree, the times are not finite and ascending or the weights not finite.
TrackTimeline ReadTimeline(const std::string& path);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TRACK_FILE_H_
