// facecap assemble (paper 001 Sec. 6): a personalized rig with secondary parts, and
// eval assembly, their checks on the held-out people of a scan database.
//   assemble: eyeballs with a procedural iris matched to the albedo and a cornea, lacrimal
//     fluid, eyelashes, teeth, gums and tongue, placed on the person's face and driven by each
//     of their shapes (a linear fit of the template's shapes; the jaw's parts follow the jaw);
//     writes the rig file with /parts, which rig export and export gltf add as separate meshes;
//   eval assembly: secondary parts on the held-out people of a scan database, over every shape
//     and random weight combinations (eyelash roots to the lid surface, eyelid vertices inside
//     the eyeballs, lower teeth against the jaw's rotation), beside the generic parts and the
//     coefficient fit alone.
#ifndef FACECAP_STAGES_ASSEMBLE_STAGE_H_
#define FACECAP_STAGES_ASSEMBLE_STAGE_H_

#include <string>

#include "assets/secondary_parts.h"
#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [assemble]
struct AssembleOptions {
  std::string rig = "rig.h5";         // personalized rig (blendshapes infer, textures infer)
  std::string out = "assembled.h5";   // the rig file with /parts
  int head_resolution = 60;           // demo head resolution of the rig's topology
  int clearance_shapes = 8;           // lids clear the eyeballs in combinations of this many shapes
  int iris = -1;                      // procedural iris; -1: matched to the rig's albedo
  int iris_size = 256;                // iris texture size

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "personalized rig (HDF5 with /rig, e.g. blendshapes infer or textures infer); its /texture and "
                  "/dynamic_texture are carried over");
    v("out", out, "assembled rig file: the input's rig, textures and library plus /parts");
    v("head_resolution", head_resolution, "demo head resolution of the rig's topology (the scan database's "
                                          "head_resolution), [60, 300]");
    v("clearance_shapes", clearance_shapes, "an eyeball is set back until the lids clear it in every combination of this "
                                            "many shapes at weights in [0, 1], [0, 64]; 0: never set back");
    v("iris", iris, "procedural iris [0, 11]; -1 picks the one nearest the albedo's iris colour (0 without albedo)");
    v("iris_size", iris_size, "iris texture size in texels, [16, 4096]");
  }
  bool Check(std::string* why) const {
    if (rig.empty() || out.empty()) { *why = "rig and out must name files"; return false; }
    if (head_resolution < 60 || head_resolution > 300) { *why = "head_resolution must be in [60, 300]"; return false; }
    if (iris < -1 || iris >= static_cast<int>(assets::IrisColors().size())) {
      *why = "iris must be -1 or in [0, " + std::to_string(assets::IrisColors().size() - 1) + "]";
      return false;
    }
    if (iris_size < 16 || iris_size > 4096) { *why = "iris_size must be in [16, 4096]"; return false; }
    if (clearance_shapes < 0 || clearance_shapes > 64) { *why = "clearance_shapes must be in [0, 64]"; return false; }
    return true;
  }
};

// [eval.assembly]
struct EvalAssemblyOptions {
  std::string scans = "scans.h5";  // scan database (scans synth): held-out people with truth
  std::string model = "";          // blendshape model: the predicted rows
  int head_resolution = 60;
  int combinations = 1000;         // random weight combinations per person
  int clearance_shapes = 8;        // assembly: lids clear the eyeballs in combinations of this many shapes
  int seed = 1;
  bool json = true;
  std::string out = "";

  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "scan database with truth (scans synth)");
    v("model", model, "blendshape model (blendshapes train): adds the rows of the parts assembled onto each held-out "
                      "person's predicted shapes (empty: none)");
    v("head_resolution", head_resolution, "demo head resolution of the database's topology, [60, 300]");
    v("combinations", combinations, "random weight combinations per person (8 shapes at weights in [0, 1]), [0, 100000]");
    v("clearance_shapes", clearance_shapes, "assembly (as assemble): the lids clear the eyeballs in every combination of this "
                                            "many shapes at weights in [0, 1]; 0: no setback");
    v("seed", seed, "seed of the combinations");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
  }
  bool Check(std::string* why) const {
    if (scans.empty()) { *why = "scans must name a file"; return false; }
    if (head_resolution < 60 || head_resolution > 300) { *why = "head_resolution must be in [60, 300]"; return false; }
    if (combinations < 0 || combinations > 100000) { *why = "combinations must be in [0, 100000]"; return false; }
    if (seed < 0) { *why = "seed must be >= 0"; return false; }
    if (clearance_shapes < 0 || clearance_shapes > 64) { *why = "clearance_shapes must be in [0, 64]"; return false; }
    return true;
  }
};

// Runs assemble on rank 0 (the other ranks return at once, with an empty summary): the
// summary counts one file, the assembled rig, computed by this run.
StageSummary RunAssemble(const AssembleOptions& options, const StageContext& ctx,
                         const io::Config& resolved);

// Runs eval assembly on rank 0 (the other ranks return at once, with an empty summary): the
// summary counts one file, the JSON object (stdout, and out when given), computed by this run.
StageSummary RunEvalAssembly(const EvalAssemblyOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_ASSEMBLE_STAGE_H_
