// facecap version: version, commit, dependency versions, HDF5 parallel, ranks and threads.
#include <omp.h>

#include <iostream>
#include <sstream>

#include "dist/comm.h"
#include "io/hdf5_info.h"
#include "app/commands.h"
#include "app/registry.h"
#include "util/version.h"

namespace facecap::app {

std::string VersionReport(const dist::Comm& comm) {
  std::ostringstream os;
  os << "facecap " << Version() << " (commit " << GitCommit() << ")\n";
  os << "dependencies (built against):\n";
  std::stringstream deps(FACECAP_DEPENDENCY_VERSIONS);
  std::string item;
  while (std::getline(deps, item, '|')) os << "  " << item << "\n";
  os << "runtime:\n";
  os << "  HDF5 library " << io::Hdf5RuntimeVersion()
     << (io::Hdf5IsParallel() ? ", parallel (MPI-IO)" : ", serial") << "\n";
  os << "  MPI library " << dist::Comm::LibraryVersion() << "\n";
  os << "  MPI ranks " << comm.size() << (comm.IsSingle() ? " (single-rank mode, no launcher)" : "")
     << "\n";
  os << "  OpenMP threads per rank " << omp_get_max_threads() << " (of " << omp_get_num_procs()
     << " processors)\n";
  return os.str();
}

void RegisterVersion(CLI::App* app, AppState* state) {
  CLI::App* sub = app->add_subcommand(
      "version", "Print the version, git commit, dependency versions, whether HDF5 is "
                 "parallel, the MPI rank count and thread counts");
  sub->callback([state] {
    if (state->comm.IsMainRank()) std::cout << VersionReport(state->comm) << std::flush;
  });
}

}  // namespace facecap::app
