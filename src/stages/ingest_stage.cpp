// facecap ingest: video or images to frames.h5 (see ingest_stage.h).
#include "stages/ingest_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "face/align.h"
#include "face/frame_source.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/resumable.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {

const char* IngestFrameStatusName(int32_t status) {
  switch (status) {
    case kFrameFound: return "found";
    case kFrameNoFace: return "no_face";
    case kFrameFaceTooSmall: return "face_too_small";
    case kFrameUnreadable: return "unreadable";
    case kFrameSubjectAbsent: return "subject_absent";
    default: return "unknown";
  }
}

bool IngestOptions::Check(std::string* why) const {
  if (video.empty() == images.empty()) {
    *why = "give exactly one of video (a video file) and images (a folder of images)";
    return false;
  }
  if (out.empty()) { *why = "out must name a file"; return false; }
  if (stride < 1) { *why = "stride must be >= 1"; return false; }
  if (!(start_s >= 0.0)) { *why = "start_s must be >= 0"; return false; }
  if (end_s >= 0.0 && end_s <= start_s) { *why = "end_s must be after start_s (or < 0)"; return false; }
  if (max_frames < 0) { *why = "max_frames must be >= 0"; return false; }
  if (!(fov_deg >= 5.0 && fov_deg <= 150.0)) { *why = "fov_deg must be in [5, 150]"; return false; }
  if (min_face_size < 0) { *why = "min_face_size must be >= 0"; return false; }
  if (detect_small_max_side != 0 && detect_small_max_side < 80) {
    *why = "detect_small_max_side must be 0 (no small-face search) or >= 80";
    return false;
  }
  if (max_image_pixels < 10000) { *why = "max_image_pixels must be >= 10000"; return false; }
  if (batch < 1) { *why = "batch must be >= 1"; return false; }
  if (threads < 0) { *why = "threads must be >= 0"; return false; }
  face::CropOptions crop{crop_size, crop_padding, crop_raise};
  if (!crop.Check(why)) return false;
  face::SubjectTrackerOptions track{track_min_iou, track_max_gap};
  if (!track.Check(why)) return false;
  return Analyzer().Check(why);
}

face::FaceAnalyzerOptions IngestOptions::Analyzer() const {
  face::FaceAnalyzerOptions a;
  a.landmark_model = landmark_model;
  a.detect_max_side = detect_max_side;
  a.detect_upsample = detect_upsample;
  a.detect_threshold = detect_threshold;
  a.small_face_size = std::max(20, min_face_size / 2);
  a.small_face_max_side = detect_small_max_side;
  return a;
}

std::string IngestSummary::Line() const {
  std::string s = std::to_string(frames) + " frames: " + std::to_string(found) + " with the subject's face, " +
                  std::to_string(no_face) + " without a face, " + std::to_string(subject_absent) +
                  " with other faces only, " + std::to_string(face_too_small) + " with a face too small, " +
                  std::to_string(unreadable) + " unreadable";
  if (from_grayscale || from_16bit || downscaled) {
    s += "; converted: " + std::to_string(from_grayscale) + " grayscale, " +
         std::to_string(from_16bit) + " 16-bit, " + std::to_string(downscaled) + " scaled down";
  }
  return s;
}

namespace {

constexpr int kMaxFaces = 8;   // faces kept per frame in /detections
constexpr int kL = face::kNumLandmarks;

std::vector<int64_t> SelectFrames(const face::FrameSource& source, const IngestOptions& o) {
  const int64_t n = source.NumFrames();
  const double fps = source.Fps();
  int64_t first = 0, last = n;
  if (!o.video.empty() && fps > 0.0) {
    first = static_cast<int64_t>(std::ceil(o.start_s * fps - 1e-6));
    if (o.end_s >= 0.0) last = std::min(n, static_cast<int64_t>(std::ceil(o.end_s * fps - 1e-6)));
  } else if (!o.video.empty() && (o.start_s > 0.0 || o.end_s >= 0.0)) {
    throw InvalidInputError(o.video + ": the video reports no frame rate; start_s and end_s "
                            "cannot be applied");
  }
  std::vector<int64_t> frames;
  for (int64_t i = first; i < last; i += o.stride) {
    frames.push_back(i);
    if (o.max_frames > 0 && static_cast<int64_t>(frames.size()) >= o.max_frames) break;
  }
  if (frames.empty()) {
    throw InvalidInputError((o.video.empty() ? o.images : o.video) + ": the time range [" +
                            std::to_string(o.start_s) + ", " + std::to_string(o.end_s) +
                            "] s selects no frame of " + std::to_string(n));
  }
  return frames;
}

// Writes frames of a round in contiguous runs: `write(first, count, begin)` with results
// [begin, begin + count).
template <typename Fn>
void ForEachRun(const std::vector<int64_t>& frames, Fn&& write) {
  size_t k = 0;
  while (k < frames.size()) {
    size_t end = k + 1;
    while (end < frames.size() && frames[end] == frames[end - 1] + 1) ++end;
    write(frames[k], static_cast<int64_t>(end - k), k);
    k = end;
  }
}

// Counts of each frame status and input flag.
IngestSummary SummaryOf(const std::vector<int32_t>& status, const std::vector<int32_t>& flags) {
  IngestSummary s;
  s.frames = static_cast<int64_t>(status.size());
  for (int32_t v : status) {
    s.found += v == kFrameFound;
    s.no_face += v == kFrameNoFace;
    s.face_too_small += v == kFrameFaceTooSmall;
    s.unreadable += v == kFrameUnreadable;
    s.subject_absent += v == kFrameSubjectAbsent;
  }
  for (int32_t v : flags) {
    s.from_grayscale += (v & face::kInputFromGrayscale) != 0;
    s.from_16bit += (v & face::kInputFrom16Bit) != 0;
    s.downscaled += (v & face::kInputDownscaled) != 0;
  }
  return s;
}

// The per-frame datasets of the output, for n frames of S-pixel crops.
void CreateIngestDatasets(io::H5File* f, int64_t n, int S) {
  f->CreateFrames<float>("/detections/boxes", {kMaxFaces, 5}, n, 256);
  f->SetAttribute("/detections/boxes", "columns", std::string("x, y, width, height, score (source pixels), largest first"));
  f->CreateFrames<int32_t>("/detections/count", {}, n, 1024);
  f->CreateFrames<int32_t>(io::frames::kImageSize, {2}, n, 1024);
  f->SetAttribute(io::frames::kImageSize, "columns", std::string("width, height (source pixels)"));
  f->CreateFrames<int32_t>(io::frames::kInputFlags, {}, n, 1024);
  f->SetAttribute(io::frames::kInputFlags, "bits", std::string("1 grayscale, 2 16-bit, 4 float, 8 alpha dropped, 16 scaled down"));
  f->CreateFrames<int32_t>(io::frames::kStatus, {}, n, 1024);
  f->SetAttribute(io::frames::kStatus, "values", std::string("0 found, 1 no_face, 2 face_too_small, 3 unreadable, 4 subject_absent"));
  f->CreateFrames<uint8_t>(io::frames::kFound, {}, n, 1024);
  f->CreateFrames<float>(io::frames::kLandmarks, {kL, 2}, n, 64);
  f->SetAttribute(io::frames::kLandmarks, "units", std::string("source pixels (x right, y down), iBUG 68 order"));
  f->CreateFrames<float>(io::frames::kLandmarksCrop, {kL, 2}, n, 64);
  f->SetAttribute(io::frames::kLandmarksCrop, "units", std::string("crop pixels (x right, y down), iBUG 68 order"));
  f->CreateFrames<float>(io::frames::kCropTransform, {2, 3}, n, 256);
  f->SetAttribute(io::frames::kCropTransform, "meaning", std::string("[s R | t]: source pixels -> crop pixels"));
  f->CreateFrames<uint8_t>(io::frames::kCrop, {S, S, 3}, n, 8);
  f->SetAttribute(io::frames::kCrop, "layout", std::string("frame, y, x, RGB"));
}

// Where each selected frame comes from, the crop settings and the assumed camera (a new output).
void WriteSourceRecords(io::H5File* f, const face::FrameSource& source,
                        const std::vector<int64_t>& selected, const IngestOptions& o) {
  const int64_t n = static_cast<int64_t>(selected.size());
  std::vector<int64_t> index(selected);
  std::vector<int32_t> file_id(n);
  std::vector<double> timecode(n);
  for (int64_t k = 0; k < n; ++k) {
    file_id[k] = source.FileIdOf(selected[k]);
    timecode[k] = source.TimecodeOf(selected[k]);
  }
  f->WriteVector(io::frames::kSourceIndex, index);
  f->SetAttribute(io::frames::kSourceIndex, "meaning", std::string("frame index in the video, or image index in the folder"));
  f->WriteVector(io::frames::kSourceFileId, file_id);
  f->SetAttribute(io::frames::kSourceFileId, "meaning", std::string("row of /sources/files"));
  f->WriteVector(io::frames::kTimecode, timecode);
  f->SetAttribute(io::frames::kTimecode, "units", std::string("seconds from the start of the video (-1: still image)"));
  f->WriteStrings("/sources/files", source.Files());
  f->SetAttribute("/sources/files", "fps", source.Fps());
  f->SetAttribute("/sources/files", "num_frames", source.NumFrames());
  f->SetAttribute("/", "crop_padding", o.crop_padding);
  f->SetAttribute("/", "crop_raise", o.crop_raise);
  f->WriteVector<double>("/camera/fov_deg", {o.fov_deg});
  f->SetAttribute("/camera/fov_deg", "meaning",
                  std::string("vertical field of view of the source camera (degrees), as "
                              "assumed by ingest's fov_deg; principal point at the image "
                              "centre, square pixels"));
}

// One ingest run: the input opened on every rank (one reader and one analyzer per thread),
// the output on rank 0, and the three passes over the selected frames.
class IngestRun {
 public:
  IngestRun(const IngestOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), ctx_(ctx), resolved_(resolved), comm_(ctx.comm), threads_(ThreadsPerRank(o.threads)),
        input_(o.video.empty() ? o.images : o.video) {
    sources_.resize(threads_);
    analyzers_.resize(threads_);
    dist::CoordinateExceptions(comm_, [&] {
      for (int t = 0; t < threads_; ++t) {
        sources_[t] = o.video.empty() ? face::FrameSource::OpenImages(o.images, o.max_image_pixels)
                                      : face::FrameSource::OpenVideo(o.video, o.max_image_pixels);
      }
      selected_ = SelectFrames(*sources_[0], o);
      analyzers_[0] = std::make_unique<face::FaceAnalyzer>(o.Analyzer());
      for (int t = 1; t < threads_; ++t) analyzers_[t] = analyzers_[0]->Clone();
    });
    n_ = static_cast<int64_t>(selected_.size());
  }

  // `start`: when the run began (for the frame rate).
  IngestSummary Run(std::chrono::steady_clock::time_point start) {
    out_ = OpenFrameOutput(ctx_, resolved_, "ingest", o_.out, n_,
                           [&](io::H5File* f, bool resumed) {
                             CreateIngestDatasets(f, n_, o_.crop_size);
                             if (!resumed) WriteSourceRecords(f, *sources_[0], selected_, o_);
                           },
                           "frames", "/progress/detected");
    if (out_.up_to_date) {
      IngestSummary s;
      if (comm_.IsMainRank()) {
        s = ReadIngestSummary(o_.out);
        FC_INFO("ingest: {}", s.Line());
      }
      return s;
    }
    FrameLoopOptions loop;
    loop.what = "ingest detect";
    loop.batch = o_.batch;
    loop.threads = threads_;
    RunFrameLoop(
        comm_, out_.pending, n_, loop, [&](int64_t k, int thread) { return Detect(k, thread); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          CommitDetections(frames, results);
        });
    PlanSubject();
    loop.what = "ingest landmarks";
    RunFrameLoop(
        comm_, pending_landmarks_, n_, loop, [&](int64_t k, int thread) { return Landmark(k, thread); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          CommitLandmarks(frames, results);
        });
    return Finish(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }

 private:

  // Pass 1: decode frame k and detect its faces.
  std::vector<uint8_t> Detect(int64_t k, int thread) {
    face::DecodedFrame frame = sources_[thread]->Read(selected_[k]);
    ByteWriter w;
    w.Put<int32_t>(frame.ok ? 1 : 0);
    w.Put<int32_t>(frame.input_flags);
    w.Put<int32_t>(frame.source_width);
    w.Put<int32_t>(frame.source_height);
    std::vector<float> boxes;
    if (frame.ok) {
      const std::vector<face::FaceBox> faces = analyzers_[thread]->Detect(frame.image);
      const double s = frame.source_scale;
      for (size_t j = 0; j < faces.size() && j < static_cast<size_t>(kMaxFaces); ++j) {
        const face::FaceBox& b = faces[j];
        for (float v : {static_cast<float>(b.x * s), static_cast<float>(b.y * s),
                        static_cast<float>(b.width * s), static_cast<float>(b.height * s), b.score}) {
          boxes.push_back(v);
        }
      }
    }
    w.PutVector(boxes);
    w.PutVector(std::vector<char>(frame.error.begin(), frame.error.end()));
    return std::move(w.bytes());
  }

  void CommitDetections(const std::vector<int64_t>& frames,
                        const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = out_.output.file;
    ForEachRun(frames, [&](int64_t first, int64_t count, size_t begin) {
      std::vector<float> boxes(count * kMaxFaces * 5, 0.f);
      std::vector<int32_t> num(count), size(count * 2), flags(count), status(count);
      for (int64_t j = 0; j < count; ++j) {
        ByteReader r(results[begin + j]);
        const bool ok = r.Get<int32_t>() != 0;
        flags[j] = r.Get<int32_t>();
        size[2 * j] = r.Get<int32_t>();
        size[2 * j + 1] = r.Get<int32_t>();
        const std::vector<float> b = r.GetVector<float>();
        const std::vector<char> error = r.GetVector<char>();
        num[j] = static_cast<int32_t>(b.size() / 5);
        std::copy(b.begin(), b.end(), boxes.begin() + j * kMaxFaces * 5);
        // Provisional status; the subject pass sets the final one.
        status[j] = ok ? (num[j] ? kFrameFound : kFrameNoFace) : kFrameUnreadable;
        if (!ok && unreadable_logged_++ < 5) {
          FC_WARN("ingest: frame {} (source {}) is unreadable: {}", first + j, selected_[first + j],
                  std::string(error.begin(), error.end()));
        }
      }
      f.WriteFrames<float>("/detections/boxes", first, count, boxes.data());
      f.WriteFrames<int32_t>("/detections/count", first, count, num.data());
      f.WriteFrames<int32_t>(io::frames::kImageSize, first, count, size.data());
      f.WriteFrames<int32_t>(io::frames::kInputFlags, first, count, flags.data());
      f.WriteFrames<int32_t>(io::frames::kStatus, first, count, status.data());
    });
    io::DoneMask mask(&f, n_, "/progress/detected");
    mask.MarkDone(frames);
  }

  // Rank 0: the smallest face the detector can find at the first readable frame's size.
  void LogSmallestFace(io::H5File* f, const std::vector<int32_t>& provisional) {
    const std::vector<int32_t> image_size = f->Read<int32_t>(io::frames::kImageSize, {n_, 2});
    for (int64_t k = 0; k < n_; ++k) {
      if (provisional[k] == kFrameUnreadable) continue;
      double w = image_size[2 * k], h = image_size[2 * k + 1];
      const double budget = std::sqrt(static_cast<double>(o_.max_image_pixels) / std::max(1.0, w * h));
      const double to_source = budget < 1.0 ? 1.0 / budget : 1.0;  // source px per processed px
      w /= to_source;
      h /= to_source;
      const double first = analyzers_[0]->SmallestFace(static_cast<int>(w), static_cast<int>(h)) * to_source;
      const double smallest = analyzers_[0]->SmallestFaceWithSearch(static_cast<int>(w), static_cast<int>(h)) * to_source;
      FC_INFO("ingest: at {}x{}{} faces narrower than about {:.0f} px are not found ({:.0f} px "
              "before the small-face search); narrower than min_face_size {} px: too small",
              image_size[2 * k], image_size[2 * k + 1], o_.video.empty() ? " (the first image)" : "",
              smallest, first, o_.min_face_size);
      if (!o_.video.empty()) f->SetAttribute("/frames", "smallest_face_found", smallest);
      break;
    }
  }

  // Pass 2: follow the subject over the boxes of all frames (rank 0), then share the plan.
  void PlanSubject() {
    plan_status_.assign(n_, kFrameNoFace);
    plan_box_.assign(n_ * 5, 0.f);
    dist::CoordinateExceptions(comm_, [&] {
      if (!comm_.IsMainRank()) return;
      io::H5File& f = out_.output.file;
      const std::vector<float> boxes = f.Read<float>("/detections/boxes", {n_, kMaxFaces, 5});
      const std::vector<int32_t> count = f.ReadVector<int32_t>("/detections/count", n_);
      const std::vector<int32_t> provisional = f.ReadVector<int32_t>(io::frames::kStatus, n_);
      LogSmallestFace(&f, provisional);
      std::vector<std::vector<face::FaceBox>> faces(n_);
      for (int64_t k = 0; k < n_; ++k) {
        for (int j = 0; j < count[k]; ++j) {
          const float* b = &boxes[(k * kMaxFaces + j) * 5];
          faces[k].push_back(face::FaceBox{b[0], b[1], b[2], b[3], b[4]});
        }
      }
      // A video follows one subject from frame to frame; the images of a folder are unrelated
      // stills (other sizes, framings, people), so each keeps its largest face.
      std::vector<int> chosen(n_, -1);
      if (o_.video.empty()) {
        for (int64_t k = 0; k < n_; ++k) chosen[k] = faces[k].empty() ? -1 : 0;
      } else {
        chosen = face::FollowSubject(faces, face::SubjectTrackerOptions{o_.track_min_iou, o_.track_max_gap});
      }
      for (int64_t k = 0; k < n_; ++k) {
        if (provisional[k] == kFrameUnreadable) {
          plan_status_[k] = kFrameUnreadable;
        } else if (faces[k].empty()) {
          plan_status_[k] = kFrameNoFace;
        } else if (chosen[k] < 0) {
          plan_status_[k] = kFrameSubjectAbsent;
        } else {
          const face::FaceBox& b = faces[k][chosen[k]];
          plan_status_[k] = b.width < o_.min_face_size ? kFrameFaceTooSmall : kFrameFound;
          const float values[5] = {b.x, b.y, b.width, b.height, b.score};
          std::copy(values, values + 5, plan_box_.begin() + k * 5);
        }
      }
      if (!f.Exists(io::frames::kBox)) {
        f.WriteMatrix(io::frames::kBox, Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 5, Eigen::RowMajor>>(
                                         plan_box_.data(), n_, 5));
        f.SetAttribute(io::frames::kBox, "columns", std::string("x, y, width, height, score of the subject's face (source pixels; zeros: none)"));
      }
      io::DoneMask done(&f, n_, "/progress/done");
      pending_landmarks_ = done.Pending();
    });
    comm_.Broadcast(&plan_status_);
    comm_.Broadcast(&plan_box_);
  }

  // Pass 3: landmarks and the aligned crop of the subject's face in frame k.
  std::vector<uint8_t> Landmark(int64_t k, int thread) {
    ByteWriter w;
    int32_t status = plan_status_[k];
    if (status != kFrameFound) {
      w.Put(status);
      return std::move(w.bytes());
    }
    face::DecodedFrame frame = sources_[thread]->Read(selected_[k]);
    if (!frame.ok) {
      w.Put<int32_t>(kFrameUnreadable);
      return std::move(w.bytes());
    }
    const double s = frame.source_scale;
    const float* b = &plan_box_[k * 5];
    const face::FaceBox box{static_cast<float>(b[0] / s), static_cast<float>(b[1] / s),
                            static_cast<float>(b[2] / s), static_cast<float>(b[3] / s), b[4]};
    const face::Landmarks landmarks = analyzers_[thread]->FitLandmarks(frame.image, box);
    const face::CropOptions crop_options{o_.crop_size, o_.crop_padding, o_.crop_raise};
    const face::AlignedCrop crop = face::AlignFace(frame.image, landmarks, crop_options);
    // Landmarks and the crop transform in source pixels.
    const face::Landmarks source_landmarks = landmarks * static_cast<float>(s);
    face::Similarity2 t = crop.transform;
    t.scale /= s;
    const Eigen::Matrix<double, 2, 3> m = t.Matrix();
    w.Put(status);
    w.PutArray(source_landmarks.data(), kL * 2);
    w.PutArray(crop.landmarks.data(), kL * 2);
    const float transform[6] = {static_cast<float>(m(0, 0)), static_cast<float>(m(0, 1)),
                                static_cast<float>(m(0, 2)), static_cast<float>(m(1, 0)),
                                static_cast<float>(m(1, 1)), static_cast<float>(m(1, 2))};
    w.PutArray(transform, 6);
    w.PutVector(crop.image.data);
    return std::move(w.bytes());
  }

  void CommitLandmarks(const std::vector<int64_t>& frames,
                       const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = out_.output.file;
    const int S = o_.crop_size;
    ForEachRun(frames, [&](int64_t first, int64_t count, size_t begin) {
      std::vector<int32_t> status(count);
      std::vector<uint8_t> found(count, 0);
      std::vector<float> lm(count * kL * 2, 0.f), lm_crop(count * kL * 2, 0.f), tf(count * 6, 0.f);
      std::vector<uint8_t> crops(count * S * S * 3, 0);
      for (int64_t j = 0; j < count; ++j) {
        ByteReader r(results[begin + j]);
        status[j] = r.Get<int32_t>();
        if (status[j] != kFrameFound) continue;
        found[j] = 1;
        const auto a = r.GetVector<float>();
        const auto c = r.GetVector<float>();
        const auto t = r.GetVector<float>();
        const auto img = r.GetVector<uint8_t>();
        std::copy(a.begin(), a.end(), lm.begin() + j * kL * 2);
        std::copy(c.begin(), c.end(), lm_crop.begin() + j * kL * 2);
        std::copy(t.begin(), t.end(), tf.begin() + j * 6);
        std::copy(img.begin(), img.end(), crops.begin() + j * S * S * 3);
      }
      f.WriteFrames<int32_t>(io::frames::kStatus, first, count, status.data());
      f.WriteFrames<uint8_t>(io::frames::kFound, first, count, found.data());
      f.WriteFrames<float>(io::frames::kLandmarks, first, count, lm.data());
      f.WriteFrames<float>(io::frames::kLandmarksCrop, first, count, lm_crop.data());
      f.WriteFrames<float>(io::frames::kCropTransform, first, count, tf.data());
      f.WriteFrames<uint8_t>(io::frames::kCrop, first, count, crops.data());
    });
    io::DoneMask mask(&f, n_, "/progress/done");
    mask.MarkDone(frames);
  }

  // The summary in the file's attributes, then the final name (with a face at all).
  IngestSummary Finish(double seconds) {
    IngestSummary summary;
    dist::CoordinateExceptions(comm_, [&] {
      if (!comm_.IsMainRank()) return;
      io::H5File& f = out_.output.file;
      f.Flush();
      summary = SummaryOf(f.ReadVector<int32_t>(io::frames::kStatus, n_),
                          f.ReadVector<int32_t>(io::frames::kInputFlags, n_));
      for (const auto& [name, value] :
           {std::pair<const char*, int64_t>{"num_frames", summary.frames}, {"num_found", summary.found},
            {"num_no_face", summary.no_face}, {"num_face_too_small", summary.face_too_small},
            {"num_unreadable", summary.unreadable}, {"num_subject_absent", summary.subject_absent},
            {"num_from_grayscale", summary.from_grayscale}, {"num_from_16bit", summary.from_16bit},
            {"num_downscaled", summary.downscaled}}) {
        f.SetAttribute("/frames", name, value);
      }
      // Without a face the output is no stage's input: it stays under its .partial name.
      if (summary.found > 0) f.Commit();
    });
    summary.seconds = seconds;
    if (comm_.IsMainRank()) {
      FC_INFO("ingest: {} -> {}", input_, o_.out);
      FC_INFO("ingest summary: {}", summary.Line());
      FC_INFO("ingest: {:.1f} s, {:.1f} frames/s on {} rank(s) x {} thread(s)", summary.seconds,
              n_ / std::max(1e-9, summary.seconds), comm_.size(), threads_);
    }
    int64_t found = summary.found;
    comm_.Broadcast(&found, sizeof(found));
    if (found == 0) {
      throw FileIOError(input_ + ": no face found in any of the " + std::to_string(n_) +
                        " frames (the per-frame accounting is in " + io::H5File::PartialPath(o_.out) +
                        ", /frames/status; nothing was written to " + o_.out + ")");
    }
    return summary;
  }

  const IngestOptions& o_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  const int threads_;
  const std::string input_;
  std::vector<std::unique_ptr<face::FrameSource>> sources_;
  std::vector<std::unique_ptr<face::FaceAnalyzer>> analyzers_;
  std::vector<int64_t> selected_;
  int64_t n_ = 0;
  FrameOutput out_;  // pending: the frames still to detect
  std::vector<int64_t> pending_landmarks_;
  int64_t unreadable_logged_ = 0;
  std::vector<int32_t> plan_status_;  // each frame's status after the subject pass
  std::vector<float> plan_box_;       // [n, 5] the subject's box (source pixels)
};

}  // namespace

IngestSummary ReadIngestSummary(const std::string& path) {
  io::H5File f = io::H5File::OpenRead(path);
  const std::vector<int32_t> status = f.ReadVector<int32_t>(io::frames::kStatus);
  return SummaryOf(status, f.ReadVector<int32_t>(io::frames::kInputFlags, static_cast<int64_t>(status.size())));
}

IngestSummary RunIngest(const IngestOptions& o, const StageContext& ctx, const io::Config& resolved) {
  const auto start = std::chrono::steady_clock::now();
  IngestRun run(o, ctx, resolved);
  return run.Run(start);
}

}  // namespace facecap::stages
