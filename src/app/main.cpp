// facecap: one binary, a table of subcommands (stages/registry.h).
#include "stages/app.h"

int main(int argc, char** argv) { return facecap::stages::RunApp(argc, argv); }
