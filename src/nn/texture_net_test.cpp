// The expression texture networks: they start at "no change", learn a texel-wise rule from
// a few examples (the loss falls by half), and a checkpoint's state continues bitwise.
#include "nn/texture_net.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::nn {
namespace {

constexpr int kSize = 16;
constexpr int kTexels = kSize * kSize;

// Examples whose albedo and detail targets are a local function of the inputs: darker where
// the expression's compress influence (channel 3) is high, scaled by the neutral's
// displacement (channel 4 of the person) — the kind of rule the database's skin follows.
struct Examples {
  std::vector<std::vector<float>> person, expression, target;
  std::vector<float> mask = std::vector<float>(kTexels, 1.f);
  std::vector<TextureExample> batch() const {
    std::vector<TextureExample> out;
    for (size_t i = 0; i < person.size(); ++i) out.push_back({person[i].data(), expression[i].data(), target[i].data(), mask.data()});
    return out;
  }
};

Examples MakeExamples(int count) {
  Examples e;
  Rng rng(7, 0);
  for (int i = 0; i < count; ++i) {
    std::vector<float> p(TextureNets::kPersonChannels * kTexels), x(TextureNets::kExpressionChannels * kTexels),
        t(TextureNets::kOutputChannels * kTexels);
    for (float& v : p) v = static_cast<float>(rng.Normal());
    for (float& v : x) v = static_cast<float>(rng.Normal());
    for (int k = 0; k < kTexels; ++k) {
      const float compress = std::max(0.f, x[3 * kTexels + k]), depth = p[4 * kTexels + k];
      for (int c = 0; c < 3; ++c) t[c * kTexels + k] = -compress * (1.f + 0.3f * c);
      t[3 * kTexels + k] = -0.5f * compress;
      t[5 * kTexels + k] = -compress * depth;
    }
    e.person.push_back(std::move(p));
    e.expression.push_back(std::move(x));
    e.target.push_back(std::move(t));
  }
  return e;
}

TextureNetOptions SmallOptions() {
  TextureNetOptions o;
  o.channels = 8;
  o.residual_blocks = 1;
  o.learning_rate = 3e-3f;
  return o;
}

TEST(TextureNets, StartAtNoChangeAndLearnALocalRule) {
  TextureNets nets(SmallOptions(), kSize);
  const Examples e = MakeExamples(4);
  for (float v : nets.Predict(e.person[0].data(), e.expression[0].data())) EXPECT_EQ(v, 0.f);
  double first[2], last[2];
  for (int step = 0; step < 150; ++step) {
    double losses[2];
    nets.Backward(e.batch(), 0.25f, losses);
    nets.OptimizerStep();
    if (step == 0) std::copy(losses, losses + 2, first);
    std::copy(losses, losses + 2, last);
  }
  EXPECT_LT(last[0], 0.5 * first[0]);
  EXPECT_LT(last[1], 0.5 * first[1]);
  EXPECT_EQ(nets.Predict(e.person[1].data(), e.expression[1].data()).size(),
            static_cast<size_t>(TextureNets::kOutputChannels) * kTexels);
}

TEST(TextureNets, StateContinuesBitwiseAndBadSizesAreRefused) {
  const Examples e = MakeExamples(2);
  TextureNets straight(SmallOptions(), kSize), resumed(SmallOptions(), kSize);
  double losses[2];
  for (int step = 0; step < 3; ++step) {
    straight.Backward(e.batch(), 0.5f, losses);
    straight.OptimizerStep();
    if (step == 1) resumed.SetState(straight.State());
  }
  resumed.Backward(e.batch(), 0.5f, losses);
  resumed.OptimizerStep();
  EXPECT_EQ(straight.Parameters(), resumed.Parameters());
  EXPECT_THROW(resumed.SetState(std::vector<float>(5)), FileIOError);
  EXPECT_THROW(TextureNets(SmallOptions(), 18), InvalidInputError);
  TextureNetOptions bad = SmallOptions();
  bad.learning_rate = 0.f;
  EXPECT_THROW(TextureNets(bad, kSize), InvalidInputError);
}

}  // namespace
}  // namespace facecap::nn
