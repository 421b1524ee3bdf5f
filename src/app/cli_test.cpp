// The facecap binary as a user meets it: help, version, job files, exit codes.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "app/cli.h"
#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::app {
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

TEST(Cli, RigHelpNamesOnlyRealSubcommands) {
  Result r = RunFacecap("rig --help");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output.find("describe"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("info"), std::string::npos) << r.output;
}

TEST(Cli, UnknownJobFileTableExitsWithUsageCodeAndNamesValidTables) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[rig.demoo]\nidentity_seed = 3\n";
  Result r = RunFacecap("rig demo --job " + job + " --out " + dir.File("rig.h5"));
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find(job + ": unknown table [rig.demoo]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("valid tables: run, rig.demo, rig.import, rig.perturb, rig.export, "
                          "rig.calibrate, render"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::ifstream(dir.File("rig.h5")).good());

  Result set = RunFacecap("rig demo --set rigdemo.identity_seed=3 --out " + dir.File("rig.h5"));
  EXPECT_EQ(set.code, kExitUsage) << set.output;
  EXPECT_NE(set.output.find("--set: unknown table [rigdemo]"), std::string::npos) << set.output;

  const std::string run_job = dir.File("run.toml");
  std::ofstream(run_job) << "[rigg]\nout = '" << dir.File("rig.h5") << "'\n";
  Result run = RunFacecap("run " + run_job);
  EXPECT_EQ(run.code, kExitUsage) << run.output;
  EXPECT_NE(run.output.find(run_job + ": unknown table [rigg]"), std::string::npos) << run.output;
}

TEST(Cli, JobFileWithOtherStagesTablesIsAcceptedByOneStage) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['rig.demo', 'render']\n"
                     << "[rig.demo]\nout = '" << dir.File("rig.h5") << "'\n"
                     << "[render]\nrig = '" << dir.File("rig.h5") << "'\n"
                     << "[synth.samples]\ncount = 8\n";
  Result r = RunFacecap("rig demo --job " + job);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(std::ifstream(dir.File("rig.h5")).good()) << r.output;
}

TEST(Cli, RunChecksEveryStageBeforeTheFirstStartsAndRejectsAJobWithoutStages) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[rig.demo]\nout = '" << dir.File("rig.h5") << "'\n"
                     << "[render]\nrig = '" << dir.File("rig.h5") << "'\nsize = 3\n";
  Result r = RunFacecap("run " + job);
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("[render] size must be in [16, 8192]"), std::string::npos) << r.output;
  EXPECT_FALSE(std::ifstream(dir.File("rig.h5")).good()) << "rig demo ran before the check";

  const std::string empty = dir.File("empty.toml");
  std::ofstream(empty) << "# nothing to run\n";
  Result none = RunFacecap("run " + empty);
  EXPECT_EQ(none.code, kExitUsage) << none.output;
  EXPECT_NE(none.output.find("no stage to run"), std::string::npos) << none.output;
}

// One job runs a stage twice through an instance table [STAGE-NAME]: each run reads its own
// table, is skipped on a rerun when up to date, and an instance [run] does not name is an
// unknown table.
TEST(Cli, RunStageInstancesReadTheirOwnTables) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['rig.demo', 'rig.demo-other']\n"
                     << "[rig.demo]\nout = '" << dir.File("a.h5") << "'\n"
                     << "[rig.demo-other]\nout = '" << dir.File("b.h5") << "'\nidentity_seed = 5\n";
  Result r = RunFacecap("run " + job);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(std::ifstream(dir.File("a.h5")).good());
  EXPECT_TRUE(std::ifstream(dir.File("b.h5")).good());
  EXPECT_NE(r.output.find("rig demo [rig.demo-other]"), std::string::npos) << r.output;
  Result again = RunFacecap("run " + job + " --dry-run");
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("[2/2] rig demo [rig.demo-other]: up to date"), std::string::npos)
      << again.output;
  const std::string stray = dir.File("stray.toml");
  std::ofstream(stray) << "[run]\nstages = ['rig.demo']\n"
                       << "[rig.demo]\nout = '" << dir.File("c.h5") << "'\n"
                       << "[rig.demo-other]\nout = '" << dir.File("d.h5") << "'\n";
  Result bad = RunFacecap("run " + stray);
  EXPECT_EQ(bad.code, kExitUsage) << bad.output;
  EXPECT_NE(bad.output.find("unknown table [rig.demo-other]"), std::string::npos) << bad.output;
}

// Options grouped by concern live in sub-tables of the stage's table ([deepfake.train.loss]),
// an instance's as well ([deepfake.train-small.network]); --help names the table of each group,
// and a grouped key left in the stage's own table is refused naming the table it belongs in.
TEST(Cli, GroupedOptionsLiveInTheirSubTables) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['deepfake.train', 'deepfake.train-small']\n"
                     << "[deepfake.train]\nout = '" << dir.File("a.h5") << "'\n"
                     << "[deepfake.train.loss]\nlearning_rate = 5e-4\n"
                     << "[deepfake.train-small]\nout = '" << dir.File("b.h5") << "'\n"
                     << "[deepfake.train-small.network]\nsize = 32\nskips = 0\n";
  Result r = RunFacecap("run " + job + " --list");
  EXPECT_EQ(r.code, 0) << r.output;
  // The stage alone on the same job accepts the instance's group table: what stops it is the
  // bad value, not the table.
  Result alone = RunFacecap("deepfake train --job " + job + " --steps -1");
  EXPECT_EQ(alone.code, kExitUsage) << alone.output;
  EXPECT_NE(alone.output.find("steps must be >= 0"), std::string::npos) << alone.output;
  Result help = RunFacecap("deepfake train --help");
  EXPECT_NE(help.output.find("Network ([deepfake.train.network]):"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("--learning-rate"), std::string::npos) << help.output;
  const std::string flat = dir.File("flat.toml");
  std::ofstream(flat) << "[deepfake.train]\nout = '" << dir.File("c.h5") << "'\nlearning_rate = 5e-4\n";
  Result bad = RunFacecap("run " + flat + " --list");
  EXPECT_EQ(bad.code, kExitUsage) << bad.output;
  EXPECT_NE(bad.output.find("'learning_rate' belongs in [deepfake.train.loss]"), std::string::npos)
      << bad.output;
  const std::string stray = dir.File("stray.toml");
  std::ofstream(stray) << "[deepfake.train]\nout = '" << dir.File("d.h5") << "'\n"
                       << "[deepfake.train.losses]\nlearning_rate = 5e-4\n";
  Result unknown = RunFacecap("run " + stray + " --list");
  EXPECT_EQ(unknown.code, kExitUsage) << unknown.output;
  EXPECT_NE(unknown.output.find("unknown table [deepfake.train.losses]"), std::string::npos)
      << unknown.output;
}

// One stage of a job with instance tables runs alone with --job: it reads its own table, and the
// instances [run] names are not unknown tables (one it does not name still is).
TEST(Cli, StageAloneAcceptsTheJobsInstanceTables) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['rig.demo', 'rig.demo-other']\n"
                     << "[rig.demo]\nout = '" << dir.File("a.h5") << "'\n"
                     << "[rig.demo-other]\nout = '" << dir.File("b.h5") << "'\n";
  Result r = RunFacecap("rig demo --job " + job);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(std::ifstream(dir.File("a.h5")).good());
  EXPECT_FALSE(std::ifstream(dir.File("b.h5")).good());
  const std::string stray = dir.File("stray.toml");
  std::ofstream(stray) << "[run]\nstages = ['rig.demo']\n"
                       << "[rig.demo]\nout = '" << dir.File("c.h5") << "'\n"
                       << "[rig.demo-other]\nout = '" << dir.File("d.h5") << "'\n";
  Result bad = RunFacecap("rig demo --job " + stray);
  EXPECT_EQ(bad.code, kExitUsage) << bad.output;
  EXPECT_NE(bad.output.find("unknown table [rig.demo-other]"), std::string::npos) << bad.output;
}

// A stage reruns when one of its HDF5 inputs was rewritten after its output (make's rule):
// rerunning the rig makes the render sheet's source stale, and the next run redoes it.
TEST(Cli, RunRedoesAStageWhoseInputIsNewerThanItsOutput) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['rig.demo', 'synth.samples']\n"
                     << "[rig.demo]\nout = '" << dir.File("rig.h5") << "'\n"
                     << "[synth.samples]\nrig = '" << dir.File("rig.h5") << "'\ncount = 2\nsize = 32\n"
                     << "out = '" << dir.File("samples.h5") << "'\n";
  ASSERT_EQ(RunFacecap("run " + job).code, 0);
  Result fresh = RunFacecap("run " + job + " --dry-run");
  EXPECT_NE(fresh.output.find("[2/2] synth samples: up to date"), std::string::npos) << fresh.output;
  // The rig is made again (forced), so the samples are older than their input.
  ASSERT_EQ(RunFacecap("run " + job + " --from rig.demo --until rig.demo").code, 0);
  Result stale = RunFacecap("run " + job + " --dry-run");
  EXPECT_NE(stale.output.find("[1/2] rig demo: up to date"), std::string::npos) << stale.output;
  EXPECT_NE(stale.output.find("[2/2] synth samples: runs: its input " + dir.File("rig.h5") +
                              " is newer than its output"),
            std::string::npos)
      << stale.output;
  ASSERT_EQ(RunFacecap("run " + job).code, 0);
  Result again = RunFacecap("run " + job + " --dry-run");
  EXPECT_NE(again.output.find("[2/2] synth samples: up to date"), std::string::npos) << again.output;
}

TEST(Cli, NumericFlagTextIsExactlyOneNumber) {
  EXPECT_EQ(NumberFlagToToml("42", true), "42");
  EXPECT_EQ(NumberFlagToToml("-7", true), "-7");
  EXPECT_EQ(NumberFlagToToml("+007", true), "7");
  EXPECT_EQ(NumberFlagToToml("-9223372036854775808", true), "-9223372036854775808");
  EXPECT_EQ(NumberFlagToToml("0.5", false), "0.5");
  EXPECT_EQ(NumberFlagToToml("-.25", false), "-0.25");
  EXPECT_EQ(NumberFlagToToml("3", false), "3");
  EXPECT_EQ(NumberFlagToToml("1e20", false), "1e+20");
  EXPECT_EQ(NumberFlagToToml("2.5E-3", false), "0.0025");
  for (const char* bad : {"", " ", "1 2", "3\n", "3\nidentity_scale = 9", " 3", "1.5", "0x10",
                          "1e3", "9223372036854775808", "--3", "1_000", "seven"}) {
    EXPECT_EQ(NumberFlagToToml(bad, true), "") << "integer '" << bad << "'";
  }
  for (const char* bad : {"", ".", "0.5 1", "nan", "inf", "-inf", "1e999", "0.5x", "1e", "1e+",
                          "0x1p3", "1,5", "2.5\n"}) {
    EXPECT_EQ(NumberFlagToToml(bad, false), "") << "number '" << bad << "'";
  }
  EXPECT_EQ(FlagTextToToml<int>("12"), "12");
  EXPECT_THROW(FlagTextToToml<int>("1 2"), InvalidInputError);
  EXPECT_THROW(FlagTextToToml<float>("nan"), InvalidInputError);
}

TEST(Cli, NumericFlagThatIsNotOneNumberExitsWithUsageCode) {
  testing::TempDir dir;
  const std::string out = " --out " + dir.File("rig.h5");
  // A newline would have smuggled a second key into the table.
  Result r = RunFacecap("rig demo --identity-seed '3\nidentity_scale = 9'" + out);
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("--identity-seed: expected an integer"), std::string::npos) << r.output;
  Result nan = RunFacecap("rig demo --identity-scale nan" + out);
  EXPECT_EQ(nan.code, kExitUsage) << nan.output;
  EXPECT_NE(nan.output.find("--identity-scale: expected a number"), std::string::npos)
      << nan.output;
  EXPECT_FALSE(std::ifstream(dir.File("rig.h5")).good());
  // A range error names the flag, not "<defaults>".
  Result range = RunFacecap("rig demo --identity-scale 9" + out);
  EXPECT_EQ(range.code, kExitUsage) << range.output;
  EXPECT_NE(range.output.find("--identity-scale: [rig.demo]"), std::string::npos) << range.output;
  EXPECT_EQ(range.output.find("<defaults>"), std::string::npos) << range.output;
}

}  // namespace
}  // namespace facecap::app
