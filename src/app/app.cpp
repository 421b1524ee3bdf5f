#include "app/app.h"

#include <iostream>

#include "app/cli.h"
#include "app/commands.h"
#include "app/registry.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/signals.h"

namespace facecap::app {

void RegisterAll(CLI::App* app, AppState* state) {
  RegisterVersion(app, state);
  RegisterRig(app, state);
  RegisterRender(app, state);
  RegisterSynth(app, state);
  RegisterIngest(app, state);
  RegisterCurate(app, state);
  RegisterDeepfake(app, state);
  RegisterExport(app, state);
  RegisterScans(app, state);
  RegisterBlendshapes(app, state);
  RegisterEvalBlendshapes(app, state);
  RegisterTrack(app, state);
  RegisterPerson(app, state);
  RegisterAppearance(app, state);
  RegisterEval(app, state);
  RegisterTextures(app, state);
  RegisterEvalTextures(app, state);
  RegisterTexturesNetworks(app, state);
  RegisterAssemble(app, state);
  RegisterEvalAssembly(app, state);
  RegisterLipsync(app, state);
  RegisterEvalLipsync(app, state);
  RegisterRegress(app, state);
  RegisterRun(app, state);
}

int RunApp(int argc, char** argv) {
  dist::Comm::Init(&argc, &argv);
  AppState state;
  state.comm = dist::Comm::World();
  state.command_line = JoinCommandLine(argc, argv);
  ConfigureLogging(state.comm.rank(), state.comm.size());
  InstallStopHandlers();

  CLI::App app{
      "facecap: facial capture on a cluster. Tracked, personalized 3D face rigs from video, and\n"
      "personalized blendshapes from one neutral scan. Every stage reads and writes HDF5, runs\n"
      "alone or under mpirun/srun, and resumes when rerun. Exit codes: 0 ok, 1 internal error,\n"
      "2 usage or configuration error, 3 bad input file, 4 output not writable, 5 ranks\n"
      "disagree or MPI failed, 75 stopped by SIGTERM/SIGUSR1 after a checkpoint (rerun to "
      "continue)."};
  app.require_subcommand(1);
  app.fallthrough();
  RegisterAll(&app, &state);

  int code = kExitOk;
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    if (state.comm.IsMainRank()) app.exit(e);
    code = kExitOk;
  } catch (const CLI::CallForAllHelp& e) {
    if (state.comm.IsMainRank()) app.exit(e);
    code = kExitOk;
  } catch (const CLI::ParseError& e) {
    if (state.comm.IsMainRank()) app.exit(e);
    code = e.get_exit_code() == 0 ? kExitOk : kExitUsage;
  } catch (const Error& e) {
    FC_ERROR("{}", e.what());
    code = e.code();
    // An error only this rank saw (rank-0-only work, say, under `facecap run`, whose other
    // ranks wait at the barrier) ends them all. Usage errors are found on every rank alike.
    if (!dist::ExceptionIsCoordinated() && code != kExitUsage) dist::Comm::AbortWorld(code);
  } catch (const std::exception& e) {
    FC_ERROR("internal error: {}", e.what());
    code = kExitFailure;
    if (!dist::ExceptionIsCoordinated()) dist::Comm::AbortWorld(code);
  }
  dist::Comm::Finalize();
  return code;
}

}  // namespace facecap::app
