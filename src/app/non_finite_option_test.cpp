// NaN and infinity through a job file or --set get the same refusal as through a flag
// (exit 2, naming the key and where it came from), before anything is written.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"

namespace facecap::app {
namespace {

using testing::RunFacecap;

TEST(NonFiniteOptions, RenderRefusesNanYawFromEverySource) {
  testing::TempDir dir;
  const std::string rig = dir.File("rig.h5"), png = dir.File("face.png");
  ASSERT_EQ(RunFacecap("rig demo --out " + rig).code, 0);
  std::ofstream(dir.File("job.toml")) << "[render]\nyaw_deg = nan\n";
  const std::string base = "render --rig " + rig + " --out " + png;
  for (const std::string& source :
       {" --job " + dir.File("job.toml"), std::string(" --set render.yaw_deg=nan"),
        std::string(" --set render.yaw_deg=inf"), std::string(" --yaw-deg nan")}) {
    const testing::CommandResult r = RunFacecap(base + source);
    EXPECT_EQ(r.code, kExitUsage) << source << "\n" << r.output;
    EXPECT_NE(r.output.find("yaw"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(png)) << source;
  }
}

}  // namespace
}  // namespace facecap::app
