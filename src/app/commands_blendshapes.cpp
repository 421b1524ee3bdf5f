// The command-line table, blendshapes from a scan: blendshapes, textures, assemble.
#include <string>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "app/registry.h"
#include "stages/assemble_stage.h"
#include "stages/blendshapes_stage.h"
#include "stages/textures_net_stage.h"
#include "stages/textures_stage.h"

namespace facecap::app {

using stages::OutputKind;
using stages::PathKeys;
using stages::AssembleOptions;
using stages::BlendshapesBaselinesOptions;
using stages::BlendshapesInferOptions;
using stages::BlendshapesTrainOptions;
using stages::ExportTexturesOptions;
using stages::RunAssemble;
using stages::RunBlendshapesBaselines;
using stages::RunBlendshapesInfer;
using stages::RunBlendshapesTrain;
using stages::RunExportTextures;
using stages::RunTexturesInfer;
using stages::RunTexturesLibrary;
using stages::RunTexturesTrain;
using stages::TexturesInferOptions;
using stages::TexturesLibraryOptions;
using stages::TexturesTrainOptions;

namespace {

// GroupSubcommand(app, "textures", ...).
CLI::App* TexturesSubcommand(CLI::App* app) {
  return GroupSubcommand(app, "textures", "Dynamic textures (paper 001 Sec. 5)");
}

}  // namespace

void RegisterBlendshapes(CLI::App* app, AppState* state) {
  CLI::App* bs = app->add_subcommand("blendshapes", "Personalized blendshapes from one neutral scan");
  bs->require_subcommand(1);
  AddStage<BlendshapesTrainOptions>(
      bs, state, "train", "blendshapes.train", "blendshapes train",
      "Train the blendshape generator (Estimation Stage, then Tuning Stage with the blending weight "
      "predictor) on a scan database; data-parallel with gradient allreduce, resumable",
      PathKeys{{"scans"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunBlendshapesTrain));
  AddStage<BlendshapesBaselinesOptions>(
      bs, state, "baselines", "blendshapes.baselines", "blendshapes baselines",
      "Baseline shapes for every person of a scan database: the template moved by deformation "
      "transfer, and example-based facial rigging on the person's scans",
      PathKeys{{"scans"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunBlendshapesBaselines));
  AddStage<BlendshapesInferOptions>(
      bs, state, "infer", "blendshapes.infer", "blendshapes infer",
      "One neutral mesh (an OBJ, or a person of a scan database) to a personalized rig.h5",
      PathKeys{{"model", "neutral", "scans"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunBlendshapesInfer));
}

void RegisterTextures(CLI::App* app, AppState* state) {
  AddStage<ExportTexturesOptions>(
      ExportSubcommand(app), state, "textures", "export.textures",
      "export textures",
      "A tracked take's dynamic textures (the strain texture at each frame's weights) as EXR sequences of albedo, "
      "specular and "
      "displacement, frames spread across ranks",
      PathKeys{{"library", "track"}, {{"out", OutputKind::kFolder}}},
      StageCommand(RunExportTextures));
  CLI::App* textures = TexturesSubcommand(app);
  AddStage<TexturesLibraryOptions>(
      textures, state, "library", "textures.library", "textures library",
      "A person's dynamic texture library from their expression scans and skin maps: compress and stretch maps "
      "fitted for the strain texture (eq. 10-13's influences and references) and the rig shapes' influences; "
      "writes a textured rig that render draws with the texture of its weights and export textures plays over a "
      "take",
      PathKeys{{"scans", "rig"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunTexturesLibrary));
}

void RegisterTexturesNetworks(CLI::App* app, AppState* state) {
  CLI::App* textures = TexturesSubcommand(app);
  AddStage<TexturesTrainOptions>(
      textures, state, "train", "textures.train", "textures train",
      "The expression texture networks (paper 001 Fig. 7) on a textured scan database's training people: the first "
      "predicts an expression's albedo offset from the neutral maps, the neutral geometry image and the expression's "
      "offset geometry image and influences; the second the specular and displacement offsets from those and the "
      "first's prediction. Data-parallel over ranks (gradient allreduce), checkpoints, resume",
      PathKeys{{"scans"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunTexturesTrain));
  AddStage<TexturesInferOptions>(
      textures, state, "infer", "textures.infer", "textures infer",
      "A person's dynamic texture library from their neutral skin maps and rig alone: the networks predict the "
      "textures of the model's FACS expressions of the rig, and compress and stretch maps are fitted to them for the "
      "strain texture (a textured rig that render draws and export textures plays)",
      PathKeys{{"model", "rig", "scans"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunTexturesInfer));
}

void RegisterAssemble(CLI::App* app, AppState* state) {
  AddStage<AssembleOptions>(
      app, state, "assemble", "assemble", "assemble",
      "Secondary parts for a personalized rig (paper 001 Sec. 6): eyeballs with a procedural iris matched to the "
      "albedo and a cornea, lacrimal fluid, eyelashes, teeth, gums and tongue, placed on the person's face and "
      "driven by each of their shapes (a linear fit of the template's shapes; the jaw's parts follow the jaw); "
      "writes the rig file with /parts, which rig export and export gltf add as separate meshes",
      PathKeys{{"rig"}, {{"out", OutputKind::kHdf5}}}, StageCommand(RunAssemble));
}

}  // namespace facecap::app
