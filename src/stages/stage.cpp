#include "stages/stage.h"

namespace facecap::stages {

std::string StageSummary::Line() const {
  std::string line = out + ": " + std::to_string(items) + " " + unit;
  if (computed == 0) return line + " (up to date)";
  if (computed == items) return line;
  return line + " (" + std::to_string(computed) + " computed by this run)";
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
