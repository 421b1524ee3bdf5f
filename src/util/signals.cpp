#include "util/signals.h"

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <string>

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

void MaybeInjectFault(const char* variable, int rank, int64_t done) {
  const char* after = std::getenv(variable);
  if (!after || done < std::atoll(after)) return;
  const char* fault_rank = std::getenv("FACECAP_FAULT_RANK");
  if (rank != (fault_rank ? std::atoi(fault_rank) : 0)) return;
  static std::atomic<bool> fired{false};
  if (fired.exchange(true)) return;
  const char* kind = std::getenv("FACECAP_FAULT_SIGNAL");
  std::raise(kind && std::string(kind) == "KILL" ? SIGKILL : SIGTERM);
}

}  // namespace facecap
