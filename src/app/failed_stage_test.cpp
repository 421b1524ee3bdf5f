// A stage that fails never looks finished: ingest of footage without a face exits 3 and
// leaves nothing under its output's final name, so a rerun of the job runs it again (and
// fails again) instead of skipping it as up to date and exiting 0.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "io/image_io.h"
#include "testing/testing.h"
#include "util/errors.h"
#include "util/image.h"

namespace facecap::app {
namespace {

TEST(FailedStage, JobRerunAfterAFailedIngestFailsAgainInsteadOfSkippingIt) {
  testing::TempDir dir;
  const std::string folder = dir.File("no_faces");
  std::filesystem::create_directories(folder);
  io::WriteImage(folder + "/a.png", Image8(200, 150, 3, 40));
  io::WriteImage(folder + "/b.png", Image8(200, 150, 3, 220));
  const std::string frames = dir.File("frames.h5"), job = dir.File("job.toml");
  std::ofstream(job) << "[run]\nstages = ['ingest', 'curate.build']\n"
                     << "[ingest]\nimages = '" << folder << "'\nout = '" << frames << "'\n"
                     << "[curate.build]\nframes = '" << frames << "'\nout = '"
                     << dir.File("curation.h5") << "'\n";
  for (int attempt = 0; attempt < 2; ++attempt) {
    const testing::CommandResult r = testing::RunFacecap("run " + job);
    EXPECT_EQ(r.code, kExitInput) << "attempt " << attempt << "\n" << r.output;
    EXPECT_NE(r.output.find("no face found"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("up to date"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(frames)) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir.File("curation.h5"))) << r.output;
  }
}

}  // namespace
}  // namespace facecap::app
