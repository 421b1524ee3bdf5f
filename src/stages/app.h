#ifndef FACECAP_STAGES_APP_H_
#define FACECAP_STAGES_APP_H_

namespace facecap::stages {

// Parses the command line, runs the subcommand, and returns the process exit code
// (README.md, "Exit codes").
int RunApp(int argc, char** argv);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_APP_H_
