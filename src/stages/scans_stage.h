// facecap scans synth | import: the scan database (paper 001 Sec. 4, Sec. 7) in one HDF5
// layout (scans.h5, described at the top of scans_stage.cpp), synthetic with known personal
// shapes or imported from registered OBJ meshes.
//   scans synth: people from the demo head's identity modes, personal blendshapes that depend
//     on identity, FACS expression scans with unwanted motion and noise, and skin maps; the
//     true personal shapes are stored for evaluation;
//   scans import: registered OBJ scans (one per person and expression, listed in a labels
//     CSV), and the skin maps beside them, into the scan database layout.
#ifndef FACECAP_STAGES_SCANS_STAGE_H_
#define FACECAP_STAGES_SCANS_STAGE_H_

#include <string>
#include <vector>

#include "assets/scan_database.h"
#include "assets/template_shapes.h"
#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [scans.synth]
struct ScansSynthOptions {
  std::string out = "scans.h5";          // output scan database
  int people = 60;                       // number of people
  int test_people = 12;                  // the last test_people are held out
  int head_resolution = 60;              // demo head grid resolution (vertex count)
  std::vector<std::string> facs = assets::DefaultFacsTable();  // FACS table name=shape+shape
  int texture_size = 128;                // skin maps' width and height (0: meshes only)
  int threads = 0;                       // threads (0: the cores divided among the node's ranks)
  assets::ScanSynthOptions synth;        // personal shapes and capture noise

  template <class V>
  void Visit(V&& v) {
    v("out", out, "output scan database (HDF5)");
    v("people", people, "number of people");
    v("test_people", test_people, "the last test_people people are held out for evaluation");
    v("head_resolution", head_resolution, "demo head grid resolution ([60, 300]; 100 is about 9,000 vertices)");
    v("facs", facs, "FACS table: one 'name=shapeA+shapeB' entry per expression, covering every template shape");
    v("texture_size", texture_size, "width and height of the skin maps (albedo, specular, displacement) of every "
                                    "neutral and expression, [32, 2048]; 0 writes meshes only");
    v("threads", threads, "threads (0: the cores divided among the node's ranks)");
    synth.Visit(v);
  }
  bool Check(std::string* why) const {
    if (out.empty()) { *why = "out must name a file"; return false; }
    if (people < 2) { *why = "people must be >= 2"; return false; }
    if (test_people < 1 || test_people >= people) { *why = "test_people must be in [1, people)"; return false; }
    if (head_resolution < 60 || head_resolution > 300) { *why = "head_resolution must be in [60, 300]"; return false; }
    if (facs.empty()) { *why = "the FACS table is empty"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (texture_size != 0 && (texture_size < 32 || texture_size > 2048)) {
      *why = "texture_size must be 0 or in [32, 2048]";
      return false;
    }
    return synth.Check(why);
  }
};

// [scans.import]
struct ScansImportOptions {
  std::string labels = "labels.csv";  // CSV: person,expression,file,split (file relative to the CSV)
  std::string template_rig = "template.h5";  // rig file whose shapes are the template S_i
  std::vector<std::string> facs = assets::DefaultFacsTable();  // FACS table of the expressions
  std::string out = "scans.h5";       // output scan database
  int texture_size = 256;             // skin maps resampled to this size (0: meshes only)
  float displacement_scale_mm = 1.f;  // mm per unit of the displacement maps

  template <class V>
  void Visit(V&& v) {
    v("labels", labels, "labels CSV: person,expression,file,split; expression 'neutral' is the neutral, "
                        "split is train or test; files are OBJ meshes of the template's topology");
    v("template_rig", template_rig, "rig file (HDF5) whose shapes are the template blendshapes");
    v("facs", facs, "FACS table: one 'name=shapeA+shapeB' entry per expression");
    v("out", out, "output scan database (HDF5)");
    v("texture_size", texture_size, "skin maps found beside the meshes (MESH_albedo, MESH_specular, MESH_displacement "
                                    "with extension exr, tif, tiff, png or jpg, in the template's UV layout; albedo in sRGB unless float, "
                                    "specular and displacement from their first channel, displacement as floats) are "
                                    "resampled to this width and height, [32, 4096]; 0 imports meshes only");
    v("displacement_scale_mm", displacement_scale_mm, "millimetres per unit of the displacement maps (float EXR or TIFF)");
  }
  bool Check(std::string* why) const {
    if (labels.empty() || template_rig.empty() || out.empty()) {
      *why = "labels, template_rig and out must name files";
      return false;
    }
    if (facs.empty()) { *why = "the FACS table is empty"; return false; }
    if (texture_size != 0 && (texture_size < 32 || texture_size > 4096)) {
      *why = "texture_size must be 0 or in [32, 4096]";
      return false;
    }
    if (!(displacement_scale_mm > 0.f && displacement_scale_mm < 1e4f)) {
      *why = "displacement_scale_mm must be in (0, 1e4)";
      return false;
    }
    return true;
  }
};

// scans synth, collective: every rank synthesizes its block of people, rank 0 writes the
// database to options.out. The summary counts people, the same on every rank (computed 0 when
// the output was up to date).
StageSummary RunScansSynth(const ScansSynthOptions& options, const StageContext& ctx,
                           const io::Config& resolved);

// scans import, collective (every rank learns of an error), the work on rank 0 alone: the
// database to options.out. The summary counts people on rank 0 (computed 0 when the output was
// up to date); 0 on the other ranks.
StageSummary RunScansImport(const ScansImportOptions& options, const StageContext& ctx,
                            const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SCANS_STAGE_H_
