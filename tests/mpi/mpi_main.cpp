// GoogleTest main for tests run under mpirun: MPI is initialised around the tests and only
// rank 0 prints; a failure on any rank makes that rank exit non-zero, so mpirun fails.
#include <gtest/gtest.h>

#include "dist/comm.h"
#include "util/log.h"

int main(int argc, char** argv) {
  facecap::dist::Comm::Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const facecap::dist::Comm world = facecap::dist::Comm::World();
  facecap::ConfigureLogging(world.rank(), world.size(), spdlog::level::warn);
  if (world.rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int result = RUN_ALL_TESTS();
  facecap::dist::Comm::Finalize();
  return result;
}
