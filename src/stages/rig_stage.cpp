// facecap rig demo | import | export: make, bring in and write out rigs.
#include <filesystem>
#include <iostream>

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "rig/arkit.h"
#include "rig/demo_head.h"
#include "rig/perturb.h"
#include "stages/cli.h"
#include "stages/parts_file.h"
#include "stages/registry.h"
#include "stages/rig_texture.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

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

void WriteRigFile(const rig::Rig& rig, const std::string& path, const io::Provenance& p) {
  io::H5File file = io::H5File::CreateAtomic(path);
  file.WriteProvenance(p);
  io::WriteRig(rig, &file);
  file.Commit();
}

void RunRigDemo(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<RigDemoOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;  // a few milliseconds of work: rank 0 alone
  rig::DemoHeadOptions head;
  head.num_identity_modes = o.num_identity_modes;
  std::string why;
  if (!head.Check(&why)) throw InvalidInputError("[rig.demo] " + why);
  rig::Rig rig = rig::MakeDemoHead(head);
  if (o.identity_seed != 0) rig = rig::WithIdentity(rig, o.identity_seed, o.identity_scale);
  WriteRigFile(rig, o.out, MakeProvenance(ctx, "rig demo", resolved));
  FC_INFO("rig demo: {} vertices, {} triangles, {} shapes, {} regions, {} identity modes -> {}",
          rig.NumVertices(), rig.triangles.rows(), rig.NumShapes(), rig.regions.size(),
          rig.identity_modes.size(), o.out);
}

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

void RunRigPerturb(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<RigPerturbOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  rig::PerturbOptions perturb;
  perturb.rms_cm = o.rms_mm / 10.;
  perturb.wavelength_cm = o.wavelength_mm / 10.;
  perturb.bumps = o.bumps;
  perturb.seed = static_cast<uint64_t>(o.seed);
  const rig::Rig out = rig::PerturbNeutral(rig, perturb);
  WriteRigFile(out, o.out, MakeProvenance(ctx, "rig perturb", resolved));
  FC_INFO("rig perturb: neutral displaced by {:.2f} mm RMS (smooth field, {:.0f} mm scale) -> {}",
          o.rms_mm, o.wavelength_mm, o.out);
}

void RunRigImport(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<RigImportOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  rig::Rig rig = o.obj_dir.empty() ? io::ImportRigFromGltf(o.gltf)
                                   : io::ImportRigFromObjFolder(o.obj_dir);
  std::string why;
  if (!rig.Check(&why)) {
    throw FileIOError((o.obj_dir.empty() ? o.gltf : o.obj_dir) + ": imported rig is invalid: " + why);
  }
  WriteRigFile(rig, o.out, MakeProvenance(ctx, "rig import", resolved));
  FC_INFO("rig import: {} vertices, {} shapes -> {}", rig.NumVertices(), rig.NumShapes(), o.out);
}

void RunRigExport(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<RigExportOptions>(flags, &ctx, &resolved);
  if (!ctx.comm.IsMainRank()) return;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (!o.obj_dir.empty()) {
    std::filesystem::create_directories(o.obj_dir);
    io::ExportRigToObjFolder(rig, o.obj_dir);
    FC_INFO("rig export: {} OBJ files in {}", rig.NumShapes() + 1, o.obj_dir);
  }
  if (!o.gltf.empty()) {
    const Image8 texture = ReadRigTextureSrgb(o.rig);
    const PartMeshes parts = ReadPartMeshes(o.rig, rig);
    io::ExportRigToGltf(parts.face, o.gltf, nullptr, 30.f, texture.empty() ? nullptr : &texture, &parts.meshes);
    FC_INFO("rig export: glTF with {} morph targets{}{} -> {}", rig.NumShapes(),
            texture.empty() ? "" : " and the rig file's texture",
            parts.meshes.empty() ? "" : ", " + std::to_string(parts.meshes.size()) + " secondary parts", o.gltf);
  }
}

}  // namespace

void RegisterRig(CLI::App* app, AppState* state) {
  CLI::App* rig = app->add_subcommand("rig", "Make, import and export face rigs");
  rig->require_subcommand(1);

  AddStage<RigDemoOptions>(
      rig, state, "demo", "rig.demo", "rig demo",
      "Generate the procedural demo head: a closed mesh with eyes, eyelids, lips and a mouth "
      "opening, 12+ segmentation regions, the 68 iBUG landmarks, the 52 ARKit shapes (jaw "
      "shapes through jaw skinning) and identity modes",
      PathKeys{{}, {{"out", OutputKind::kHdf5}}},
      RunRigDemo);
  AddStage<RigImportOptions>(
      rig, state, "import", "rig.import", "rig import",
      "Import a rig from an OBJ folder (neutral.obj + <shape>.obj) or a glTF file with morph "
      "targets",
      PathKeys{{"obj_dir", "gltf"}, {{"out", OutputKind::kHdf5}}},
      RunRigImport);
  AddStage<RigPerturbOptions>(
      rig, state, "perturb", "rig.perturb", "rig perturb",
      "The rig with its neutral displaced by a smooth random field of a given RMS (a known "
      "geometry error, to measure how a stage copes with imperfect geometry); shapes follow",
      PathKeys{{"rig"}, {{"out", OutputKind::kHdf5}}}, RunRigPerturb);
  AddStage<RigExportOptions>(rig, state, "export", "rig.export", "rig export",
                             "Export a rig to OBJ files and/or glTF",
      PathKeys{{"rig"}, {{"obj_dir", OutputKind::kFolder}, {"gltf", OutputKind::kGltf}}},
      RunRigExport);
  RegisterRigCalibrate(rig, state);
}

}  // namespace facecap::stages
