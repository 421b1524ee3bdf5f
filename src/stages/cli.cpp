#include "stages/cli.h"

#include "util/errors.h"

namespace facecap::stages {

io::Config BuildConfig(const StageFlags& flags) {
  io::Config config = flags.job.empty() ? io::Config() : io::Config::Load(flags.job);
  for (const auto& assignment : flags.sets) config.SetAssignment(assignment);
  for (const auto& [key, text] : flags.overrides) config.SetFromText(flags.table, key, text);
  return config;
}

std::string JoinCommandLine(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    const bool quote = arg.find_first_of(" \t'\"") != std::string::npos || arg.empty();
    if (quote) {
      std::string q = "'";
      for (char c : arg) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      arg = q + "'";
    }
    line += (i ? " " : "") + arg;
  }
  return line;
}

io::Provenance MakeProvenance(const StageContext& ctx, const std::string& stage,
                              const io::Config& resolved) {
  io::Provenance p;
  p.stage = stage;
  p.command_line = ctx.command_line;
  p.config = resolved.ToToml();
  p.mpi_ranks = ctx.comm.size();
  return p;
}

}  // namespace facecap::stages
