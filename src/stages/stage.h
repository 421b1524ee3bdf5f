// What every stage controller receives: the communicator, the job configuration with the
// command-line overrides applied, and the command line for provenance.
#ifndef FACECAP_STAGES_STAGE_H_
#define FACECAP_STAGES_STAGE_H_

#include <cstdint>
#include <string>

#include "dist/comm.h"
#include "io/config.h"
#include "io/hdf5.h"
#include "train/controller.h"
#include "util/errors.h"

namespace facecap::stages {

struct StageContext {
  dist::Comm comm = dist::Comm::Single();
  std::string command_line;   // as typed, for provenance
};

// What a stage's Run returns: the output it wrote or found complete, how many items (frames,
// samples, steps, files: `unit`) the output holds, and how many of them this run computed
// (0 when the output was already up to date).
struct StageSummary {
  std::string out;
  std::string unit;
  int64_t items = 0;
  int64_t computed = 0;
  std::string Line() const;  // "OUT: 40 frames (12 computed by this run)"
};

// The options of table `table` as an output's provenance stores them: the `resolved` argument
// of a stage's Run when it is called in-process (the command line resolves it from the job
// file, --set and the flags).
template <class Options>
io::Config StoredOptions(const Options& options, const std::string& table) {
  io::Config resolved;
  io::StoreOptions(options, table, &resolved);
  return resolved;
}

// Runs a stage in this process on one rank without MPI (tests, tools): `run` is the stage's
// Run, its options checked as the command line checks them (InvalidInputError naming the
// table) and stored in the output under `table` as the command line would store them. The
// command line's checks of the paths themselves (an output naming an input, a folder, an
// extension; app/registry.h) are not made here: the caller names its own files.
template <class Options, class Summary>
Summary RunInProcess(Summary (*run)(const Options&, const StageContext&, const io::Config&),
                     const Options& options, const std::string& table) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("[" + table + "] " + why);
  StageContext ctx;
  ctx.command_line = "facecap " + table + " (in-process)";
  return run(options, ctx, StoredOptions(options, table));
}

// Provenance for an output of `stage` whose resolved options are `resolved`.
io::Provenance MakeProvenance(const StageContext& ctx, const std::string& stage,
                              const io::Config& resolved);

// The training controller's options for the trainer of `stage` (train/controller.h): its
// name, provenance and model file `out`, and as its identity the hash of `identity_options`
// (the stage's options with those that may change between a run and its continuation reset)
// stored under `table`. The caller sets the steps and cadences.
template <class Options>
train::ControllerOptions TrainingControl(const StageContext& ctx, const io::Config& resolved,
                                         const std::string& stage, const std::string& table,
                                         const std::string& out, const Options& identity_options) {
  train::ControllerOptions control;
  control.name = stage;
  control.out = out;
  control.provenance = MakeProvenance(ctx, stage, resolved);
  io::Config config;
  io::StoreOptions(identity_options, table, &config);
  control.identity = io::ConfigHash(config.ToToml());
  return control;
}

// A trainer's options with those that may change between a run and its continuation (the
// model file, checkpoint and progress cadences, threads) at their defaults: what
// TrainingControl's identity hashes.
template <class Options>
Options TrainingIdentity(const Options& o) {
  Options id = o;
  const Options defaults;
  id.out = defaults.out;
  id.checkpoint_every = defaults.checkpoint_every;
  id.threads = defaults.threads;
  id.progress_seconds = defaults.progress_seconds;
  return id;
}

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_STAGE_H_
