// Fuzz target: the reader of ingest outputs (frames.h5), stages::IngestedFrames::Read.
//
// Feeds: a structure-aware description (fuzz_support.h) of a frames file: the datasets the
// reader expects (/frames/crop, found, crop_transform, landmarks, image_size, source_index,
// timecode, /camera/fov_deg) and /sources/files@fps, each present or not, with its element
// type, rank, small dimensions and values taken from the input; written with io::H5File, then
// read, and every accessor a stage calls is run over every frame the result claims to have.
// Failure: a crash, a sanitizer report (out-of-bounds read, undefined behaviour, leak), an
// exception other than FileIOError, a FileIOError that does not name the file, or a result
// that breaks the reader's promises (a found frame without a finite camera or landmarks).
#include <cstdint>
#include <cstdio>

#include "fuzz_support.h"
#include "render/camera.h"
#include "stages/ingested_frames.h"

namespace facecap::fuzz {
namespace {

FileSpec BaseFrames(FuzzedDataProvider& in) {
  // Empty input: 3 frames of 4 x 4 crops, the second without a face.
  const int64_t n = (in.ConsumeIntegralInRange<int>(0, 5) + 3) % 6;
  const int64_t c = 4 - in.ConsumeIntegralInRange<int>(0, 3);
  FileSpec spec;
  auto& d = spec.datasets;
  std::vector<double> crop, found, transform, landmarks, size, index, timecode;
  for (int64_t k = 0; k < n; ++k) {
    const bool face = k % 3 != 1;
    found.push_back(face ? 1. : 0.);
    for (int64_t i = 0; i < c * c * 3; ++i) crop.push_back(static_cast<double>((k + i) % 256));
    const double t[6] = {0.25, 0.01, -40., -0.01, 0.25, -30.};
    for (double x : t) transform.push_back(face ? x : 0.);
    for (int l = 0; l < 68; ++l) {
      landmarks.push_back(face ? 200. + l : 0.);
      landmarks.push_back(face ? 150. + 0.5 * l : 0.);
    }
    size.push_back(640.);
    size.push_back(480.);
    index.push_back(static_cast<double>(2 * k));
    timecode.push_back(2. * static_cast<double>(k) / 25.);
  }
  d["/frames/crop"] = Numeric(Kind::kUInt8, {n, c, c, 3}, crop);
  d["/frames/found"] = Numeric(Kind::kUInt8, {n}, found);
  d["/frames/crop_transform"] = Numeric(Kind::kFloat32, {n, 2, 3}, transform);
  d["/frames/landmarks"] = Numeric(Kind::kFloat32, {n, 68, 2}, landmarks);
  d["/frames/image_size"] = Numeric(Kind::kInt32, {n, 2}, size);
  d["/frames/source_index"] = Numeric(Kind::kInt64, {n}, index);
  d["/frames/timecode"] = Numeric(Kind::kFloat64, {n}, timecode);
  d["/camera/fov_deg"] = Numeric(Kind::kFloat64, {1}, {40.});
  d["/sources/files"] = Strings({"clip.mp4"});
  spec.attributes[{"/sources/files", "fps"}] = DoubleAttribute(25.);
  return spec;
}

const Slots& FrameSlots() {
  static const Slots slots = {
      {"/frames/crop", "/frames/found", "/frames/crop_transform", "/frames/landmarks",
       "/frames/image_size", "/frames/source_index", "/frames/timecode", "/camera/fov_deg",
       "/sources/files"},
      {{"/sources/files", "fps"}, {"/camera/fov_deg", "meaning"}},
      {"clip.mp4", ""}};
  return slots;
}

bool Finite(const render::Camera& c) {
  return std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy);
}

// What the stages do with an ingest output: every frame's camera, crop camera, landmarks and
// poses moved between the two cameras.
void Exercise(const stages::IngestedFrames& frames) {
  const int64_t n = frames.NumFrames();
  if (static_cast<int64_t>(frames.found().size()) != n) Fail("found() size differs");
  if (frames.crop_size() <= 0) Fail("crop size " + std::to_string(frames.crop_size()));
  if (!(frames.fov_deg() > 1. && frames.fov_deg() < 170.)) Fail("fov_deg out of range");
  if (!std::isfinite(frames.fps()) || frames.fps() < 0.) Fail("fps not finite");
  double sink = 0.;
  for (int64_t k = 0; k < n; ++k) {
    sink += static_cast<double>(frames.SourceIndex(k)) + frames.Timecode(k);
    const render::Camera source = frames.SourceCamera(k);
    for (int out_size : {64, frames.crop_size()}) {
      const render::CropView view = frames.CropCamera(k, out_size);
      const auto crop_landmarks = frames.CropLandmarks(k, out_size);
      rig::RigidPose pose;
      const rig::RigidPose in_crop = stages::PoseInCrop(pose, view);
      const rig::RigidPose back = stages::PoseInSource(in_crop, view);
      sink += back.translation.sum() + crop_landmarks.sum();
      if (frames.Found(k)) {
        if (!Finite(view.camera) || !(view.camera.fx > 0.f)) {
          Fail("found frame " + std::to_string(k) + " has a crop camera that is not finite");
        }
        if (!crop_landmarks.allFinite()) {
          Fail("found frame " + std::to_string(k) + " has crop landmarks that are not finite");
        }
      }
    }
    const auto landmarks = frames.SourceLandmarks(k);
    sink += landmarks.sum();
    if (frames.Found(k)) {
      if (source.width <= 0 || source.height <= 0 || !Finite(source)) {
        Fail("found frame " + std::to_string(k) + " has no usable source camera");
      }
      if (!landmarks.allFinite()) Fail("found frame " + std::to_string(k) + " landmarks");
    }
  }
  if (DescribeRequested()) std::fprintf(stderr, "read %lld frames (%g)\n",
                                        static_cast<long long>(n), sink);
}

}  // namespace
}  // namespace facecap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facecap;
  using namespace facecap::fuzz;
  return RunHdf5Input(data, size, BaseFrames, FrameSlots(), "frames.h5",
                      [](const std::string& path) {
                        Exercise(stages::IngestedFrames::Read(path));
                      });
}
