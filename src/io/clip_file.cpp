#include "io/clip_file.h"

#include "io/camera_file.h"
#include "io/frames_file.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

// FileIOError naming the file when `name` does not have `expected` (-1: any) shape.
void CheckTruthShape(const H5File& f, const char* name, const Shape& expected,
                     const std::string& meaning) {
  const Shape actual = f.DatasetShape(name);
  bool ok = actual.size() == expected.size();
  for (size_t i = 0; ok && i < expected.size(); ++i) {
    if (expected[i] >= 0 && actual[i] != expected[i]) ok = false;
  }
  if (!ok) {
    throw FileIOError(f.path() + ": " + name + " has shape " + ShapeToString(actual) +
                      ", expected " + ShapeToString(expected) + " (" + meaning + ")");
  }
}

}  // namespace

ClipTruth ReadClipTruth(const H5File& f) {
  for (const char* name : {frames::kWeights, frames::kShapeNames, frames::kPose}) {
    if (!f.Exists(name)) {
      throw FileIOError(f.path() + ": no " + std::string(name) + " (not a clip from synth clip?)");
    }
  }
  ClipTruth t;
  t.names = f.ReadStrings(frames::kShapeNames);
  const int64_t shapes = static_cast<int64_t>(t.names.size());
  CheckTruthShape(f, frames::kWeights, {-1, shapes},
                  "frames by the " + std::to_string(shapes) + " of " + frames::kShapeNames);
  t.weights = f.ReadMatrix<float>(frames::kWeights);
  const int64_t n = t.weights.rows();
  const std::string rows = "one row of 3 per frame of " + std::string(frames::kWeights);
  CheckTruthShape(f, frames::kPose, {n, 3}, rows);
  t.pose = f.ReadMatrix<float>(frames::kPose);
  if (f.Exists(frames::kTranslation)) {
    CheckTruthShape(f, frames::kTranslation, {n, 3}, rows);
    t.translation = f.ReadMatrix<float>(frames::kTranslation);
  } else {
    t.translation.resize(0, 3);
  }
  t.fps = HasCamera(f) ? ReadCamera(f).fps.value_or(0.) : 0.;
  return t;
}

}  // namespace facecap::io
