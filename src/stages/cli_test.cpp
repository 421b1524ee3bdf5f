// The facecap binary as a user meets it: help, version, job files, exit codes.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;
using Result = testing::CommandResult;

TEST(Cli, HelpListsSubcommands) {
  Result r = RunFacecap("--help");
  EXPECT_EQ(r.code, 0);
  for (const char* sub : {"version", "rig", "render"}) {
    EXPECT_NE(r.output.find(sub), std::string::npos) << sub << "\n" << r.output;
  }
  Result demo = RunFacecap("rig demo --help");
  EXPECT_EQ(demo.code, 0);
  EXPECT_NE(demo.output.find("--identity-seed"), std::string::npos) << demo.output;
  EXPECT_NE(demo.output.find("default: 0"), std::string::npos) << demo.output;
}

TEST(Cli, VersionNamesDependenciesParallelHdf5RanksAndThreads) {
  Result r = RunFacecap("version");
  EXPECT_EQ(r.code, 0);
  for (const char* what : {"facecap ", "commit", "HDF5", "parallel", "Open MPI", "libtorch",
                           "Ceres", "OpenCV", "dlib", "MPI ranks 1", "OpenMP threads"}) {
    EXPECT_NE(r.output.find(what), std::string::npos) << what << "\n" << r.output;
  }
}

TEST(Cli, UnknownJobFileKeyExitsWithUsageCodeAndNamesValidKeys) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[rig.demo]\nidentity_sed = 3\n";
  Result r = RunFacecap("rig demo --job " + job + " --out " + dir.File("rig.h5"));
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("identity_sed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("valid keys: out, identity_seed"), std::string::npos) << r.output;
}

TEST(Cli, BadValuesAndMissingInputsHaveTheirExitCodes) {
  testing::TempDir dir;
  EXPECT_EQ(RunFacecap("rig demo --identity-scale 9 --out " + dir.File("r.h5")).code, kExitUsage);
  EXPECT_EQ(RunFacecap("rig demo --identity-seed many").code, kExitUsage);
  EXPECT_EQ(RunFacecap("no-such-subcommand").code, kExitUsage);
  Result missing = RunFacecap("render --rig " + dir.File("absent.h5") + " --out " + dir.File("x.png"));
  EXPECT_EQ(missing.code, kExitInput) << missing.output;
  EXPECT_NE(missing.output.find("absent.h5"), std::string::npos) << missing.output;
}

}  // namespace
}  // namespace facecap::stages
