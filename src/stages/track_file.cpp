#include "stages/track_file.h"

#include <algorithm>
#include <cmath>

#include "io/camera_file.h"
#include "util/errors.h"

namespace facecap::stages {

void CreateTrackDatasets(io::H5File* f, int64_t frames, int S) {
  f->CreateFrames<float>("/track/pose", {3}, frames, 1024, 4);
  f->SetAttribute("/track/pose", "columns", std::string("pitch, yaw, roll"));
  f->SetAttribute("/track/pose", "units", std::string("rad"));
  f->CreateFrames<float>("/track/translation", {3}, frames, 1024, 4);
  f->SetAttribute("/track/translation", "units", std::string("cm (camera space)"));
  f->CreateFrames<float>("/track/scale", {}, frames, 1024, 4);
  f->CreateFrames<float>("/track/weights", {S}, frames, 256, 4);
  f->CreateFrames<double>("/track/cost", {}, frames, 1024, 4);
  f->SetAttribute("/track/cost", "meaning",
                  std::string("final 0.5 |F - T|^2 of the objective at full resolution"));
  f->CreateFrames<double>("/track/initial_cost", {}, frames, 1024, 4);
  f->CreateFrames<int32_t>("/track/iterations", {}, frames, 1024, 4);
  f->CreateFrames<int32_t>("/track/evaluations", {}, frames, 1024, 4);
  f->CreateFrames<int32_t>("/track/termination", {}, frames, 1024, 4);
  f->SetAttribute("/track/termination", "codes",
                  std::string("0 CONVERGENCE, 1 NO_CONVERGENCE, 2 FAILURE, 3 NO_TARGET (no face "
                              "in the frame: not solved, the previous frame's solution held, "
                              "or the neutral)"));
  f->CreateFrames<double>("/track/seconds", {}, frames, 1024, 4);
  f->SetAttribute("/track/seconds", "meaning", std::string("wall time of the frame's solve"));
}

void WriteSourceFrames(io::H5File* f, const IngestedFrames& ingested, const std::string& frames_path,
                       int64_t frames) {
  f->SetAttribute(io::kCameraPath, "fov_deg", ingested.fov_deg());
  f->SetAttribute(io::kCameraPath, "meaning",
                  std::string("the source video's camera as assumed by ingest: poses are in "
                              "its space, landmarks project to source pixels"));
  f->SetAttribute("/track", "frames", frames_path);
  std::vector<int64_t> index(frames);
  std::vector<double> timecode(frames);
  for (int64_t k = 0; k < frames; ++k) {
    index[k] = ingested.SourceIndex(k);
    timecode[k] = ingested.Timecode(k);
  }
  f->WriteVector("/track/source_index", index);
  f->SetAttribute("/track/source_index", "meaning",
                  std::string("frame index in the source video (or image index)"));
  f->WriteVector("/track/timecode", timecode);
  f->SetAttribute("/track/timecode", "units", std::string("seconds from the start of the video"));
  if (ingested.fps() > 0.) f->SetAttribute("/track", "fps", ingested.fps());
}

void WriteTrackRecords(io::H5File* f, const std::vector<std::string>& shape_names,
                       const render::Camera& c, float distance_cm) {
  f->WriteStrings("/track/shape_names", shape_names);
  io::CameraRecord record = io::CameraRecord::Of(c);
  record.distance_cm = distance_cm;
  io::WriteCamera(f, record);
}

int TrackTimeline::Column(const std::string& name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

TrackTimeline ReadTimeline(const std::string& path) {
  io::H5File f = io::H5File::OpenRead(path);
  for (const char* name : {"/track/shape_names", "/track/weights", "/track/pose", "/track/termination"}) {
    if (!f.Exists(name)) throw FileIOError(path + ": no " + std::string(name) + " (not a track file?)");
  }
  TrackTimeline t;
  t.names = f.ReadStrings("/track/shape_names");
  t.weights = f.ReadMatrix<float>("/track/weights");
  const int64_t n = t.weights.rows();
  if (t.weights.cols() != static_cast<int64_t>(t.names.size())) {
    throw FileIOError(path + ": /track/weights has " + std::to_string(t.weights.cols()) +
                      " columns for " + std::to_string(t.names.size()) + " shape names");
  }
  f.CheckShape("/track/pose", {n, 3});
  t.pose = f.ReadMatrix<float>("/track/pose");
  t.termination = f.ReadVector<int32_t>("/track/termination", n);
  if (f.Exists("/track/timecode")) {
    t.times = f.ReadVector<double>("/track/timecode", n);
  } else {
    const double fps = f.HasAttribute("/track", "fps") ? f.GetDoubleAttribute("/track", "fps") : 0.;
    if (!(fps > 0.)) throw FileIOError(path + ": neither /track/timecode nor a frame rate (/track@fps)");
    for (int64_t i = 0; i < n; ++i) t.times.push_back(i / fps);
  }
  if (f.Exists("/track/source_index")) {
    t.source_index = f.ReadVector<int64_t>("/track/source_index", n);
  } else {
    for (int64_t i = 0; i < n; ++i) t.source_index.push_back(i);
  }
  for (int64_t i = 0; i < n; ++i) {
    if (!std::isfinite(t.times[i]) || (i > 0 && t.times[i] <= t.times[i - 1])) {
      throw FileIOError(path + ": the frame times are not finite and ascending at frame " + std::to_string(i));
    }
  }
  if (!t.weights.allFinite()) throw FileIOError(path + ": /track/weights holds non-finite values");
  return t;
}

}  // namespace facecap::stages
