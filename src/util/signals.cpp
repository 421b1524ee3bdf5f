#include "util/signals.h"

#include <atomic>
#include <csignal>

namespace facecap {
namespace {

std::atomic<int> g_stop_signal{0};

extern "C" void OnStopSignal(int signal_number) { g_stop_signal.store(signal_number); }

}  // namespace

void InstallStopHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGUSR1, &action, nullptr);
}

bool StopRequested() { return g_stop_signal.load(std::memory_order_relaxed) != 0; }
int StopSignal() { return g_stop_signal.load(); }
void RequestStop(int signal_number) { g_stop_signal.store(signal_number); }
void ClearStopRequest() { g_stop_signal.store(0); }

}  // namespace facecap
