// The command-line table, rigs and synthetic data: rig, render, synth, scans.
#include <string>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "app/registry.h"
#include "stages/render_stage.h"
#include "stages/rig_calibrate_stage.h"
#include "stages/rig_stage.h"
#include "stages/sample_set_stage.h"
#include "stages/scans_stage.h"
#include "stages/synth_clip_stage.h"
#include "stages/synth_crops_stage.h"
#include "stages/synth_stage.h"

namespace facecap::app {

using stages::OutputKind;
using stages::PathKeys;
using stages::RenderStageOptions;
using stages::RigCalibrateOptions;
using stages::RigDemoOptions;
using stages::RigExportOptions;
using stages::RigImportOptions;
using stages::RigPerturbOptions;
using stages::RunRender;
using stages::RunRigCalibrate;
using stages::RunRigDemo;
using stages::RunRigExport;
using stages::RunRigImport;
using stages::RunRigPerturb;
using stages::RunScansImport;
using stages::RunScansSynth;
using stages::RunSynthClip;
using stages::RunSynthContract;
using stages::RunSynthCrops;
using stages::RunSynthExpand;
using stages::RunSynthSamples;
using stages::RunSynthSheet;
using stages::ScansImportOptions;
using stages::ScansSynthOptions;
using stages::SynthClipOptions;
using stages::SynthContractOptions;
using stages::SynthCropsOptions;
using stages::SynthExpandOptions;
using stages::SynthSamplesOptions;
using stages::SynthSheetOptions;

void RegisterRig(CLI::App* app, AppState* state) {
  CLI::App* rig = app->add_subcommand("rig", "Make, import and export face rigs");
  rig->require_subcommand(1);

  AddStage<RigDemoOptions>(
      rig, state, "demo", "rig.demo", "rig demo",
      "Generate the procedural demo head: a closed mesh with eyes, eyelids, lips and a mouth "
      "opening, 12+ segmentation regions, the 68 iBUG landmarks, the 52 ARKit shapes (jaw "
      "shapes through jaw skinning) and identity modes",
      PathKeys{{}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunRigDemo));
  AddStage<RigImportOptions>(
      rig, state, "import", "rig.import", "rig import",
      "Import a rig from an OBJ folder (neutral.obj + <shape>.obj) or a glTF file with morph "
      "targets",
      PathKeys{{"obj_dir", "gltf"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunRigImport));
  AddStage<RigPerturbOptions>(
      rig, state, "perturb", "rig.perturb", "rig perturb",
      "The rig with its neutral displaced by a smooth random field of a given RMS (a known "
      "geometry error, to measure how a stage copes with imperfect geometry); shapes follow",
      PathKeys{{"rig"}, {{"out", OutputKind::kHdf5}}}, StageCommand(RunRigPerturb));
  AddStage<RigExportOptions>(rig, state, "export", "rig.export", "rig export",
                             "Export a rig to OBJ files and/or glTF",
      PathKeys{{"rig"}, {{"obj_dir", OutputKind::kFolder}, {"gltf", OutputKind::kGltf}}},
      StageCommand(RunRigExport));
  RegisterRigCalibrate(rig, state);
}

void RegisterRigCalibrate(CLI::App* rig, AppState* state) {
  AddStage<RigCalibrateOptions>(
      rig, state, "calibrate", "rig.calibrate", "rig calibrate",
      "Place the rig's 68 landmark vertices where dlib's detector finds the iBUG points on "
      "renders of people made of the rig (poses, expressions, lighting), so that fits to dlib's "
      "landmarks on footage measure the face, not the difference of conventions",
      PathKeys{{"rig", "landmark_model"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunRigCalibrate));
}

void RegisterRender(CLI::App* app, AppState* state) {
  AddStage<RenderStageOptions>(
      app, state, "render", "render", "render",
      "Render a rig at a pose and shape weights (segmentation, shaded, UV or depth) to PNG/EXR, "
      "or with --sheet a contact sheet of the neutral and expressions",
      PathKeys{{"rig"}, {{"out", OutputKind::kImage}, {"mesh_out", OutputKind::kMesh}}},
      StageCommand(RunRender));
}

void RegisterSynth(CLI::App* app, AppState* state) {
  CLI::App* synth = app->add_subcommand("synth", "Synthetic data with known truth");
  synth->require_subcommand(1);
  AddStage<SynthSamplesOptions>(
      synth, state, "samples", "synth.samples", "synth samples",
      "Random rig samples (controls uniform under per-region sparsity limits, pose from a "
      "truncated Gaussian) rendered as segmentation images with landmarks; spread across ranks, "
      "identical for any rank count, resumable",
      PathKeys{{"rig"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunSynthSamples));
  AddStage<SynthExpandOptions>(
      synth, state, "expand", "synth.expand", "synth expand",
      "Expand a contracted sample set (paper 000 Sec. 7.2): the real frames whose deepfake codes "
      "lie farthest from every sample's are gaps; the tracker's solutions on them, jittered per "
      "control (D w, d_i in [jitter_low, jitter_high]) and interpolated between pairs, are "
      "rendered as new samples with the set's own sampling options; identical for any rank "
      "count, resumable",
      PathKeys{{"rig", "samples", "frame_codes", "track"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunSynthExpand));
  RegisterSynthContract(synth, state);
  RegisterSynthClip(synth, state);
  RegisterSynthCrops(synth, state);
}

void RegisterSynthContract(CLI::App* synth, AppState* state) {
  AddStage<SynthContractOptions>(
      synth, state, "contract", "synth.contract", "synth contract",
      "Contract a random sample set (paper 000 Sec. 7.1): a sample whose deepfake code lies far "
      "from every real frame's (mean distance to the k nearest) is out of distribution; the "
      "remove_fraction highest-scoring samples are removed, with a contact sheet of the most "
      "and least in-distribution samples beside their nearest real frames",
      PathKeys{{"samples", "sample_codes", "frame_codes", "frames", "bound"},
               {{"out", OutputKind::kHdf5}}},
      StageCommand(RunSynthContract));
}

void RegisterSynthClip(CLI::App* synth, AppState* state) {
  AddStage<SynthClipOptions>(
      synth, state, "clip", "synth.clip", "synth clip",
      "A wild clip of one person (identity_seed): a smooth random or scripted performance of "
      "expressions and head motion, skin-like texture, moving lights, backgrounds, blur, noise "
      "and JPEG, with the true pose, weights, landmarks and segmentation of every frame; "
      "spread across ranks, identical for any rank count, resumable; --video adds an mp4",
      PathKeys{{"rig", "background_folder"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunSynthClip));
  AddStage<SynthSheetOptions>(
      synth, state, "sheet", "synth.sheet", "synth sheet",
      "Contact sheet of a clip's wild frames, each beside the segmentation render of the same "
      "frame (with its visible true landmarks)",
      PathKeys{{"clip"}, {{"out", OutputKind::kImage}}},
      StageCommand(RunSynthSheet));
}

void RegisterSynthCrops(CLI::App* synth, AppState* state) {
  AddStage<SynthCropsOptions>(
      synth, state, "crops", "synth.crops", "synth crops",
      "A synthetic clip as ingest cropped its video: the crops beside the clip's segmentation "
      "warped by the same crop transforms, with the regions (paired deepfake examples in the "
      "framing of real crops; the true segmentation of a clip's crops for oracle solves)",
      PathKeys{{"clip", "frames"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunSynthCrops));
}

void RegisterScans(CLI::App* app, AppState* state) {
  CLI::App* scans = app->add_subcommand("scans", "Scan databases of people and FACS expressions");
  scans->require_subcommand(1);
  AddStage<ScansSynthOptions>(
      scans, state, "synth", "scans.synth", "scans synth",
      "Synthetic scan database: people from the demo head's identity modes, personal blendshapes "
      "that depend on identity, FACS expression scans with unwanted motion and noise; the true "
      "personal shapes are stored for evaluation",
      PathKeys{{}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunScansSynth));
  AddStage<ScansImportOptions>(
      scans, state, "import", "scans.import", "scans import",
      "Registered OBJ scans (one per person and expression, listed in a labels CSV) into the scan "
      "database layout",
      PathKeys{{"labels", "template_rig"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunScansImport));
}

}  // namespace facecap::app
