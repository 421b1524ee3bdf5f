// facecap rig demo | import | export: make, bring in and write out rigs.
#include <filesystem>
#include <iostream>

#include "stages/rig_stage.h"

#include "io/hdf5.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "rig/arkit.h"
#include "rig/demo_head.h"
#include "rig/perturb.h"
#include "stages/parts_file.h"
#include "stages/rig_texture.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

void WriteRigFile(const rig::Rig& rig, const std::string& path, const io::Provenance& p) {
  io::H5File file = io::H5File::CreateAtomic(path);
  file.WriteProvenance(p);
  io::WriteRig(rig, &file);
  file.Commit();
}

}  // namespace

StageSummary RunRigDemo(const RigDemoOptions& o, const StageContext& ctx,
                        const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;  // a few milliseconds of work: rank 0 alone
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
  summary.items = summary.computed = 1;
  return summary;
}

StageSummary RunRigPerturb(const RigPerturbOptions& o, const StageContext& ctx,
                           const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
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
  summary.items = summary.computed = 1;
  return summary;
}

StageSummary RunRigImport(const RigImportOptions& o, const StageContext& ctx,
                          const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  rig::Rig rig = o.obj_dir.empty() ? io::ImportRigFromGltf(o.gltf)
                                   : io::ImportRigFromObjFolder(o.obj_dir);
  std::string why;
  if (!rig.Check(&why)) {
    throw FileIOError((o.obj_dir.empty() ? o.gltf : o.obj_dir) + ": imported rig is invalid: " + why);
  }
  WriteRigFile(rig, o.out, MakeProvenance(ctx, "rig import", resolved));
  FC_INFO("rig import: {} vertices, {} shapes -> {}", rig.NumVertices(), rig.NumShapes(), o.out);
  summary.items = summary.computed = 1;
  return summary;
}

StageSummary RunRigExport(const RigExportOptions& o, const StageContext& ctx,
                          const io::Config& /*resolved*/) {
  // The outputs: the OBJ folder and/or the glTF file.
  StageSummary summary{o.obj_dir.empty() || o.gltf.empty() ? o.obj_dir + o.gltf
                                                           : o.obj_dir + ", " + o.gltf,
                       "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const rig::Rig rig = io::ReadRigFile(o.rig);
  if (!o.obj_dir.empty()) {
    std::filesystem::create_directories(o.obj_dir);
    io::ExportRigToObjFolder(rig, o.obj_dir);
    FC_INFO("rig export: {} OBJ files in {}", rig.NumShapes() + 1, o.obj_dir);
    summary.items += rig.NumShapes() + 1;
  }
  if (!o.gltf.empty()) {
    const Image8 texture = ReadRigTextureSrgb(o.rig);
    const PartMeshes parts = ReadPartMeshes(o.rig, rig);
    io::ExportRigToGltf(parts.face, o.gltf, nullptr, 30.f, texture.empty() ? nullptr : &texture, &parts.meshes);
    FC_INFO("rig export: glTF with {} morph targets{}{} -> {}", rig.NumShapes(),
            texture.empty() ? "" : " and the rig file's texture",
            parts.meshes.empty() ? "" : ", " + std::to_string(parts.meshes.size()) + " secondary parts", o.gltf);
    summary.items += 1;
  }
  summary.computed = summary.items;
  return summary;
}

}  // namespace facecap::stages
