// The command-line table: each Register* adds the subcommands of one stage or area (their
// --help text, their flags and the stage each runs) to the facecap binary. RegisterAll
// (app.cpp) calls them in pipeline order: the order in which `facecap run` runs a job's
// stages when the job does not list them.
#ifndef FACECAP_APP_COMMANDS_H_
#define FACECAP_APP_COMMANDS_H_

#include <string>

#include "dist/comm.h"

namespace CLI { class App; }

namespace facecap::app {

struct AppState;

void RegisterVersion(CLI::App* app, AppState* state);
void RegisterRun(CLI::App* app, AppState* state);

// commands_rig.cpp
void RegisterRig(CLI::App* app, AppState* state);
// `rig calibrate`, under the `rig` subcommand made by RegisterRig.
void RegisterRigCalibrate(CLI::App* rig, AppState* state);
void RegisterRender(CLI::App* app, AppState* state);
void RegisterSynth(CLI::App* app, AppState* state);
// `synth contract`, `synth clip` and `synth sheet`, `synth crops`: under the `synth`
// subcommand made by RegisterSynth.
void RegisterSynthContract(CLI::App* synth, AppState* state);
void RegisterSynthClip(CLI::App* synth, AppState* state);
void RegisterSynthCrops(CLI::App* synth, AppState* state);
void RegisterScans(CLI::App* app, AppState* state);

// commands_video.cpp
void RegisterIngest(CLI::App* app, AppState* state);
void RegisterCurate(CLI::App* app, AppState* state);
void RegisterDeepfake(CLI::App* app, AppState* state);
// `export livelink`, `export gltf`, `export overlay`, `export landmarks`.
void RegisterExport(CLI::App* app, AppState* state);
// `track`, and `lipsync track`.
void RegisterTrack(CLI::App* app, AppState* state);
// `person fit` under a `person` subcommand.
void RegisterPerson(CLI::App* app, AppState* state);
void RegisterAppearance(CLI::App* app, AppState* state);
// `lipsync blend` and `lipsync audio`.
void RegisterLipsync(CLI::App* app, AppState* state);
// `regress train` and `regress infer`.
void RegisterRegress(CLI::App* app, AppState* state);

// commands_blendshapes.cpp
void RegisterBlendshapes(CLI::App* app, AppState* state);
// `export textures` and `textures library`.
void RegisterTextures(CLI::App* app, AppState* state);
// `textures train` and `textures infer`.
void RegisterTexturesNetworks(CLI::App* app, AppState* state);
void RegisterAssemble(CLI::App* app, AppState* state);

// commands_eval.cpp: the `eval` subcommands.
// `eval track`, `eval landmarks`, `eval person`, `eval appearance`, `eval rerender`.
void RegisterEval(CLI::App* app, AppState* state);
void RegisterEvalBlendshapes(CLI::App* app, AppState* state);
void RegisterEvalTextures(CLI::App* app, AppState* state);
void RegisterEvalAssembly(CLI::App* app, AppState* state);
void RegisterEvalLipsync(CLI::App* app, AppState* state);

// Subcommand `name` (eval, export, ...) of `app`, added with `description` on first use:
// several Register* add subcommands under it.
CLI::App* GroupSubcommand(CLI::App* app, const std::string& name, const std::string& description);
CLI::App* EvalSubcommand(CLI::App* app);
CLI::App* ExportSubcommand(CLI::App* app);
CLI::App* LipsyncSubcommand(CLI::App* app);

std::string VersionReport(const dist::Comm& comm);

}  // namespace facecap::app

#endif  // FACECAP_APP_COMMANDS_H_
