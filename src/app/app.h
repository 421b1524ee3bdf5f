#ifndef FACECAP_APP_APP_H_
#define FACECAP_APP_APP_H_

namespace CLI { class App; }

namespace facecap::app {

struct AppState;

// Adds every subcommand to `app`, in the order --help lists them; `state` collects the
// stages (StageSpec) that `facecap run` can run.
void RegisterAll(CLI::App* app, AppState* state);

// Parses the command line, runs the subcommand, and returns the process exit code
// (README.md, "Exit codes").
int RunApp(int argc, char** argv);

}  // namespace facecap::app

#endif  // FACECAP_APP_APP_H_
