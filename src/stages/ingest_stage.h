// facecap ingest: real footage (a video file or a folder of images) to frames.h5: per frame
// the subject's face box, 68 landmarks (source and crop pixels), a similarity-aligned crop,
// the source file, frame index and timecode, and a status that says why a frame has no face.
//
// Three passes, so that the output is the same for any number of ranks:
//   1. detect (per frame, spread across ranks): decode, find all faces;
//   2. follow the subject (rank 0, sequential over boxes only): face::FollowSubject for a
//      video; the images of a folder are unrelated stills, each with its largest face;
//   3. landmarks and crops (per frame, spread across ranks) for the subject's face.
// Both per-frame passes are resumable (done masks /progress/detected and /progress/done).
#ifndef FACECAP_STAGES_INGEST_STAGE_H_
#define FACECAP_STAGES_INGEST_STAGE_H_

#include <cstdint>
#include <string>

#include "face/face_analyzer.h"
#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// Why a frame has no face (/frames/status).
enum IngestFrameStatus : int32_t {
  kFrameFound = 0,          // the subject's face: landmarks and crop stored
  kFrameNoFace = 1,         // no face detected
  kFrameFaceTooSmall = 2,   // the subject's box is narrower than min_face_size
  kFrameUnreadable = 3,     // the frame or image could not be decoded
  kFrameSubjectAbsent = 4,  // faces, but none is the subject being followed (video only)
};
const char* IngestFrameStatusName(int32_t status);

// [ingest]
struct IngestOptions {
  std::string video;                  // video file (any format OpenCV's ffmpeg backend reads)
  std::string images;                 // or a folder of images (sorted by name)
  std::string out = "frames.h5";      // output file
  int stride = 1;                     // keep every stride-th frame
  double start_s = 0.0;               // video time range start, seconds
  double end_s = -1.0;                // video time range end, seconds (< 0: the end)
  int64_t max_frames = 0;             // at most this many frames (0: all)
  std::string landmark_model = face::kDefaultLandmarkModel;  // dlib 68-point model
  int detect_max_side = 480;          // detection image's longer side (0: full size)
  int detect_upsample = 0;            // detection image doublings (smaller faces, slower)
  double detect_threshold = 0.0;      // detector threshold adjustment
  int min_face_size = 64;             // subject boxes narrower than this (source px) are too small
  int detect_small_max_side = 1280;   // longer side of the small-face search (0: none)
  int crop_size = 128;                // aligned crop width and height
  double crop_padding = 0.25;         // margin around the mean face in the crop
  double crop_raise = 0.0;            // the face moved up by this fraction of the crop
  double fov_deg = 40.0;              // vertical field of view of the source camera (assumed)
  float track_min_iou = 0.25f;        // box overlap that continues the subject
  int track_max_gap = 10;             // frames without the subject before a new one is taken
  int64_t max_image_pixels = 40000000;  // larger images are processed scaled down
  int batch = 16;                     // frames per rank per round (a checkpoint per round)
  int threads = 0;                    // OpenMP threads per rank (0: cores / ranks on the node)

  template <class V>
  void Visit(V&& v) {
    v("video", video, "video file to ingest (mp4, mkv, avi, mov, ...: what OpenCV's ffmpeg "
                      "backend decodes)");
    v("images", images, "folder of images to ingest instead of a video (sorted by file name)");
    v("out", out, "output file (HDF5)");
    v("stride", stride, "keep every stride-th frame of the selected range");
    v("start_s", start_s, "start of the video time range in seconds");
    v("end_s", end_s, "end of the video time range in seconds (< 0: to the end)");
    v("max_frames", max_frames, "keep at most this many frames (0: all)");
    v("landmark_model", landmark_model, "dlib 68-point shape predictor (Debian libdlib-data)");
    v("detect_max_side", detect_max_side, "faces are detected on a copy whose longer side is at "
                                          "most this (0: full size); the smallest face found is "
                                          "about 80 px at that scale");
    v("detect_upsample", detect_upsample, "doublings of the detection image (finds faces half "
                                          "as large per step, ~4x slower)");
    v("detect_threshold", detect_threshold, "added to the detector threshold (> 0: fewer, "
                                            "surer faces)");
    v("min_face_size", min_face_size, "subject faces narrower than this many source pixels are "
                                      "recorded as too small (half the crop size: the crop "
                                      "would upsample them more than 2x)");
    v("detect_small_max_side", detect_small_max_side,
      "a frame without a face at the detection size is searched again, upsampled, for faces "
      "down to half min_face_size (at least 20 px), the search image's longer side at most "
      "this; faces found narrower than min_face_size are recorded as too small (0: no second "
      "search)");
    v("crop_size", crop_size, "aligned crop width and height in pixels");
    v("crop_padding", crop_padding, "margin around the mean face in the crop, in face sizes (negative: the crop cuts into "
      "the face; with crop_raise, e.g. -0.125 and 0.43 frame the mouth and chin)");
    v("crop_raise", crop_raise,
      "the face moved up by this fraction of the crop height (negative: down)");
    v("fov_deg", fov_deg,
      "vertical field of view of the camera that filmed the source, in degrees (a webcam or "
      "phone front camera: 40-50); later stages model the footage as a pinhole camera with it");
    v("track_min_iou", track_min_iou, "box overlap (IoU) with the subject's last box that "
                                      "continues the subject");
    v("track_max_gap", track_max_gap, "frames without the subject after which the largest face "
                                      "becomes the subject");
    v("max_image_pixels", max_image_pixels, "images with more pixels are processed scaled down "
                                            "(landmarks still in source pixels)");
    v("batch", batch, "frames per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
  }
  bool Check(std::string* why) const;
  face::FaceAnalyzerOptions Analyzer() const;
};

// Counts of the frames of an ingest output.
struct IngestSummary {
  int64_t frames = 0;
  int64_t found = 0;
  int64_t no_face = 0;
  int64_t face_too_small = 0;
  int64_t unreadable = 0;
  int64_t subject_absent = 0;
  int64_t from_grayscale = 0;
  int64_t from_16bit = 0;
  int64_t downscaled = 0;
  double seconds = 0.0;  // wall time of this run
  std::string Line() const;
};

// Runs the stage on every rank of ctx.comm (collective). `resolved` is the resolved [ingest]
// table stored in the output. Returns the summary on every rank.
IngestSummary RunIngest(const IngestOptions& options, const StageContext& ctx,
                        const io::Config& resolved);

// The summary of an existing ingest output.
IngestSummary ReadIngestSummary(const std::string& path);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_INGEST_STAGE_H_
