// The subcommand table. Each Register* adds one subcommand (with its --help text and flags)
// and the callback that runs its controller.
#ifndef FACECAP_STAGES_REGISTRY_H_
#define FACECAP_STAGES_REGISTRY_H_

#include <list>
#include <string>

#include <CLI/CLI.hpp>

#include "dist/comm.h"
#include "stages/cli.h"

namespace facecap::stages {

struct AppState {
  dist::Comm comm = dist::Comm::Single();
  std::string command_line;
  std::list<StageFlags> stage_flags;  // one per subcommand; a list keeps pointers stable
  StageFlags* NewFlags() { return &stage_flags.emplace_back(); }
};

void RegisterVersion(CLI::App* app, AppState* state);
void RegisterRig(CLI::App* app, AppState* state);
void RegisterRender(CLI::App* app, AppState* state);

std::string VersionReport(const dist::Comm& comm);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_REGISTRY_H_
