#include "io/config.h"

#include <string>
#include <vector>

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

// A list of strings may be given as one string (a job file written when the option took one
// file keeps working); other element types are still named.
// NaN passes every range check written as `x < lo || x > hi`: job files and --set refuse
// non-finite numbers as the flags do, naming where the value came from.
TEST(Config, NonFiniteNumbersAreRefusedFromJobFilesAndSet) {
  for (const char* value : {"nan", "-nan", "inf", "-inf", "+inf"}) {
    Config job = Config::Parse(std::string("[synth.samples]\nyaw_max_deg = ") + value + "\n",
                               "job.toml");
    try {
      ResolveOptions<ExampleOptions>(job, "synth.samples");
      ADD_FAILURE() << value << " was accepted";
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("job.toml"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("must be a finite number"), std::string::npos)
          << e.what();
    }
    Config set;
    set.SetAssignment(std::string("synth.samples.yaw_max_deg=") + value);
    EXPECT_THROW(ResolveOptions<ExampleOptions>(set, "synth.samples"), InvalidInputError)
        << value;
  }
  // Finite doubles beyond the float range would become infinity.
  Config big = Config::Parse("[synth.samples]\nyaw_max_deg = 1e39\n", "job.toml");
  EXPECT_THROW(ResolveOptions<ExampleOptions>(big, "synth.samples"), InvalidInputError);
  Config list = Config::Parse("[synth.samples]\nsizes = [64, 4294967360]\n", "job.toml");
  EXPECT_THROW(ResolveOptions<ExampleOptions>(list, "synth.samples"), InvalidInputError);
}

// Found by fuzzing: dotted keys nest tables that toml++ reads but would not read back from
// what ToToml writes; such nesting is refused when parsed.
TEST(Config, DeepNestingIsRefusedAndWhatIsAcceptedReadsBack) {
  std::string deep = "a = {";
  for (int i = 0; i < 100; ++i) deep += "k" + std::to_string(i) + ".";
  deep += "v = 1}\n";
  EXPECT_THROW(Config::Parse(deep, "deep.toml"), InvalidInputError);
  const Config ok = Config::Parse("[synth.samples]\ncount = 3\nsizes = [[1, 2], [3]]\n");
  EXPECT_NO_THROW(Config::Parse(ok.ToToml(), "written back"));
}

TEST(Config, OneStringIsAListOfOne) {
  Config c = Config::Parse("[t]\nfiles = 'a.h5'\nmore = ['b.h5', 'c.h5']\nbad = [1]\n", "job.toml");
  std::vector<std::string> files, more, bad;
  c.Get("t", "files", &files);
  c.Get("t", "more", &more);
  EXPECT_EQ(files, std::vector<std::string>{"a.h5"});
  EXPECT_EQ(more, (std::vector<std::string>{"b.h5", "c.h5"}));
  EXPECT_THROW(c.Get("t", "bad", &bad), InvalidInputError);
}

// The message of the InvalidInputError that `fn` throws; "" when it throws none.
template <typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "";
}

const std::vector<std::string> kJobTables = {"run", "rig.demo", "rig.import", "render",
                                             "synth.samples"};

TEST(Config, CheckTablesAcceptsEveryStageTableAndTheirParents) {
  Config c = Config::Parse(
      "[run]\nstages = ['rig.demo']\n[rig.demo]\nidentity_seed = 3\n[render]\nsize = 64\n"
      "[synth.samples]\ncount = 4\n",
      "job.toml");
  EXPECT_NO_THROW(c.CheckTables(kJobTables));
  EXPECT_NO_THROW(Config().CheckTables(kJobTables));
  EXPECT_NO_THROW(Config::Parse("[rig]\n", "job.toml").CheckTables(kJobTables));
}

TEST(Config, UnknownTableNamesTheFileTheTableAndTheValidTables) {
  for (const char* text : {"[rig.demoo]\nidentity_seed = 3\n", "[rigg]\n",
                           "[rig.demo]\n[rigg.demo]\nout = 'x'\n"}) {
    const std::string msg =
        ErrorOf([&] { Config::Parse(text, "job.toml").CheckTables(kJobTables); });
    EXPECT_EQ(msg.rfind("job.toml: unknown table [rig", 0), 0u) << text << ": " << msg;
    EXPECT_NE(msg.find("valid tables: run, rig.demo, rig.import, render, synth.samples"),
              std::string::npos)
        << msg;
  }
  // A table inside a stage's table is read by no one either.
  const std::string nested = ErrorOf(
      [] { Config::Parse("[render.extra]\nsize = 3\n", "job.toml").CheckTables(kJobTables); });
  EXPECT_NE(nested.find("unknown table [render.extra]"), std::string::npos) << nested;
}

TEST(Config, ValuesOutsideStageTablesAreErrors) {
  const std::string top = ErrorOf(
      [] { Config::Parse("count = 3\n[render]\n", "job.toml").CheckTables(kJobTables); });
  EXPECT_NE(top.find("job.toml: key 'count' outside any table"), std::string::npos) << top;
  const std::string parent =
      ErrorOf([] { Config::Parse("[rig]\nout = 'x'\n", "job.toml").CheckTables(kJobTables); });
  EXPECT_NE(parent.find("job.toml: key 'out' in [rig]"), std::string::npos) << parent;
}

TEST(Config, UnknownTableFromSetIsLabelledSet) {
  Config c = Config::Parse("[rig.demo]\nidentity_seed = 1\n", "job.toml");
  c.SetAssignment("rigdemo.identity_seed=3");
  const std::string msg = ErrorOf([&] { c.CheckTables(kJobTables); });
  EXPECT_EQ(msg.rfind("--set: unknown table [rigdemo]", 0), 0u) << msg;
}

TEST(Config, ErrorsNameTheSourceOfTheValue) {
  Config c = Config::Parse("[t]\ncount = 'many'\n", "job.toml");
  auto resolve = [&] { ResolveOptions<ExampleOptions>(c, "t"); };
  EXPECT_EQ(ErrorOf(resolve).rfind("job.toml: [t] count", 0), 0u) << ErrorOf(resolve);
  c.SetAssignment("t.count=lots");
  EXPECT_EQ(ErrorOf(resolve).rfind("--set: [t] count", 0), 0u) << ErrorOf(resolve);
  c.SetFromText("t", "count", "few", "--count");
  EXPECT_EQ(ErrorOf(resolve).rfind("--count: [t] count", 0), 0u) << ErrorOf(resolve);
  c.SetFromText("t", "count", "-4", "--count");  // parses, fails Check()
  c.SetFromText("t", "out", "x.h5", "--out");
  const std::string check = ErrorOf([&] { ResolveOptions<ExampleOptions>(c, "t"); });
  EXPECT_EQ(check.rfind("--count: [t] count must be positive", 0), 0u) << check;
  c.Set("t", "count", 5);  // set by the program: the job file's origin again
  c.SetAssignment("t.cuont=5");
  const std::string unknown = ErrorOf([&] { ResolveOptions<ExampleOptions>(c, "t"); });
  EXPECT_EQ(unknown.rfind("--set: unknown key 'cuont'", 0), 0u) << unknown;
  // Without a job file, flag values are not labelled as defaults.
  Config flags_only;
  flags_only.SetFromText("t", "yaw_max_deg", "'x'", "--yaw-max-deg");
  const std::string flag = ErrorOf([&] { ResolveOptions<ExampleOptions>(flags_only, "t"); });
  EXPECT_EQ(flag.rfind("--yaw-max-deg: [t] yaw_max_deg", 0), 0u) << flag;
  EXPECT_EQ(flag.find("<defaults>"), std::string::npos) << flag;
}

TEST(Config, TextIsOneLiteralOrAString) {
  Config c;
  c.SetFromText("t", "count", "3\nvideo = true", "--count");
  const std::string msg = ErrorOf([&] { ResolveOptions<ExampleOptions>(c, "t"); });
  EXPECT_NE(msg.find("count must be an integer, got string"), std::string::npos) << msg;
  EXPECT_FALSE(c.Has("t", "video"));
  std::string out;
  c.SetFromText("t", "out", "a = b");
  c.Get("t", "out", &out);
  EXPECT_EQ(out, "a = b");
}

// Options grouped by concern: "loss.rate" lives in [t.loss], its flag is --rate.
struct GroupedOptions {
  int steps = 10;
  float rate = 1e-3f;
  float weight = 1.f;
  bool flip = true;
  template <class V>
  void Visit(V&& v) {
    v("steps", steps, "training steps");
    v("loss.rate", rate, "learning rate");
    v("loss.weight", weight, "a loss weight");
    v("augment.flip", flip, "mirror images");
  }
  bool Check(std::string*) const { return true; }
};

TEST(Config, GroupedOptionsLiveInTheirSubTablesAndRoundTrip) {
  Config c = Config::Parse("[train]\nsteps = 3\n[train.loss]\nrate = 0.5\n[train.augment]\nflip = false\n",
                           "job.toml");
  GroupedOptions o = ResolveOptions<GroupedOptions>(c, "train");
  EXPECT_EQ(o.steps, 3);
  EXPECT_FLOAT_EQ(o.rate, 0.5f);
  EXPECT_FLOAT_EQ(o.weight, 1.f);  // default kept
  EXPECT_FALSE(o.flip);
  Config stored;
  StoreOptions(o, "train", &stored);
  EXPECT_TRUE(stored.Has("train.loss", "weight"));
  EXPECT_FALSE(stored.Has("train", "rate"));
  const GroupedOptions back = ResolveOptions<GroupedOptions>(Config::Parse(stored.ToToml()), "train");
  EXPECT_FLOAT_EQ(back.rate, 0.5f);
  EXPECT_FALSE(back.flip);
  EXPECT_EQ(OptionTables<GroupedOptions>("train"),
            (std::vector<std::string>{"train", "train.loss", "train.augment"}));
  c.SetAssignment("train.loss.rate=0.25");
  EXPECT_FLOAT_EQ(ResolveOptions<GroupedOptions>(c, "train").rate, 0.25f);
}

TEST(Config, AGroupedKeyElsewhereOrAnUnknownGroupIsAnError) {
  const std::string flat = ErrorOf(
      [] { ResolveOptions<GroupedOptions>(Config::Parse("[train]\nrate = 0.5\n", "job.toml"), "train"); });
  EXPECT_EQ(flat.rfind("job.toml: unknown key 'rate' in [train]; 'rate' belongs in [train.loss]", 0), 0u)
      << flat;
  EXPECT_NE(flat.find("and the tables [train.loss], [train.augment]"), std::string::npos) << flat;
  const std::string wrong = ErrorOf([] {
    ResolveOptions<GroupedOptions>(Config::Parse("[train.augment]\nrate = 0.5\n", "job.toml"), "train");
  });
  EXPECT_NE(wrong.find("unknown key 'rate' in [train.augment]; 'rate' belongs in [train.loss]; "
                       "valid keys: flip"),
            std::string::npos)
      << wrong;
  const std::string group = ErrorOf([] {
    ResolveOptions<GroupedOptions>(Config::Parse("[train.losss]\nrate = 0.5\n", "job.toml"), "train");
  });
  EXPECT_EQ(group.rfind("job.toml: unknown table [train.losss]; the option groups of [train] are "
                        "[train.loss], [train.augment]", 0),
            0u)
      << group;
  // A failed check names the origin of a grouped value.
  Config c = Config::Parse("[train.loss]\nrate = 0.5\n", "job.toml");
  c.SetFromText("train.loss", "weight", "2", "--weight");
  EXPECT_EQ(c.OriginOfCheck("train", "weight must be small"), "--weight");
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
