// Fuzz target: the reader of tracking outputs (track.h5), stages::TrackedRig.
//
// Feeds: a structure-aware description (fuzz_support.h) of a track file: /track/shape_names,
// pose, translation, scale, weights, termination, source_index, timecode, /camera/intrinsics
// with its width attribute and /track@fps, each present or not, with its element type, rank,
// small dimensions and values taken from the input; written with io::H5File, then read against
// a small rig (fuzz_support.h: SmallRig) whose shapes the track names in part, and every
// accessor a stage calls is run over every frame the result claims to have, with the rig
// evaluated at each solved frame's pose and weights.
// Failure: a crash, a sanitizer report, an exception other than FileIOError, a FileIOError
// that does not name the file, or a result that breaks the reader's promises (weights of the
// wrong size, a camera that is not finite).
#include <cstdint>
#include <cstdio>

#include "fuzz_support.h"
#include "rig/evaluate.h"
#include "stages/tracked_rig.h"

namespace facecap::fuzz {
namespace {

const std::vector<std::string>& TrackedNames() {
  // The rig's three shapes and one it lacks.
  static const std::vector<std::string> names = {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft",
                                                 "browInnerUp"};
  return names;
}

FileSpec BaseTrack(FuzzedDataProvider& in) {
  // Empty input: 3 frames (the second unsolved), 4 tracked shapes, from footage.
  const int64_t n = (in.ConsumeIntegralInRange<int>(0, 5) + 3) % 6;
  const int64_t s = 4 - in.ConsumeIntegralInRange<int>(0, 4);
  const bool footage = in.ConsumeIntegralInRange<int>(0, 1) == 0;
  FileSpec spec;
  auto& d = spec.datasets;
  std::vector<std::string> names(TrackedNames().begin(), TrackedNames().begin() + s);
  std::vector<double> pose, translation, scale, weights, termination, index, timecode;
  for (int64_t k = 0; k < n; ++k) {
    for (double x : {0.1, -0.05, 0.02}) pose.push_back(x * static_cast<double>(k + 1));
    for (double x : {0.5, -1., -60.}) translation.push_back(x);
    scale.push_back(1.);
    for (int64_t j = 0; j < s; ++j) weights.push_back(0.1 * static_cast<double>(j + k));
    termination.push_back(k % 3 == 1 ? 3. : 0.);
    index.push_back(static_cast<double>(3 * k));
    timecode.push_back(3. * static_cast<double>(k) / 30.);
  }
  d["/track/shape_names"] = Strings(names);
  d["/track/pose"] = Numeric(Kind::kFloat32, {n, 3}, pose);
  d["/track/translation"] = Numeric(Kind::kFloat32, {n, 3}, translation);
  d["/track/scale"] = Numeric(Kind::kFloat32, {n}, scale);
  d["/track/weights"] = Numeric(Kind::kFloat32, {n, s}, weights);
  d["/track/termination"] = Numeric(Kind::kInt32, {n}, termination);
  if (footage) {
    d["/track/source_index"] = Numeric(Kind::kInt64, {n}, index);
    d["/track/timecode"] = Numeric(Kind::kFloat64, {n}, timecode);
  }
  d["/camera/intrinsics"] = Numeric(Kind::kFloat64, {4}, {800., 800., 320., 240.});
  spec.groups = {"/track", "/camera"};
  spec.attributes[{"/camera/intrinsics", "width"}] = DoubleAttribute(640.);
  spec.attributes[{"/camera/intrinsics", "height"}] = DoubleAttribute(480.);
  spec.attributes[{"/track", "fps"}] = DoubleAttribute(30.);
  return spec;
}

const Slots& TrackSlots() {
  static const Slots slots = {
      {"/track/shape_names", "/track/pose", "/track/translation", "/track/scale",
       "/track/weights", "/track/termination", "/track/source_index", "/track/timecode",
       "/camera/intrinsics"},
      {{"/camera/intrinsics", "width"}, {"/camera/intrinsics", "height"}, {"/track", "fps"}},
      {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft", "browInnerUp", ""}};
  return slots;
}

bool Finite(const render::Camera& c) {
  return std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy);
}

// What exports and evaluations do with a track: every frame's pose and weights in the rig's
// shape order, the rig evaluated there, the camera at the sizes images are drawn at.
void Exercise(const stages::TrackedRig& track, const rig::Rig& rig) {
  const rig::RigEvaluator evaluator(rig);
  rig::Vertices posed;
  double sink = 0.;
  for (const auto& [w, h] : {std::pair<int, int>{640, 480}, {128, 128}}) {
    const render::Camera camera = track.CameraForWidth(w, h);
    if (!Finite(camera) || !(camera.fx > 0.f) || !(camera.fy > 0.f)) {
      Fail("the track's camera is not finite or not positive");
    }
  }
  if (!std::isfinite(track.fps()) || track.fps() < 0.) Fail("fps not finite");
  sink += track.HasCameraWidth() ? 1. : 0.;
  for (int64_t f = 0; f < track.NumFrames(); ++f) {
    const rig::RigidPose pose = track.Pose(f);
    const Eigen::VectorXf weights = track.Weights(f);
    if (weights.size() != rig.NumShapes()) Fail("weights of the wrong size");
    if (track.InSourceCamera()) {
      sink += static_cast<double>(track.SourceIndex(f)) + track.Timecode(f);
    }
    if (track.Solved(f)) {
      evaluator.EvaluatePosed(pose, weights, &posed);
      sink += posed.sum();
    }
  }
  if (DescribeRequested()) {
    std::fprintf(stderr, "read %lld frames (%g)\n", static_cast<long long>(track.NumFrames()),
                 sink);
  }
}

}  // namespace
}  // namespace facecap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facecap;
  using namespace facecap::fuzz;
  static const rig::Rig rig = SmallRig();
  return RunHdf5Input(data, size, BaseTrack, TrackSlots(), "track.h5",
                      [](const std::string& path) { Exercise(stages::TrackedRig(path, rig), rig); });
}
