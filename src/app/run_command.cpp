// facecap run JOB.toml: the job's stages in pipeline order; a stage whose output exists and
// records the same configuration is skipped, so rerunning after a crash or a requeue continues.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iostream>

#include "io/hdf5.h"
#include "app/cli.h"
#include "app/commands.h"
#include "app/registry.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::app {
namespace {

using stages::CheckJobPaths;
using stages::CheckStagePaths;
using stages::StagePaths;

struct RunFlags {
  std::string job;
  std::vector<std::string> sets;
  std::string from;
  std::string until;
  std::string only;
  bool dry_run = false;
  bool list = false;
};

// One entry of the plan: a stage and the table its options come from (its own table, or an
// instance table "TABLE-NAME" such as [track-oracle], so that one job can run a stage twice).
struct PlannedStage {
  const StageSpec* spec = nullptr;
  std::string table;
};

// Why a stage runs, or "" when its output is up to date.
// *stale: the output is complete but older than an input; it must be removed before the stage
// runs, since the stage itself would find it up to date.
std::string WhyRun(const PlannedStage& stage, const io::Config& config, std::string* out,
                   bool* stale) {
  *stale = false;
  const auto [resolved, output] = stage.spec->resolve(config, stage.table);
  *out = output;
  if (output.empty()) return "it has no recorded output";
  if (!std::filesystem::exists(output)) {
    return std::filesystem::exists(io::H5File::PartialPath(output))
               ? "an interrupted run left " + io::H5File::PartialPath(output) + " to continue"
               : "its output " + output + " does not exist";
  }
  if (!io::H5File::IsHdf5(output)) return "its output " + output + " is not an HDF5 file";
  try {
    io::H5File f = io::H5File::OpenRead(output);
    if (!f.HasAttribute("/", "config_hash")) return "its output records no configuration";
    if (f.GetStringAttribute("/", "config_hash") != io::ConfigHash(resolved)) {
      return "its output was made with another configuration";
    }
  } catch (const FileIOError& e) {
    return std::string("its output is unreadable: ") + e.what();
  }
  // Make's rule for the pipeline's intermediates: an HDF5 input rewritten after the output
  // was made (an earlier stage reran, a file was replaced) makes the output stale.
  std::error_code made_error;
  const auto made = std::filesystem::last_write_time(output, made_error);
  if (made_error) return "its output " + output + " cannot be inspected: " + made_error.message();
  for (const std::string& path : stage.spec->texts(config, stage.table)) {
    std::error_code error;
    if (path.empty() || path == output || !std::filesystem::is_regular_file(path, error)) continue;
    if (std::filesystem::last_write_time(path, error) > made && !error && io::H5File::IsHdf5(path)) {
      *stale = true;
      return "its input " + path + " is newer than its output";
    }
  }
  return "";
}

// The stage a [run] entry names: a stage table, or an instance "TABLE-NAME" of one (NAME of
// letters, digits and underscores). Null when it is neither.
const StageSpec* FindStage(const AppState& state, const std::string& entry) {
  for (const StageSpec& spec : state.stages) {
    if (spec.table == entry) return &spec;
  }
  for (const StageSpec& spec : state.stages) {
    const std::string& t = spec.table;
    if (entry.size() > t.size() + 1 && entry.compare(0, t.size(), t) == 0 && entry[t.size()] == '-' &&
        std::all_of(entry.begin() + t.size() + 1, entry.end(),
                    [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; })) {
      return &spec;
    }
  }
  return nullptr;
}

void RunJob(const RunFlags& flags, AppState* state) {
  io::Config config = io::Config::Load(flags.job);
  for (const auto& s : flags.sets) config.SetAssignment(s);
  // Which stages: [run] stages = [...] in that order, else every stage table present.
  std::vector<std::string> tables;
  if (config.Has("run", "stages")) {
    if (!config.IsArray("run", "stages")) {
      throw InvalidInputError(flags.job + ": [run] stages must be an array of stage tables, "
                              "e.g. stages = [\"rig.demo\", \"synth.samples\"]");
    }
    config.Get("run", "stages", &tables);
  } else {
    for (const StageSpec& spec : state->stages) {
      if (config.HasTable(spec.table)) tables.push_back(spec.table);
    }
  }
  for (const std::string& key : config.Keys("run")) {
    if (key != "stages") {
      throw InvalidInputError(flags.job + ": unknown key '" + key + "' in [run]; valid keys: stages");
    }
  }
  std::vector<PlannedStage> plan;
  std::vector<std::string> job_tables = state->job_tables;  // plus the instances [run] names
  for (const std::string& table : tables) {
    const StageSpec* found = FindStage(*state, table);
    if (!found) {
      std::string valid;
      for (const StageSpec& spec : state->stages) valid += (valid.empty() ? "" : ", ") + spec.table;
      throw InvalidInputError(flags.job + ": [run] stages names '" + table +
                              "', which is not a stage (nor an instance STAGE-NAME of one); "
                              "stages: " + valid);
    }
    for (const PlannedStage& p : plan) {
      if (p.table == table) {
        throw InvalidInputError(flags.job + ": [run] stages names '" + table + "' twice; run a "
                                "stage again with an instance table such as [" + table + "-2]");
      }
    }
    // Without its table a stage would run on built-in defaults in the current folder.
    if (!config.HasTable(table)) {
      throw InvalidInputError(flags.job + ": [run] stages names '" + table + "', but the job "
                              "has no [" + table + "] table; add the table (an empty one "
                              "runs the stage on its defaults) or remove the stage");
    }
    plan.push_back({found, table});
    if (table != found->table) AddInstanceTables(state->job_tables, found->table, table, &job_tables);
  }
  // A misspelled table ([rigg]) would otherwise be a stage that silently never runs.
  config.CheckTables(job_tables);
  if (plan.empty()) {
    std::string valid;
    for (const StageSpec& spec : state->stages) valid += (valid.empty() ? "" : ", ") + spec.table;
    throw InvalidInputError(flags.job + ": no stage to run; stage tables: " + valid);
  }
  // Every stage's options are read and range-checked before the first stage starts, so a bad
  // value in a late stage does not surface hours into the run.
  // Their files too: an output never replaces an input of itself or of an earlier stage.
  std::vector<StagePaths> paths;
  for (const PlannedStage& p : plan) {
    p.spec->resolve(config, p.table);
    paths.push_back(p.spec->paths(config, p.table));
    CheckStagePaths(paths.back());
  }
  CheckJobPaths(paths, flags.job);
  auto index_of = [&](const std::string& table, const char* flag) {
    for (size_t i = 0; i < plan.size(); ++i) if (plan[i].table == table) return i;
    throw InvalidInputError(std::string("--") + flag + " " + table + ": not a stage of " + flags.job);
  };
  if (flags.list) {
    if (state->comm.IsMainRank()) {
      for (const PlannedStage& p : plan) std::cout << p.table << "\n";
    }
    return;
  }
  size_t first = flags.from.empty() ? 0 : index_of(flags.from, "from");
  size_t last = flags.until.empty() ? plan.size() - 1 : index_of(flags.until, "until");
  if (!flags.only.empty()) first = last = index_of(flags.only, "only");
  const bool main_rank = state->comm.IsMainRank();
  if (main_rank) FC_INFO("run {}: {} stages", flags.job, plan.size());
  for (size_t i = 0; i < plan.size(); ++i) {
    const StageSpec& spec = *plan[i].spec;
    const std::string label =
        plan[i].table == spec.table ? spec.command : spec.command + " [" + plan[i].table + "]";
    // Rank 0 decides (and alone removes a stale output): every rank must take the same branch.
    std::string out;
    bool stale = false;
    std::string why;
    dist::CoordinateExceptions(state->comm, [&] {
      if (main_rank && !(i < first || i > last)) why = WhyRun(plan[i], config, &out, &stale);
    });
    int decision[2] = {why.empty() ? 0 : 1, stale ? 1 : 0};
    state->comm.Broadcast(decision, sizeof(decision));
    if (!main_rank) {
      why = decision[0] ? "rank 0 found it out of date" : "";
      stale = decision[1] != 0;
    }
    const bool forced = !flags.from.empty() && flags.only.empty() && i == first;
    if (forced && why.empty()) why = "--from starts here";
    if (flags.dry_run) {
      if (main_rank) {
        std::cout << "[" << (i + 1) << "/" << plan.size() << "] " << label << ": "
                  << (i < first || i > last ? "outside --from/--until, skipped"
                                            : why.empty() ? "up to date, skipped" : "runs: " + why)
                  << "\n";
      }
      continue;
    }
    if (i < first || i > last) continue;
    if (why.empty()) {
      if (main_rank) FC_INFO("[{}/{}] {}: up to date ({}), skipped", i + 1, plan.size(), label, out);
      continue;
    }
    if (main_rank) FC_INFO("[{}/{}] {}: runs because {}", i + 1, plan.size(), label, why);
    if (main_rank && (forced || stale) && std::filesystem::exists(out)) std::filesystem::remove(out);
    state->comm.Barrier();
    StageFlags stage_flags;
    stage_flags.job = flags.job;
    stage_flags.sets = flags.sets;
    stage_flags.table = plan[i].table;
    stage_flags.job_tables = &job_tables;
    spec.run(stage_flags);
    // Stages that write on rank 0 only return early elsewhere: the next stage reads what this
    // one wrote, so every rank waits for it.
    state->comm.Barrier();
  }
  if (main_rank && !flags.dry_run) FC_INFO("run {}: done", flags.job);
}

}  // namespace

void RegisterRun(CLI::App* app, AppState* state) {
  static RunFlags run_flags;  // RegisterRun is called once per process
  RunFlags* flags = &run_flags;
  CLI::App* sub = app->add_subcommand(
      "run", "Run a job file's stages in order ([run] stages = [...], or every stage table it "
             "has, in pipeline order). A stage whose output exists and records the same "
             "configuration is skipped, so rerunning continues after a crash or a requeue");
  sub->add_option("job", flags->job, "TOML job file")->required()->check(CLI::ExistingFile);
  sub->add_option("--set", flags->sets, "override a job-file value: --set table.key=value");
  sub->add_option("--from", flags->from, "start at this stage table (it reruns even if up to date)");
  sub->add_option("--until", flags->until, "stop after this stage table");
  sub->add_option("--only", flags->only,
                  "run only this stage table (skipped when up to date), as Slurm scripts do "
                  "with one srun per stage");
  sub->add_flag("--dry-run", flags->dry_run, "print what would run and why, run nothing");
  sub->add_flag("--list", flags->list, "print the job's stage tables in order, one per line");
  sub->callback([=] { RunJob(*flags, state); });
}

}  // namespace facecap::app
