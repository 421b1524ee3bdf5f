// The textured scan database and eval textures end to end on a tiny database: the skin maps
// are the same on 1 and 3 ranks and change only where an expression moves the skin, and the
// dynamic textures of eq. 14 beat the static neutral texture on a held-out person.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "testing/testing.h"

namespace facecap::stages {
namespace {

using testing::RunFacecap;

class TexturedScans : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    auto r = RunFacecap(Synth(Scans()));
    ASSERT_EQ(r.code, 0) << r.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Scans() { return dir_->File("scans.h5"); }
  static std::string Synth(const std::string& out) {
    return "scans synth --people 4 --test-people 1 --texture-size 64 --threads 1 --out " + out;
  }
  // The number after "key": inside the object that follows "object": in a JSON text.
  static double Nested(const std::string& json, const std::string& object, const std::string& key) {
    const size_t o = json.find("\"" + object + "\": {");
    if (o == std::string::npos) return NAN;
    const size_t at = json.find("\"" + key + "\": ", o);
    if (at == std::string::npos) return NAN;
    return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
  }
  // Every value of a frame-major dataset.
  static std::vector<float> ReadAll(const io::H5File& f, const std::string& name) {
    const io::Shape shape = f.DatasetShape(name);
    size_t count = 1;
    for (int64_t d : shape) count *= static_cast<size_t>(d);
    std::vector<float> out(count);
    f.ReadFrames<float>(name, 0, shape[0], out.data());
    return out;
  }
  static testing::TempDir* dir_;
};

testing::TempDir* TexturedScans::dir_ = nullptr;

TEST_F(TexturedScans, SkinMapsAreTheSameOnThreeRanksAndMoveOnlyWhereTheSkinMoves) {
  const std::string three = dir_->File("scans3.h5");
  auto r = RunFacecap(Synth(three), 3);
  ASSERT_EQ(r.code, 0) << r.output;
  const io::H5File a = io::H5File::OpenRead(Scans()), b = io::H5File::OpenRead(three);
  for (const char* name : {"/scans/textures/neutral", "/scans/textures/offsets", "/scans/truth/shape_offsets",
                           "/scans/truth/skin"}) {
    EXPECT_EQ(ReadAll(a, name), ReadAll(b, name)) << name;
  }
  ASSERT_EQ(a.DatasetShape("/scans/textures/offsets"), (io::Shape{4, 24, 64, 64, 5}));
  // Each true blendshape's maps at weight 1 (the expressions add unwanted motion of others).
  const io::Shape shape = a.DatasetShape("/scans/truth/shape_offsets");
  ASSERT_EQ(shape.size(), 5u);
  const size_t N = static_cast<size_t>(shape[1]), per_map = 64 * 64 * 5;
  const std::vector<float> offsets = ReadAll(a, "/scans/truth/shape_offsets");
  const std::vector<std::string> names = a.ReadStrings("/scans/shape_names");
  ASSERT_EQ(names.size(), N);
  auto moved = [&](size_t person, const std::string& shape_name) {
    const size_t i = std::find(names.begin(), names.end(), shape_name) - names.begin();
    EXPECT_LT(i, N) << shape_name;
    int texels = 0;
    const float* o = &offsets[(person * N + i) * per_map];
    for (size_t t = 0; t < 64 * 64; ++t) {
      float m = 0;
      for (int c = 0; c < 5; ++c) m = std::max(m, std::abs(o[5 * t + c]));
      texels += m > 0.f;
    }
    return texels;
  };
  for (size_t person = 0; person < 4; ++person) {
    // A blink moves a lid; opening the jaw moves the lower face.
    EXPECT_GT(moved(person, "eyeBlinkLeft"), 0);
    EXPECT_LT(moved(person, "eyeBlinkLeft"), moved(person, "jawOpen") / 2);
    EXPECT_LT(moved(person, "jawOpen"), 64 * 64 / 2);
  }
  const std::vector<float> neutral = ReadAll(a, "/scans/textures/neutral");
  EXPECT_NE(std::vector<float>(neutral.begin(), neutral.begin() + per_map),
            std::vector<float>(neutral.begin() + per_map, neutral.begin() + 2 * per_map));
}

TEST_F(TexturedScans, DynamicTexturesBeatTheStaticNeutralOnAHeldOutPerson) {
  auto r = RunFacecap("eval textures --scans " + Scans());
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* layer : {"albedo_db", "displacement_db"}) {
    const double stat = Nested(r.output, "static_neutral", layer), dyn = Nested(r.output, "dynamic", layer);
    EXPECT_GT(dyn, stat + 3.0) << layer << "\n" << r.output;
  }
  EXPECT_GT(Nested(r.output, "per_blendshape_maps", "albedo_db"), Nested(r.output, "static_neutral", "albedo_db"));
  auto none = RunFacecap("scans synth --people 2 --test-people 1 --texture-size 0 --threads 1 --out " +
                         dir_->File("plain.h5"));
  ASSERT_EQ(none.code, 0) << none.output;
  auto bad = RunFacecap("eval textures --scans " + dir_->File("plain.h5"));
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("no skin maps"), std::string::npos) << bad.output;
}

}  // namespace
}  // namespace facecap::stages
