// Comm in single-rank mode (a plain process, no launcher): every collective is the identity,
// so algorithms and tests run the same with and without mpirun.
#include "dist/comm.h"

#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "util/errors.h"

namespace facecap::dist {
namespace {

TEST(CommSingle, IsOneMainRank) {
  const Comm comm = Comm::Single();
  EXPECT_TRUE(comm.IsSingle());
  EXPECT_TRUE(comm.IsMainRank());
  EXPECT_EQ(comm.rank(), 0);
  EXPECT_EQ(comm.size(), 1);
  EXPECT_LT(comm.handle(), 0);
  comm.Barrier();
}

TEST(CommSingle, SumReduceKeepsTheValuesWhateverTheChunk) {
  const Comm comm = Comm::Single();
  std::vector<double> d(1001);
  std::iota(d.begin(), d.end(), 0.5);
  std::vector<int64_t> k(1001);
  std::iota(k.begin(), k.end(), int64_t{1} << 40);
  std::vector<float> f(1001, 2.f);
  const std::vector<double> d0 = d;
  const std::vector<int64_t> k0 = k;
  for (const int64_t chunk : {int64_t{1}, int64_t{7}, Comm::kMaxReduceChunk}) {
    comm.SumReduce(d.data(), static_cast<int64_t>(d.size()), chunk);
    comm.SumReduce(k.data(), static_cast<int64_t>(k.size()), chunk);
    comm.SumReduce(f.data(), static_cast<int64_t>(f.size()), chunk);
  }
  EXPECT_EQ(d, d0);
  EXPECT_EQ(k, k0);
  EXPECT_EQ(f, std::vector<float>(1001, 2.f));
  comm.SumReduce(d.data(), 0, 7);  // nothing to reduce
}

TEST(CommSingle, SumReduceRejectsAChunkMpiCannotCount) {
  const Comm comm = Comm::Single();
  double x = 1.0;
  EXPECT_THROW(comm.SumReduce(&x, 1, 0), Error);
  EXPECT_THROW(comm.SumReduce(&x, 1, -7), Error);
  EXPECT_THROW(comm.SumReduce(&x, 1, int64_t{INT_MAX} + 1), Error);
  EXPECT_EQ(x, 1.0);
}

TEST(CommSingle, CollectivesAreTheIdentity) {
  const Comm comm = Comm::Single();
  EXPECT_EQ(comm.Max(2.5), 2.5);
  EXPECT_EQ(comm.Min(-1.0), -1.0);
  EXPECT_TRUE(comm.AnyTrue(true));
  EXPECT_FALSE(comm.AnyTrue(false));
  std::string text = "only rank";
  comm.Broadcast(&text);
  EXPECT_EQ(text, "only rank");
  std::vector<int> values = {1, 2, 3};
  comm.Broadcast(&values);
  EXPECT_EQ(values, (std::vector<int>{1, 2, 3}));
  const std::vector<uint8_t> mine = {4, 5};
  const auto gathered = comm.Gather(mine);
  ASSERT_EQ(gathered.size(), 1u);
  EXPECT_EQ(gathered[0], mine);
  const auto all = comm.AllGather(mine);
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0], mine);
}

TEST(CommSingle, WorkQueueHandsOutEveryItemInOrder) {
  const Comm comm = Comm::Single();
  WorkQueue queue(comm, 10, 3);
  std::vector<int64_t> firsts, counts;
  int64_t count = 0;
  for (int64_t first = queue.Next(&count); first >= 0; first = queue.Next(&count)) {
    firsts.push_back(first);
    counts.push_back(count);
  }
  EXPECT_EQ(firsts, (std::vector<int64_t>{0, 3, 6, 9}));
  EXPECT_EQ(counts, (std::vector<int64_t>{3, 3, 3, 1}));
}

TEST(CommSingle, ExceptionsPassThroughUnchanged) {
  const Comm comm = Comm::Single();
  EXPECT_THROW(CoordinateExceptions(comm, [] { throw FileIOError("x.h5: broken"); }),
               FileIOError);
  EXPECT_NO_THROW(CoordinateExceptions(comm, [] {}));
}

}  // namespace
}  // namespace facecap::dist
