// Half-configured jobs: a stage named in [run] without its table, and [run] stages that is
// not an array, are errors that name them; nothing runs and the current folder is untouched.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::app {
namespace {

using testing::RunCommand;

TEST(JobPlan, StageWithoutItsTableIsAnErrorNamingIt) {
  testing::TempDir dir;
  std::ofstream(dir.File("job.toml")) << "[run]\nstages = ['rig.demo', 'synth.samples']\n"
                                      << "[rig.demo]\nout = 'person.h5'\n";
  std::ofstream(dir.File("samples.h5")) << "an unrelated file";
  const testing::CommandResult r =
      RunCommand("cd " + dir.path() + " && " + testing::BuildDir() + "/facecap run job.toml");
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("names 'synth.samples', but the job has no [synth.samples] table"),
            std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("person.h5"))) << "a stage ran";
  std::ifstream in(dir.File("samples.h5"));
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(text, "an unrelated file");
}

TEST(JobPlan, StagesMustBeAnArray) {
  testing::TempDir dir;
  std::ofstream(dir.File("job.toml")) << "[run]\nstages = 'rig.demo'\n[rig.demo]\n";
  const testing::CommandResult r = testing::RunFacecap("run " + dir.File("job.toml"));
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("[run] stages must be an array"), std::string::npos) << r.output;
}

// Every job file shipped in jobs/ names known stages with known keys and valid values: --list
// checks each table as its stage would and prints one line per stage.
TEST(JobPlan, EveryShippedJobFileIsValid) {
  int jobs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(testing::SourceDir() + "/jobs")) {
    if (entry.path().extension() != ".toml") continue;
    ++jobs;
    const testing::CommandResult r = testing::RunFacecap("run " + entry.path().string() + " --list");
    EXPECT_EQ(r.code, 0) << entry.path() << ": " << r.output;
    std::istringstream lines(r.output);
    int listed = 0;
    for (std::string line; std::getline(lines, line);) listed += !line.empty();
    EXPECT_GE(listed, 1) << entry.path();
  }
  EXPECT_GE(jobs, 10);
}

}  // namespace
}  // namespace facecap::app
