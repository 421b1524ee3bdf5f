// facecap rig demo | import | perturb | export: make, bring in and write out rigs.
//   rig demo: the procedural demo head (a closed mesh with eyes, eyelids, lips and a mouth
//     opening, 12+ segmentation regions, the 68 iBUG landmarks, the 52 ARKit shapes and
//     identity modes) to a rig file;
//   rig import: a rig from an OBJ folder (neutral.obj + <shape>.obj) or a glTF file with
//     morph targets;
//   rig perturb: the rig with its neutral displaced by a smooth random field of a given RMS
//     (a known geometry error); shapes follow;
//   rig export: a rig to OBJ files and/or glTF.
// Each is a few milliseconds to seconds of work, done by rank 0 alone.
#ifndef FACECAP_STAGES_RIG_STAGE_H_
#define FACECAP_STAGES_RIG_STAGE_H_

#include <string>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [rig.demo]: the procedural demo head.
struct RigDemoOptions {
  std::string out = "rig.h5";       // output rig file
  int identity_seed = 0;            // person to make: 0 is the mean face, others sample the modes
  float identity_scale = 1.f;       // standard deviations of the identity sample
  int num_identity_modes = 24;      // identity modes stored in the rig (>= 20)

  template <class V>
  void Visit(V&& v) {
    v("out", out, "output rig file (HDF5)");
    v("identity_seed", identity_seed, "person to make: 0 is the mean face, any other seed samples "
                                      "the identity modes");
    v("identity_scale", identity_scale, "size of the identity sample in standard deviations");
    v("num_identity_modes", num_identity_modes, "identity modes stored in the rig");
  }
  bool Check(std::string* why) const {
    if (out.empty()) { *why = "out must name a file"; return false; }
    if (identity_seed < 0) { *why = "identity_seed must be >= 0"; return false; }
    if (!(identity_scale >= 0.f && identity_scale <= 3.f)) {
      *why = "identity_scale must be in [0, 3], got " + std::to_string(identity_scale);
      return false;
    }
    if (num_identity_modes < 0 || num_identity_modes > 64) {
      *why = "num_identity_modes must be in [0, 64]";
      return false;
    }
    return true;
  }
};

// [rig.import]: a rig from an OBJ folder or a glTF file.
struct RigImportOptions {
  std::string obj_dir;   // folder with neutral.obj and one OBJ per shape
  std::string gltf;      // glTF/GLB file with morph targets
  std::string out = "rig.h5";
  template <class V>
  void Visit(V&& v) {
    v("obj_dir", obj_dir, "folder with neutral.obj and one <shape>.obj per shape");
    v("gltf", gltf, "glTF or GLB file with morph targets");
    v("out", out, "output rig file (HDF5)");
  }
  bool Check(std::string* why) const {
    if (obj_dir.empty() == gltf.empty()) {
      *why = "give exactly one of obj_dir and gltf";
      return false;
    }
    return !out.empty() || (*why = "out must name a file", false);
  }
};

// [rig.export]: a rig to an OBJ folder and/or a glTF file.
struct RigExportOptions {
  std::string rig = "rig.h5";
  std::string obj_dir;
  std::string gltf;
  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5); the texture of a textured rig (appearance gather's output) "
                  "goes into the glTF");
    v("obj_dir", obj_dir, "write neutral.obj and one OBJ per shape into this folder");
    v("gltf", gltf, "write a glTF file with one morph target per shape");
  }
  bool Check(std::string* why) const {
    if (obj_dir.empty() && gltf.empty()) {
      *why = "give obj_dir and/or gltf";
      return false;
    }
    return true;
  }
};

// [rig.perturb]: the rig with a known geometry error, for robustness measurements.
struct RigPerturbOptions {
  std::string rig = "rig.h5";
  std::string out = "rig_perturbed.h5";
  double rms_mm = 3.;           // RMS displacement of the neutral's vertices (mm)
  double wavelength_mm = 20.;   // spatial scale of the displacement field (mm)
  int bumps = 48;               // random bumps the field is made of
  int seed = 1;                 // the field is a function of the seed alone

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5)");
    v("out", out, "output rig file (HDF5): the rig with its neutral displaced");
    v("rms_mm", rms_mm, "RMS displacement of the neutral's vertices (mm)");
    v("wavelength_mm", wavelength_mm, "spatial scale of the smooth displacement field: the sigma "
                                      "of its Gaussian bumps (mm)");
    v("bumps", bumps, "number of random bumps, centred on random vertices");
    v("seed", seed, "random seed of the field");
  }
  bool Check(std::string* why) const {
    if (!(rms_mm >= 0. && rms_mm <= 50.)) { *why = "rms_mm must be in [0, 50]"; return false; }
    if (!(wavelength_mm >= 1. && wavelength_mm <= 500.)) {
      *why = "wavelength_mm must be in [1, 500]";
      return false;
    }
    if (bumps < 1 || bumps > 10000) { *why = "bumps must be in [1, 10000]"; return false; }
    if (seed < 0) { *why = "seed must be >= 0"; return false; }
    return true;
  }
};

// rig demo, rank 0 alone: writes the demo head to options.out. The summary counts files (1 on
// rank 0; 0 on the other ranks, which do nothing).
StageSummary RunRigDemo(const RigDemoOptions& options, const StageContext& ctx,
                        const io::Config& resolved);

// rig import, rank 0 alone: the imported rig to options.out. The summary counts files (1 on
// rank 0, 0 on the other ranks).
StageSummary RunRigImport(const RigImportOptions& options, const StageContext& ctx,
                          const io::Config& resolved);

// rig perturb, rank 0 alone: the perturbed rig to options.out. The summary counts files (1 on
// rank 0, 0 on the other ranks).
StageSummary RunRigPerturb(const RigPerturbOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

// rig export, rank 0 alone: the OBJ folder and/or the glTF file. The summary's out is the OBJ
// folder and/or the glTF (", " between them) and it counts the files written on rank 0 (the
// shapes' OBJs and the neutral's, and the glTF); 0 on the other ranks.
StageSummary RunRigExport(const RigExportOptions& options, const StageContext& ctx,
                          const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RIG_STAGE_H_
