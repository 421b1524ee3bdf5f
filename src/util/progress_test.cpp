#include "util/progress.h"

#include <gtest/gtest.h>

#include "util/parallel_for.h"

namespace facecap {
namespace {

TEST(Progress, FormatsSecondsForBatchLogs) {
  EXPECT_EQ(Progress::FormatSeconds(3.25), "3.2 s");
  EXPECT_EQ(Progress::FormatSeconds(72), "1 min 12 s");
  EXPECT_EQ(Progress::FormatSeconds(3 * 3600 + 5 * 60), "3 h 05 min");
  EXPECT_EQ(Progress::FormatSeconds(-1), "?");
}

TEST(Progress, LineHasCountPercentRateAndNoCarriageReturn) {
  Progress p("synth samples", 4000, 0, 1e9, false);
  const std::string line = p.Line(1000);
  EXPECT_NE(line.find("1000/4000 (25.0%)"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA"), std::string::npos) << line;
  EXPECT_EQ(line.find('\r'), std::string::npos);
}

TEST(ParallelFor, VisitsEveryIndexOnceAndRethrows) {
  std::vector<int> hits(1000, 0);
  ParallelFor(0, 1000, 2, [&](int i) { hits[i] += 1; });
  for (int h : hits) EXPECT_EQ(h, 1);
  EXPECT_THROW(ParallelFor(0, 10, 2, [](int i) { if (i == 7) throw std::runtime_error("x"); }),
               std::runtime_error);
}

}  // namespace
}  // namespace facecap
