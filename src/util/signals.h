// SIGTERM and SIGUSR1 set a process-wide stop flag. Long stages poll StopRequested() between
// work items, write their checkpoint, and throw InterruptedError (exit code 75) so Slurm can
// requeue the job; rerunning the same command continues.
#ifndef FACECAP_UTIL_SIGNALS_H_
#define FACECAP_UTIL_SIGNALS_H_

#include <cstdint>

namespace facecap {

// Installs the handlers for SIGTERM and SIGUSR1 (idempotent).
void InstallStopHandlers();
// True once SIGTERM or SIGUSR1 arrived (or RequestStop was called).
bool StopRequested();
// The signal number that requested the stop, 0 if none.
int StopSignal();
// For tests: sets or clears the flag as if a signal had arrived.
void RequestStop(int signal_number);
void ClearStopRequest();

// Fault injection for the restart tests. Once `done` reaches the value of the environment
// variable `variable` (FACECAP_FAULT_AFTER_STEPS, _FRAMES, _ROUNDS), rank FACECAP_FAULT_RANK
// (default 0) sends itself SIGTERM, as Slurm does before a time limit, or SIGKILL with
// FACECAP_FAULT_SIGNAL=KILL (a crash, an OOM kill, a lost node: nothing beyond what is on disk
// survives). At most once per process; without the variable nothing happens.
void MaybeInjectFault(const char* variable, int rank, int64_t done);

}  // namespace facecap

#endif  // FACECAP_UTIL_SIGNALS_H_
