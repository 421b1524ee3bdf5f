#include "stages/track_file.h"

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
  f->SetAttribute("/camera/intrinsics", "fov_deg", ingested.fov_deg());
  f->SetAttribute("/camera/intrinsics", "meaning",
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
  f->WriteVector<double>("/camera/intrinsics", {c.fx, c.fy, c.cx, c.cy});
  f->SetAttribute("/camera/intrinsics", "columns", std::string("fx, fy, cx, cy (pixels)"));
  f->SetAttribute("/camera/intrinsics", "distance_cm", static_cast<double>(distance_cm));
  f->SetAttribute("/camera/intrinsics", "width", static_cast<double>(c.width));
  f->SetAttribute("/camera/intrinsics", "height", static_cast<double>(c.height));
}

}  // namespace facecap::stages
