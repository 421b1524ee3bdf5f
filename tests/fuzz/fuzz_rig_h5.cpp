// Fuzz target: the reader of rig files (rig.h5, person.h5), io::ReadRigFile.
//
// Feeds: a structure-aware description (fuzz_support.h) of a rig file: every dataset of the
// /rig layout (rig_io.h: neutral, triangles, uvs, uv_triangles, triangle_region, regions,
// jaw, shapes and their sparse deltas, landmarks, identity_modes), starting from a small valid
// rig (fuzz_support.h: SmallRig, with or without uvs, landmarks and identity modes), each
// present or not, with its element type, rank, small dimensions and values taken from the
// input; written with io::H5File, then read, and the rig is used as stages use it: evaluated
// at zero, unit and mixed weights, posed, its landmarks and identity modes applied.
// Failure: a crash, a sanitizer report, an exception other than FileIOError, a FileIOError
// that does not name the file, or a rig that is returned but fails Rig::Check.
#include <cstdint>
#include <cstdio>

#include "fuzz_support.h"
#include "io/rig_io.h"
#include "rig/evaluate.h"

namespace facecap::fuzz {
namespace {

FileSpec BaseRig(FuzzedDataProvider& in) {
  // Empty input: uvs, 68 landmarks, two identity modes.
  const int variant = in.ConsumeIntegralInRange<int>(0, 7);
  const int modes = in.ConsumeIntegralInRange<int>(0, 2);
  FileSpec spec;
  AddRig(SmallRig((variant & 1) == 0, (variant & 2) == 0, 2 - modes), "/rig", &spec);
  spec.attributes[{"/rig/neutral", "units"}] = StringAttribute("cm");
  return spec;
}

const Slots& RigSlots() {
  static const Slots slots = {
      {"/rig/neutral", "/rig/triangles", "/rig/uvs", "/rig/uv_triangles", "/rig/triangle_region",
       "/rig/regions/names", "/rig/regions/colors", "/rig/jaw/weights", "/rig/jaw/pivot",
       "/rig/shapes/names", "/rig/shapes/jaw_euler", "/rig/shapes/jaw_translation",
       "/rig/shapes/deltas/row_offsets", "/rig/shapes/deltas/vertex",
       "/rig/shapes/deltas/offset", "/rig/landmarks", "/rig/identity_modes"},
      {{"/rig/neutral", "units"}},
      {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft", "skin", "lips", ""}};
  return slots;
}

void Exercise(const rig::Rig& rig) {
  std::string why;
  if (!rig.Check(&why)) Fail("ReadRigFile returned a rig that fails Check: " + why);
  const rig::RigEvaluator evaluator(rig);
  const int S = rig.NumShapes();
  rig::Vertices out;
  double sink = 0.;
  for (const Eigen::VectorXf& w :
       {Eigen::VectorXf(Eigen::VectorXf::Zero(S)), Eigen::VectorXf(Eigen::VectorXf::Ones(S)),
        Eigen::VectorXf(Eigen::VectorXf::LinSpaced(S, -0.5f, 1.f))}) {
    evaluator.EvaluateShape(w, &out);
    sink += out.sum();
    rig::RigidPose pose;
    pose.yaw = 0.3f;
    evaluator.EvaluatePosed(pose, w, &out);
    for (Eigen::Index l = 0; l < rig.landmarks.size(); ++l) sink += out.row(rig.landmarks[l]).sum();
  }
  for (int s = 0; s < S; ++s) {
    if (rig.ShapeIndex(rig.shapes[s].name) != s) Fail("shape names are not unique");
  }
  for (const rig::Vertices& mode : rig.identity_modes) sink += (rig.neutral + mode).sum();
  if (DescribeRequested()) std::fprintf(stderr, "read a rig of %d shapes (%g)\n", S, sink);
}

}  // namespace
}  // namespace facecap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facecap;
  using namespace facecap::fuzz;
  return RunHdf5Input(data, size, BaseRig, RigSlots(), "rig.h5",
                      [](const std::string& path) { Exercise(io::ReadRigFile(path)); });
}
