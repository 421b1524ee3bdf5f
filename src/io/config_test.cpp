#include "io/config.h"

#include <gtest/gtest.h>

namespace facecap::io {
namespace {

struct ExampleOptions {
  int count = 4000;          // number of samples
  float yaw_max_deg = 80.f;  // largest yaw
  bool video = false;        // also write an mp4
  std::string out = "samples.h5";
  std::vector<int> sizes = {64, 128};
  template <class V>
  void Visit(V&& v) {
    v("count", count, "number of samples");
    v("yaw_max_deg", yaw_max_deg, "largest yaw in degrees");
    v("video", video, "also write an mp4");
    v("out", out, "output file");
    v("sizes", sizes, "image sizes");
  }
  bool Check(std::string* why) const {
    if (count <= 0) {
      *why = "count must be positive, got " + std::to_string(count);
      return false;
    }
    return true;
  }
};

TEST(Config, LoadsTableIntoStructAndKeepsDefaults) {
  Config c = Config::Parse("[synth.samples]\ncount = 12\nyaw_max_deg = 45\nsizes = [32]\n", "job.toml");
  ExampleOptions o = ResolveOptions<ExampleOptions>(c, "synth.samples");
  EXPECT_EQ(o.count, 12);
  EXPECT_FLOAT_EQ(o.yaw_max_deg, 45.f);  // an integer is accepted for a float
  EXPECT_EQ(o.out, "samples.h5");        // default kept
  EXPECT_EQ(o.sizes, std::vector<int>{32});
}

TEST(Config, UnknownKeyListsValidKeys) {
  Config c = Config::Parse("[synth.samples]\ncuont = 12\n", "job.toml");
  try {
    ResolveOptions<ExampleOptions>(c, "synth.samples");
    FAIL();
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("job.toml"), std::string::npos) << msg;
    EXPECT_NE(msg.find("cuont"), std::string::npos) << msg;
    EXPECT_NE(msg.find("count, yaw_max_deg, video, out, sizes"), std::string::npos) << msg;
  }
}

TEST(Config, WrongTypeAndFailedCheckAreUsageErrors) {
  EXPECT_THROW(ResolveOptions<ExampleOptions>(Config::Parse("[t]\ncount = 'many'\n"), "t"),
               InvalidInputError);
  EXPECT_THROW(ResolveOptions<ExampleOptions>(Config::Parse("[t]\ncount = -1\n"), "t"),
               InvalidInputError);
  EXPECT_THROW(Config::Parse("[t\ncount = 1\n"), InvalidInputError);
  EXPECT_THROW(Config::Load("/nonexistent/job.toml"), FileIOError);
}

TEST(Config, OverridesFromTextAndAssignments) {
  Config c;
  c.SetFromText("t", "count", "7");
  c.SetFromText("t", "out", "x.h5");  // not a TOML literal: kept as a string
  c.SetAssignment("t.video=true");
  c.SetAssignment("t.sizes=[16, 24]");
  ExampleOptions o = ResolveOptions<ExampleOptions>(c, "t");
  EXPECT_EQ(o.count, 7);
  EXPECT_EQ(o.out, "x.h5");
  EXPECT_TRUE(o.video);
  EXPECT_EQ(o.sizes, (std::vector<int>{16, 24}));
  EXPECT_THROW(c.SetAssignment("novalue"), InvalidInputError);
}

TEST(Config, StoredOptionsRoundTripThroughToml) {
  ExampleOptions o;
  o.count = 99;
  o.out = "a \"quoted\" name.h5";
  Config c;
  StoreOptions(o, "synth.samples", &c);
  Config back = Config::Parse(c.ToToml());
  ExampleOptions r = ResolveOptions<ExampleOptions>(back, "synth.samples");
  EXPECT_EQ(r.count, 99);
  EXPECT_EQ(r.out, o.out);
  EXPECT_EQ(r.sizes, o.sizes);
}

}  // namespace
}  // namespace facecap::io
