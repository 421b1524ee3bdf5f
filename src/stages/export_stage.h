// facecap export livelink | gltf | overlay | landmarks: tracked animation out to the formats
// of the tools that use it, each written by rank 0 (the other ranks return at once):
//   export livelink: a Live Link Face CSV (Unreal Engine, MetaHuman): Timecode,
//     BlendShapeCount, then 61 values per frame (the 52 ARKit shapes matched by name, head
//     yaw/pitch/roll, eye yaw/pitch/roll);
//   export gltf: a glTF (.glb/.gltf) of the rig with one morph target per shape and the tracked
//     weights as a morph-target animation;
//   export overlay: an mp4 of the tracked rig drawn over the frames it was tracked on
//     (segmentation colours blended in, region borders and silhouette in white), optionally a
//     contact sheet PNG;
//   export landmarks: a CSV of the tracked rig's 68 landmarks in the source video's pixels, one
//     row per ingested frame, so that other tools can score the tracking.
#ifndef FACECAP_STAGES_EXPORT_STAGE_H_
#define FACECAP_STAGES_EXPORT_STAGE_H_

#include <string>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// Where the animation lives in the tracking output.
struct TrackDatasets {
  std::string weights = "/track/weights";          // [F, S] in [0, 1]
  std::string shape_names = "/track/shape_names";  // [S]
  std::string pose = "/track/pose";                // [F, 3] pitch, yaw, roll (rad)

  template <class V>
  void Visit(V&& v) {
    v("weights_dataset", weights, "dataset of per-frame shape weights [frames, shapes]");
    v("shape_names_dataset", shape_names, "dataset of the shape names [shapes]");
    v("pose_dataset", pose, "dataset of per-frame head rotation [frames, 3]: pitch, yaw, roll in rad");
  }
};

// [export.livelink]
struct ExportLiveLinkOptions {
  std::string track = "track.h5";   // tracking output
  std::string out = "take.csv";     // CSV file
  float fps = 0.f;                  // frame rate of the take (0: the track's)
  float eye_look_deg = 25.f;        // eye rotation at eyeLook* weight 1
  TrackDatasets datasets;

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5) with per-frame weights and pose");
    v("out", out, "Live Link Face CSV file");
    v("fps", fps, "frame rate of the take (frames per second, for the timecodes); 0: the "
                  "track's own (its source video's rate and timecodes), else 30");
    v("eye_look_deg", eye_look_deg, "eye rotation in degrees at an eyeLook* weight of 1, for the "
                                    "eye yaw and pitch columns");
    datasets.Visit(v);
  }
  bool Check(std::string* why) const {
    if (!(fps >= 0.f && fps <= 1000.f)) { *why = "fps must be in [0, 1000] (0: the track's)"; return false; }
    return true;
  }
};

// Runs export livelink on rank 0 (the other ranks return at once, with 0 frames); the
// summary counts the CSV's frames, all written by this run.
StageSummary RunExportLiveLink(const ExportLiveLinkOptions& options, const StageContext& ctx,
                               const io::Config& resolved);

// [export.gltf]
struct ExportGltfOptions {
  std::string track = "track.h5";  // tracking output
  std::string rig = "rig.h5";      // the rig that was tracked
  std::string out = "take.glb";    // .glb or .gltf
  float fps = 0.f;                 // 0: the track's frame rate
  TrackDatasets datasets;

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5) with per-frame weights");
    v("rig", rig, "the rig that was tracked (HDF5); a textured rig's texture is embedded");
    v("out", out, "glTF file (.glb binary or .gltf text)");
    v("fps", fps, "frame rate of the morph-target animation (0: the track's own, else 30)");
    datasets.Visit(v);
  }
  bool Check(std::string* why) const {
    if (!(fps >= 0.f && fps <= 1000.f)) { *why = "fps must be in [0, 1000] (0: the track's)"; return false; }
    return true;
  }
};

// Runs export gltf on rank 0 (the other ranks return at once, with 0 frames); the summary
// counts the frames of the morph-target animation, all written by this run.
StageSummary RunExportGltf(const ExportGltfOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

// [export.overlay]
struct ExportOverlayOptions {
  std::string track = "track.h5";    // tracking output (pose, translation, scale, weights)
  std::string rig = "rig.h5";        // the rig that was tracked
  std::string frames = "clip.h5";    // the frames that were tracked
  std::string frames_dataset = "";   // image dataset ("": see Visit)
  std::string out = "overlay.mp4";   // mp4 file
  float fps = 0.f;                   // frame rate of the video (0: the track's)
  float opacity = 0.45f;             // opacity of the segmentation colours over the frame
  int scale = 0;                     // magnification (0: 2 below 256 pixels, else 1)
  int count = 0;                     // frames to draw from the first (0: all tracked frames)
  std::string sheet = "";            // contact sheet PNG of evenly spaced frames ("": none)
  int sheet_count = 12;              // frames on the sheet
  bool texture = false;              // the rig shaded with its texture instead of its regions

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5): /track/pose, translation, scale, weights");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("frames", frames, "file of the frames that were tracked (a wild clip or an ingest file)");
    v("frames_dataset", frames_dataset,
      "image dataset of the frames (empty: the source video's own frames for a track of an "
      "ingest output's crops, else /frames/image, then /frames/crop)");
    v("out", out, "mp4 file: each frame with the tracked rig drawn over it");
    v("fps", fps, "frame rate of the video (0: the track's own, else 30)");
    v("opacity", opacity, "opacity of the rig's segmentation colours over the frame, in [0, 1]");
    v("scale", scale, "magnification of the video (nearest neighbour), 1 to 8 (0: 2 for frames "
                      "under 256 pixels, else 1)");
    v("count", count, "frames to draw from the first (0: all tracked frames)");
    v("sheet", sheet, "also a contact sheet PNG of sheet_count evenly spaced frames (empty: none)");
    v("sheet_count", sheet_count, "frames on the contact sheet");
    v("texture", texture,
      "draw the rig shaded with the rig file's texture (a dynamic texture library: its texture at each "
      "frame's weights) at `opacity` instead of its segmentation colours");
  }
  bool Check(std::string* why) const {
    if (!(fps >= 0.f && fps <= 1000.f)) { *why = "fps must be in [0, 1000] (0: the track's)"; return false; }
    if (!(opacity >= 0.f && opacity <= 1.f)) { *why = "opacity must be in [0, 1]"; return false; }
    if (scale < 0 || scale > 8) { *why = "scale must be in [0, 8]"; return false; }
    if (count < 0) { *why = "count must be >= 0"; return false; }
    if (sheet_count < 1 || sheet_count > 400) { *why = "sheet_count must be in [1, 400]"; return false; }
    return true;
  }
};

// Runs export overlay on rank 0 (the other ranks return at once, with 0 frames); the
// summary counts the video's frames, all drawn by this run.
StageSummary RunExportOverlay(const ExportOverlayOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

// [export.landmarks]
struct ExportLandmarksOptions {
  std::string track = "track.h5";     // tracking of an ingest output's crops
  std::string rig = "rig.h5";         // the rig that was tracked
  std::string frames = "frames.h5";   // the ingest output
  std::string out = "landmarks.csv";  // CSV file

  template <class V>
  void Visit(V&& v) {
    v("track", track, "tracking output (HDF5) of an ingest output's crops (track --frames)");
    v("rig", rig, "the rig that was tracked (HDF5)");
    v("frames", frames, "the ingest output (frames.h5) the track was made of");
    v("out", out, "CSV file: source_index, timecode, x_0..x_67, y_0..y_67, visible_0..visible_67 "
                  "in source video pixels (pixel centres at integers, as dlib and OpenCV)");
  }
  bool Check(std::string* why) const {
    if (out.empty()) { *why = "out must name a file"; return false; }
    return true;
  }
};

// Runs export landmarks on rank 0 (the other ranks return at once, with 0 frames); the
// summary counts the CSV's rows (every ingested frame), all written by this run.
StageSummary RunExportLandmarks(const ExportLandmarksOptions& options, const StageContext& ctx,
                                const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_EXPORT_STAGE_H_
