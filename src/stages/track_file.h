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

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TRACK_FILE_H_
