#include <gtest/gtest.h>

#include "util/log.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  facecap::ConfigureLogging(0, 1, spdlog::level::warn);
  return RUN_ALL_TESTS();
}
