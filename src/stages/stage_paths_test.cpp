// Outputs that name inputs: every spelling of the same file (".", "..", symbolic and hard
// links) is refused before any work with exit 2 naming both options, for one stage and
// across the stages of a job.
#include "stages/stage_paths.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::stages {
namespace {

namespace fs = std::filesystem;
using testing::RunFacecap;

std::string Sha(const std::string& path) {
  return testing::RunCommand("sha256sum '" + path + "'").output;
}

TEST(StagePaths, EverySpellingOfAnInputIsTheInput) {
  testing::TempDir dir;
  const std::string rig = dir.File("rig.h5");
  std::ofstream(rig) << "bytes";
  fs::create_directories(dir.File("sub"));
  fs::create_symlink(rig, dir.File("link.h5"));
  fs::create_hard_link(rig, dir.File("hard.h5"));
  for (const std::string& spelling :
       {rig, dir.path() + "/./rig.h5", dir.path() + "/sub/../rig.h5",
        dir.path() + "/absent/../rig.h5", dir.File("link.h5"), dir.File("hard.h5")}) {
    StagePaths paths{"synth.samples", {{"rig", rig}}, {{"out", spelling, OutputKind::kHdf5}}};
    try {
      CheckStagePaths(paths);
      ADD_FAILURE() << spelling << " was accepted";
    } catch (const InvalidInputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("[synth.samples] out '" + spelling + "' is the input rig '" + rig),
                std::string::npos) << what;
    }
  }
  StagePaths other{"synth.samples", {{"rig", rig}}, {{"out", dir.File("samples.h5"), OutputKind::kHdf5}}};
  EXPECT_NO_THROW(CheckStagePaths(other));
}

TEST(StagePaths, OutputsMustBeFilesWithTheirFormatsNamesAndDistinct) {
  testing::TempDir dir;
  fs::create_directories(dir.File("folder.h5"));
  auto check = [&](const std::string& path, OutputKind kind) {
    CheckStagePaths({"render", {}, {{"out", path, kind}}});
  };
  EXPECT_THROW(check(dir.File("folder.h5"), OutputKind::kHdf5), InvalidInputError);
  EXPECT_THROW(check(dir.File("image.bmp"), OutputKind::kImage), InvalidInputError);
  EXPECT_THROW(check(dir.File("take.fbx"), OutputKind::kGltf), InvalidInputError);
  EXPECT_NO_THROW(check(dir.File("IMAGE.PNG"), OutputKind::kImage));
  EXPECT_NO_THROW(check(dir.File("folder.h5"), OutputKind::kFolder));
  std::ofstream(dir.File("file")) << "x";
  EXPECT_THROW(check(dir.File("file"), OutputKind::kFolder), InvalidInputError);
  EXPECT_THROW(CheckStagePaths({"export.overlay", {},
                                {{"out", dir.File("a.png"), OutputKind::kImage},
                                 {"sheet", dir.File("./a.png"), OutputKind::kImage}}}),
               InvalidInputError);
}

TEST(StagePaths, JobStagesNeverOverwriteAnEarlierStagesInputOrEachOther) {
  const StagePaths samples{"synth.samples", {{"rig", "x.h5"}}, {{"out", "y.h5", OutputKind::kHdf5}}};
  const StagePaths calibrate{"rig.calibrate", {{"rig", "y.h5"}}, {{"out", "x.h5", OutputKind::kHdf5}}};
  try {
    CheckJobPaths({samples, calibrate}, "job.toml");
    ADD_FAILURE() << "swapped inputs and outputs were accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("[rig.calibrate] out 'x.h5' is the input rig 'x.h5' of "
                                         "[synth.samples], which runs before it"),
              std::string::npos) << e.what();
  }
  const StagePaths twice{"rig.demo", {}, {{"out", "y.h5", OutputKind::kHdf5}}};
  EXPECT_THROW(CheckJobPaths({samples, twice}, "job.toml"), InvalidInputError);
  // A later stage reading an earlier one's output is the pipeline.
  const StagePaths demo{"rig.demo", {}, {{"out", "x.h5", OutputKind::kHdf5}}};
  EXPECT_NO_THROW(CheckJobPaths({demo, samples}, "job.toml"));
}

TEST(StagePaths, SubcommandsRefuseTheirInputAsOutputAndLeaveItUnchanged) {
  testing::TempDir dir;
  const std::string rig = dir.File("rig.h5"), video = dir.File("clip.mp4");
  ASSERT_EQ(RunFacecap("rig demo --out " + rig).code, 0);
  std::ofstream(video) << "stands for a video";
  const std::string rig_sha = Sha(rig), video_sha = Sha(video);
  for (const std::string& args :
       {"synth samples --rig " + rig + " --out " + dir.path() + "/./rig.h5",
        "render --rig " + rig + " --out " + rig,
        "rig export --rig " + rig + " --gltf " + rig,
        "ingest --video " + video + " --out " + video}) {
    const testing::CommandResult r = RunFacecap(args);
    EXPECT_EQ(r.code, kExitUsage) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("is the input"), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_EQ(Sha(rig), rig_sha);
  EXPECT_EQ(Sha(video), video_sha);
}

TEST(StagePaths, JobWhoseStagesSwapFilesIsRefusedBeforeAnyStageRuns) {
  testing::TempDir dir;
  const std::string job = dir.File("job.toml");
  std::ofstream(job) << "[synth.samples]\nrig = '" << dir.File("x.h5") << "'\nout = '"
                     << dir.File("y.h5") << "'\n[rig.calibrate]\nrig = '" << dir.File("y.h5")
                     << "'\nout = '" << dir.File("x.h5") << "'\n";
  const testing::CommandResult r = RunFacecap("run " + job);
  EXPECT_EQ(r.code, kExitUsage) << r.output;
  EXPECT_NE(r.output.find("which runs before it"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("y.h5")));
}

}  // namespace
}  // namespace facecap::stages
