// What every stage controller receives: the communicator, the job configuration with the
// command-line overrides applied, and the command line for provenance.
#ifndef FACECAP_STAGES_STAGE_H_
#define FACECAP_STAGES_STAGE_H_

#include <string>

#include "dist/comm.h"
#include "io/config.h"
#include "io/hdf5.h"

namespace facecap::stages {

struct StageContext {
  dist::Comm comm = dist::Comm::Single();
  io::Config config;          // job file + --set + flags
  std::string command_line;   // as typed, for provenance
};

// Provenance for an output of `stage` whose resolved options are `resolved`.
io::Provenance MakeProvenance(const StageContext& ctx, const std::string& stage,
                              const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_STAGE_H_
