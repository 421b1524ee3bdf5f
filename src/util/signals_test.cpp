#include "util/signals.h"

#include <csignal>

#include <gtest/gtest.h>

namespace facecap {
namespace {

TEST(Signals, SigtermAndSigusr1SetTheStopFlag) {
  InstallStopHandlers();
  for (int sig : {SIGTERM, SIGUSR1}) {
    ClearStopRequest();
    EXPECT_FALSE(StopRequested());
    std::raise(sig);  // handled: the process keeps running
    EXPECT_TRUE(StopRequested());
    EXPECT_EQ(StopSignal(), sig);
  }
  ClearStopRequest();
}

}  // namespace
}  // namespace facecap
