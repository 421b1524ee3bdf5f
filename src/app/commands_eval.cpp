// The command-line table, evaluation: every `eval` subcommand (the metrics of an output
// against its truth or its footage), and the group subcommands (eval, export, ...).
#include <string>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "app/registry.h"
#include "stages/assemble_stage.h"
#include "stages/blendshapes_stage.h"
#include "stages/eval_stage.h"
#include "stages/lipsync_stage.h"
#include "stages/textures_stage.h"

namespace facecap::app {

using stages::OutputKind;
using stages::PathKeys;
using stages::EvalAppearanceOptions;
using stages::EvalAssemblyOptions;
using stages::EvalBlendshapesOptions;
using stages::EvalLandmarksOptions;
using stages::EvalLipsyncOptions;
using stages::EvalPersonOptions;
using stages::EvalRerenderOptions;
using stages::EvalTexturesOptions;
using stages::EvalTrackOptions;
using stages::RunEvalAppearance;
using stages::RunEvalAssembly;
using stages::RunEvalBlendshapes;
using stages::RunEvalLandmarks;
using stages::RunEvalLipsync;
using stages::RunEvalPerson;
using stages::RunEvalRerender;
using stages::RunEvalTextures;
using stages::RunEvalTrack;

CLI::App* GroupSubcommand(CLI::App* app, const std::string& name, const std::string& description) {
  try {
    return app->get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    CLI::App* group = app->add_subcommand(name, description);
    group->require_subcommand(1);
    return group;
  }
}

CLI::App* EvalSubcommand(CLI::App* app) {
  return GroupSubcommand(app, "eval", "Metrics of an output against synthetic truth");
}

void RegisterEval(CLI::App* app, AppState* state) {
  CLI::App* eval = EvalSubcommand(app);
  AddStage<EvalTrackOptions>(
      eval, state, "track", "eval.track", "eval track",
      "Tracking accuracy against the truth, each beside the neutral face's: pose error (deg), "
      "weight MAE (overall, over the truth's active weights, per shape), expression vertex "
      "error (rigid pose and identity removed), landmark NME and vertex error over the "
      "inter-ocular distance (outer eye corners 36, 45), seconds per frame; one JSON object",
      PathKeys{{"truth", "track", "rig", "truth_rig"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalTrack));
  AddStage<EvalLandmarksOptions>(
      eval, state, "landmarks", "eval.landmarks", "eval landmarks",
      "Real footage: the tracked rig's 68 landmarks against dlib's in source pixels, over the "
      "detected outer-eye-corner distance, on all frames with a face and on the frames held "
      "out of deepfake training apart; one JSON object (score against an independent "
      "landmarker with export landmarks and analysis/compare_landmarks.py)",
      PathKeys{{"frames", "track", "rig"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalLandmarks));
  AddStage<EvalPersonOptions>(
      eval, state, "person", "eval.person", "eval person",
      "The person fit's neutral against the true person of a synthetic clip: vertex RMS after a "
      "similarity alignment, in mm and over the inter-ocular distance, beside the generic head's "
      "and the landmarks-only fit's; one JSON object",
      PathKeys{{"truth", "person"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalPerson));
  AddStage<EvalAppearanceOptions>(
      eval, state, "appearance", "eval.appearance", "eval appearance",
      "A captured texture against a synthetic person's true albedo: PSNR over the face region "
      "of the UV map after one gain per colour channel (the clip's lighting is baked into any "
      "capture), beside a flat texture of the capture's mean colour, and the coverage; one JSON "
      "object",
      PathKeys{{"truth", "texture", "naive"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalAppearance));
  AddStage<EvalRerenderOptions>(
      eval, state, "rerender", "eval.rerender", "eval rerender",
      "Tracked footage re-rendered with a captured texture against the footage itself (no "
      "truth needed, for real video): PSNR over the face pixels of held-out frames, each render "
      "shaded by the frame's light (first-order in the surface normal, fitted per frame and "
      "colour channel), beside the naive capture, the generic texture and a flat colour; one "
      "JSON object",
      PathKeys{{"views", "texture", "naive"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalRerender));
}

void RegisterEvalBlendshapes(CLI::App* app, AppState* state) {
  CLI::App* eval = EvalSubcommand(app);
  AddStage<EvalBlendshapesOptions>(
      eval, state, "blendshapes", "eval.blendshapes", "eval blendshapes",
      "Reconstruction errors of template, example-based and generated blendshapes on training and "
      "held-out people (paper 001 Table 2), and their distance to the true personal shapes",
      PathKeys{{"scans", "baselines", "model"}, {{"markdown", OutputKind::kText}, {"shapes", OutputKind::kHdf5}}},
      StageCommand(RunEvalBlendshapes));
}

void RegisterEvalTextures(CLI::App* app, AppState* state) {
  AddStage<EvalTexturesOptions>(
      EvalSubcommand(app), state, "textures", "eval.textures", "eval textures",
      "Dynamic textures (paper 001 eq. 10-14) on the held-out people of a textured scan database: PSNR "
      "of albedo, specular and displacement against the true expression textures where the "
      "expression moves the skin, beside the static neutral texture and per-blendshape maps, and "
      "the library's size against theirs; one JSON object",
      PathKeys{{"scans", "model"}, {{"out", OutputKind::kText}, {"maps", OutputKind::kHdf5}}},
      StageCommand(RunEvalTextures));
}

void RegisterEvalAssembly(CLI::App* app, AppState* state) {
  AddStage<EvalAssemblyOptions>(
      EvalSubcommand(app), state, "assembly", "eval.assembly", "eval assembly",
      "Secondary parts on the held-out people of a scan database, over every shape and random weight "
      "combinations: eyelash roots to the lid surface, eyelid vertices inside the eyeballs, lower teeth "
      "against the jaw's rotation; beside the generic parts and the coefficient fit alone",
      PathKeys{{"scans", "model"}, {{"out", OutputKind::kText}}},
      StageCommand(RunEvalAssembly));
}

void RegisterEvalLipsync(CLI::App* app, AppState* state) {
  CLI::App* eval = EvalSubcommand(app);
  AddStage<EvalLipsyncOptions>(
      eval, state, "lipsync", "eval.lipsync", "eval lipsync",
      "Tracks of a talking clip against its truth: mouth-control and upper-face-control MAE, "
      "pose error, and lip closures (the truth rig's inner lips meeting) found within a "
      "tolerance (F1), beside the neutral mouth",
      PathKeys{{"truth", "tracks"}, {{"out", OutputKind::kText}, {"gaps", OutputKind::kCsv}}},
      StageCommand(RunEvalLipsync));
}

}  // namespace facecap::app
