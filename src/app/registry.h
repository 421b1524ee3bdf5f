// The subcommand table. Each Register* adds one subcommand (with its --help text and flags)
// and the callback that runs its controller.
#ifndef FACECAP_APP_REGISTRY_H_
#define FACECAP_APP_REGISTRY_H_

#include <functional>
#include <list>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "dist/comm.h"
#include "app/cli.h"
#include "stages/stage_paths.h"

namespace facecap::app {

template <typename T, typename = void>
struct HasOut : std::false_type {};
template <typename T>
struct HasOut<T, std::void_t<decltype(std::declval<T>().out)>> : std::true_type {};

// Options may name files they write beside their options (OUT.checkpoint, a preview):
//   void DerivedOutputs(std::vector<stages::NamedPath>* outputs) const;
template <typename T, typename = void>
struct HasDerivedOutputs : std::false_type {};
template <typename T>
struct HasDerivedOutputs<T, std::void_t<decltype(std::declval<const T&>().DerivedOutputs(
                                std::declval<std::vector<stages::NamedPath>*>()))>> : std::true_type {};

// The files named by `options` under `keys`: std::logic_error when a key is not an option
// of the struct or not a text option (a mistake in the stage's registration).
template <typename Options>
stages::StagePaths PathsOf(const Options& options, const std::string& table,
                           const stages::PathKeys& keys) {
  stages::StagePaths paths;
  paths.table = table;
  auto take = [&](const std::string& key, std::vector<std::string>* values) {
    bool found = false;
    const_cast<Options&>(options).Visit([&](const char* k, auto& field, const char*) {
      using Field = std::decay_t<decltype(field)>;
      if (key != k) return;
      found = true;
      if constexpr (std::is_same_v<Field, std::string>) {
        values->push_back(field);
      } else if constexpr (std::is_same_v<Field, std::vector<std::string>>) {
        values->insert(values->end(), field.begin(), field.end());
      } else {
        throw std::logic_error("[" + table + "] " + key + " is not a text option");
      }
    });
    if (!found) throw std::logic_error("[" + table + "] has no option " + key);
  };
  // An option not used (an empty text or list) is kept as an empty path: the keys stay listed.
  for (const std::string& key : keys.inputs) {
    std::vector<std::string> values;
    take(key, &values);
    if (values.empty()) values.emplace_back();
    for (const std::string& v : values) paths.inputs.push_back({key, v});
  }
  for (const stages::OutputKey& output : keys.outputs) {
    std::vector<std::string> values;
    take(output.key, &values);
    if (values.empty()) values.emplace_back();
    for (const std::string& v : values) paths.outputs.push_back({output.key, v, output.kind});
  }
  if constexpr (HasDerivedOutputs<Options>::value) options.DerivedOutputs(&paths.outputs);
  return paths;
}

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
  // The files the stage reads and writes with the options of `table`.
  std::function<stages::StagePaths(const io::Config&, const std::string& table)> paths;
  stages::PathKeys path_keys;  // the options that name them
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

// The command-line callback of a stage's Run(options, context, resolved): the options
// resolved from the defaults, the job file, --set and the flags, then the stage run.
template <typename Options, typename Summary>
std::function<void(const StageFlags&, AppState*)> StageCommand(
    Summary (*run)(const Options&, const stages::StageContext&, const io::Config&)) {
  return [run](const StageFlags& flags, AppState* state) {
    const stages::StageContext ctx{state->comm, state->command_line};
    io::Config resolved;
    const Options options = ResolveStageOptions<Options>(flags, &resolved);
    run(options, ctx, resolved);
  };
}

// Adds a subcommand for a stage whose options are `Options` (table `table`), runnable by
// `facecap run`: flags from the options, --job and --set, and the callback. `paths` names the
// options that are the stage's input and output files: they are checked (CheckStagePaths)
// before the stage starts.
template <typename Options>
CLI::App* AddStage(CLI::App* parent, AppState* state, const std::string& name,
                   const std::string& table, const std::string& command,
                   const std::string& description, const stages::PathKeys& paths,
                   std::function<void(const StageFlags&, AppState*)> run) {
  PathsOf(Options(), table, paths);  // every key named is a text option of Options
  StageFlags* flags = state->NewFlags();
  CLI::App* sub = parent->add_subcommand(name, description);
  AddStageFlags<Options>(sub, table, flags);
  // The files are checked before the option values, so that an output naming an input is
  // reported as such, whatever else is wrong with it.
  auto checked_run = [=](const StageFlags& f) {
    Options options;
    io::LoadOptions(BuildConfig(f), f.table, &options);
    stages::CheckStagePaths(PathsOf(options, f.table, paths));
    run(f, state);
  };
  sub->callback([=] { checked_run(*flags); });
  for (const std::string& t : io::OptionTables<Options>(table)) state->job_tables.push_back(t);
  StageSpec spec;
  spec.table = table;
  spec.command = command;
  spec.run = checked_run;
  spec.path_keys = paths;
  spec.resolve = [](const io::Config& config, const std::string& instance) {
    Options options = io::ResolveOptions<Options>(config, instance);
    const io::Config resolved = stages::StoredOptions(options, instance);
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
  spec.paths = [paths](const io::Config& config, const std::string& instance) {
    return PathsOf(io::ResolveOptions<Options>(config, instance), instance, paths);
  };
  state->stages.push_back(spec);
  return sub;
}

}  // namespace facecap::app

#endif  // FACECAP_APP_REGISTRY_H_
