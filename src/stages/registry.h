// The subcommand table. Each Register* adds one subcommand (with its --help text and flags)
// and the callback that runs its controller.
#ifndef FACECAP_STAGES_REGISTRY_H_
#define FACECAP_STAGES_REGISTRY_H_

#include <functional>
#include <list>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "dist/comm.h"
#include "stages/cli.h"

namespace facecap::stages {

template <typename T, typename = void>
struct HasOut : std::false_type {};
template <typename T>
struct HasOut<T, std::void_t<decltype(std::declval<T>().out)>> : std::true_type {};

// What `facecap run` needs to know of a stage: how to run it from a job file, and how to
// resolve its table to the configuration text and output path that its output records.
struct StageSpec {
  std::string table;         // "synth.samples"
  std::string command;       // "synth samples"
  std::function<void(const StageFlags&)> run;
  // Resolved TOML of the stage's options read from table `table` (its own, or an instance
  // such as [track-oracle]; as stored in the output's config_hash) and the output path.
  std::function<std::pair<std::string, std::string>(const io::Config&, const std::string& table)>
      resolve;
  // Every text option of the stage read from `table` (file names among them): what
  // `facecap run` checks for inputs newer than the output.
  std::function<std::vector<std::string>(const io::Config&, const std::string& table)> texts;
};

// Collects the text (std::string) options of an options struct through its Visit.
struct TextOptionCollector {
  std::vector<std::string>* texts;
  template <class T>
  void operator()(const char* /*key*/, T& value, const char* /*help*/) {
    if constexpr (std::is_same_v<T, std::string>) texts->push_back(value);
  }
};

struct AppState {
  dist::Comm comm = dist::Comm::Single();
  std::string command_line;
  std::list<StageFlags> stage_flags;  // one per subcommand; a list keeps pointers stable
  StageFlags* NewFlags() {
    StageFlags* flags = &stage_flags.emplace_back();
    flags->job_tables = &job_tables;
    return flags;
  }
  std::vector<StageSpec> stages;      // in pipeline order, for `facecap run`
  // The tables a job file may have: [run] and every stage's table (AddStage adds them).
  std::vector<std::string> job_tables = {"run"};
};

// Adds a subcommand for a stage whose options are `Options` (table `table`), runnable by
// `facecap run`: flags from the options, --job and --set, and the callback.
template <typename Options>
CLI::App* AddStage(CLI::App* parent, AppState* state, const std::string& name,
                   const std::string& table, const std::string& command,
                   const std::string& description,
                   std::function<void(const StageFlags&, AppState*)> run) {
  StageFlags* flags = state->NewFlags();
  CLI::App* sub = parent->add_subcommand(name, description);
  AddStageFlags<Options>(sub, table, flags);
  sub->callback([=] { run(*flags, state); });
  state->job_tables.push_back(table);
  StageSpec spec;
  spec.table = table;
  spec.command = command;
  spec.run = [=](const StageFlags& f) { run(f, state); };
  spec.resolve = [](const io::Config& config, const std::string& instance) {
    Options options = io::ResolveOptions<Options>(config, instance);
    io::Config resolved;
    io::StoreOptions(options, instance, &resolved);
    std::string out;
    if constexpr (HasOut<Options>::value) out = options.out;
    return std::make_pair(resolved.ToToml(), out);
  };
  spec.texts = [](const io::Config& config, const std::string& instance) {
    Options options = io::ResolveOptions<Options>(config, instance);
    std::vector<std::string> texts;
    options.Visit(TextOptionCollector{&texts});
    return texts;
  };
  state->stages.push_back(spec);
  return sub;
}

void RegisterVersion(CLI::App* app, AppState* state);
void RegisterRig(CLI::App* app, AppState* state);
// `rig calibrate`, under the `rig` subcommand made by RegisterRig.
void RegisterRigCalibrate(CLI::App* rig, AppState* state);
void RegisterRender(CLI::App* app, AppState* state);
void RegisterSynth(CLI::App* app, AppState* state);
// `synth clip` and `synth sheet`, under the `synth` subcommand made by RegisterSynth.
void RegisterSynthClip(CLI::App* synth, AppState* state);
// `synth crops`, under the `synth` subcommand.
void RegisterSynthCrops(CLI::App* synth, AppState* state);
void RegisterIngest(CLI::App* app, AppState* state);
void RegisterCurate(CLI::App* app, AppState* state);
void RegisterDeepfake(CLI::App* app, AppState* state);
void RegisterExport(CLI::App* app, AppState* state);
void RegisterScans(CLI::App* app, AppState* state);
void RegisterBlendshapes(CLI::App* app, AppState* state);
void RegisterTrack(CLI::App* app, AppState* state);
// `person fit` under a `person` subcommand.
void RegisterPerson(CLI::App* app, AppState* state);
// `eval track` (and other metrics) under an `eval` subcommand, made when absent.
void RegisterEval(CLI::App* app, AppState* state);
void RegisterRun(CLI::App* app, AppState* state);

std::string VersionReport(const dist::Comm& comm);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_REGISTRY_H_
