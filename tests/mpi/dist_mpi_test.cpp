// The MPI layer at whatever rank count mpirun gave (CTest runs 1, 2 and 3).
#include <algorithm>
#include <numeric>

#include <gtest/gtest.h>

#include "dist/comm.h"
#include "util/errors.h"

namespace facecap::dist {
namespace {

Comm World() { return Comm::World(); }

TEST(CommMpi, RunsUnderTheLauncher) {
  EXPECT_TRUE(Comm::MpiActive());
  EXPECT_GE(World().size(), 1);
}

TEST(CommMpi, SumReduceAddsEveryRanksBuffer) {
  const Comm comm = World();
  const int n = comm.size();
  std::vector<double> d(1001);
  std::vector<float> f(17);
  for (size_t i = 0; i < d.size(); ++i) d[i] = (comm.rank() + 1) * 0.5 + i;
  for (size_t i = 0; i < f.size(); ++i) f[i] = static_cast<float>(comm.rank() * i);
  comm.SumReduce(d.data(), static_cast<int64_t>(d.size()));
  comm.SumReduce(f.data(), static_cast<int64_t>(f.size()));
  const double rank_sum = 0.5 * n * (n + 1) / 2.0;
  for (size_t i = 0; i < d.size(); ++i) ASSERT_DOUBLE_EQ(d[i], rank_sum + n * double(i));
  for (size_t i = 0; i < f.size(); ++i) ASSERT_FLOAT_EQ(f[i], float(n * (n - 1) / 2 * i));
}

TEST(CommMpi, SumReduceInSmallChunksAddsEveryElementAndNoMore) {
  // The split that buffers above INT_MAX elements take, with chunks of 7 elements: 1001 values
  // are 143 whole chunks, 1000 end in a partial one. The buffer is longer than `count`, and
  // what lies past `count` must stay as it was.
  const Comm comm = World();
  const int n = comm.size();
  for (const int64_t count : {int64_t{1001}, int64_t{1000}, int64_t{3}}) {
    std::vector<double> d(count + 5);
    std::vector<float> f(count + 5);
    std::vector<int64_t> k(count + 5);
    for (size_t i = 0; i < d.size(); ++i) {
      d[i] = (comm.rank() + 1) * 0.25 + static_cast<double>(i);
      f[i] = static_cast<float>(comm.rank() + 1);
      k[i] = (int64_t{1} << 40) * (comm.rank() + 1) + static_cast<int64_t>(i);
    }
    comm.SumReduce(d.data(), count, 7);
    comm.SumReduce(f.data(), count, 7);
    comm.SumReduce(k.data(), count, 7);
    const int64_t ranks_sum = int64_t{n} * (n + 1) / 2;  // 1 + 2 + ... + n
    for (int64_t i = 0; i < count; ++i) {
      ASSERT_DOUBLE_EQ(d[i], 0.25 * ranks_sum + n * static_cast<double>(i)) << "element " << i;
      ASSERT_FLOAT_EQ(f[i], static_cast<float>(ranks_sum)) << "element " << i;
      ASSERT_EQ(k[i], (int64_t{1} << 40) * ranks_sum + n * i) << "element " << i;
    }
    for (int64_t i = count; i < count + 5; ++i) {
      ASSERT_DOUBLE_EQ(d[i], (comm.rank() + 1) * 0.25 + static_cast<double>(i)) << "past the end";
      ASSERT_FLOAT_EQ(f[i], static_cast<float>(comm.rank() + 1)) << "past the end";
      ASSERT_EQ(k[i], (int64_t{1} << 40) * (comm.rank() + 1) + i) << "past the end";
    }
  }
  // A chunk of one element, and a chunk larger than the buffer, give the same sums.
  std::vector<double> one(11, comm.rank() + 1.0), big(11, comm.rank() + 1.0);
  comm.SumReduce(one.data(), 11, 1);
  comm.SumReduce(big.data(), 11, 1 << 20);
  for (int i = 0; i < 11; ++i) {
    EXPECT_DOUBLE_EQ(one[i], n * (n + 1) / 2.0);
    EXPECT_DOUBLE_EQ(big[i], n * (n + 1) / 2.0);
  }
}

TEST(CommMpi, BroadcastAndGatherCarryBytesInRankOrder) {
  const Comm comm = World();
  std::string text = comm.IsMainRank() ? "weights from rank 0" : "";
  comm.Broadcast(&text);
  EXPECT_EQ(text, "weights from rank 0");
  std::vector<uint8_t> mine(comm.rank() + 1, static_cast<uint8_t>(comm.rank()));
  auto all = comm.AllGather(mine);
  ASSERT_EQ(static_cast<int>(all.size()), comm.size());
  for (int r = 0; r < comm.size(); ++r) {
    EXPECT_EQ(all[r].size(), static_cast<size_t>(r + 1));
    EXPECT_TRUE(std::all_of(all[r].begin(), all[r].end(), [r](uint8_t v) { return v == r; }));
  }
}

TEST(CommMpi, WorkQueueHandsOutEveryItemExactlyOnce) {
  const Comm comm = World();
  const int64_t num_items = 103;
  std::vector<int64_t> claimed;
  {
    WorkQueue queue(comm, num_items, 2);
    int64_t count = 0;
    for (int64_t first = queue.Next(&count); first >= 0; first = queue.Next(&count)) {
      for (int64_t i = first; i < first + count; ++i) claimed.push_back(i);
    }
  }
  std::vector<uint8_t> bytes(reinterpret_cast<uint8_t*>(claimed.data()),
                             reinterpret_cast<uint8_t*>(claimed.data() + claimed.size()));
  auto all = comm.AllGather(bytes);
  std::vector<int64_t> every;
  for (const auto& part : all) {
    const int64_t* p = reinterpret_cast<const int64_t*>(part.data());
    every.insert(every.end(), p, p + part.size() / sizeof(int64_t));
  }
  std::sort(every.begin(), every.end());
  std::vector<int64_t> expected(num_items);
  std::iota(expected.begin(), expected.end(), 0);
  EXPECT_EQ(every, expected);
}

TEST(CommMpi, ExceptionOnOneRankBecomesAnExceptionOnEveryRank) {
  const Comm comm = World();
  const int failing = comm.size() - 1;
  try {
    CoordinateExceptions(comm, [&] {
      if (comm.rank() == failing) throw FileIOError("frames.h5: broken on the last rank");
    });
    FAIL() << "no rank may pass";
  } catch (const FileIOError& e) {
    EXPECT_EQ(comm.rank(), failing);
  } catch (const ParallelConsistencyError& e) {
    EXPECT_NE(comm.rank(), failing);
    EXPECT_NE(std::string(e.what()).find("broken on the last rank"), std::string::npos);
  }
  // And nobody hangs afterwards: a collective still works.
  double one = 1.0;
  comm.SumReduce(&one, 1);
  EXPECT_DOUBLE_EQ(one, comm.size());
}

TEST(CommMpi, BlockRangesTileTheItems) {
  const Comm comm = World();
  for (int64_t n : {0, 1, 2, 7, 100}) {
    int64_t covered = 0, expected_begin = 0;
    for (int r = 0; r < comm.size(); ++r) {
      Range range = BlockRange(n, r, comm.size());
      EXPECT_EQ(range.begin, expected_begin);
      covered += range.end - range.begin;
      expected_begin = range.end;
    }
    EXPECT_EQ(covered, n);
  }
}

}  // namespace
}  // namespace facecap::dist
