// The exception hierarchy thrown at stage boundaries and the process exit codes they map to.
// Exit codes are documented in README.md ("Exit codes"); keep the two in sync.
#ifndef FACECAP_UTIL_ERRORS_H_
#define FACECAP_UTIL_ERRORS_H_

#include <stdexcept>
#include <string>

namespace facecap {

enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,        // an unexpected internal error
  kExitUsage = 2,          // bad command line, job file or option values
  kExitInput = 3,          // an input file is missing, unreadable, truncated or wrongly shaped
  kExitOutput = 4,         // an output could not be written
  kExitParallel = 5,       // ranks disagree (parallel consistency) or MPI failed
  kExitInterrupted = 75,   // stopped by SIGTERM/SIGUSR1 after writing a checkpoint; rerun continues
};

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what, ExitCode code = kExitFailure)
      : std::runtime_error(what), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// Bad command line, job file key or option value.
class InvalidInputError : public Error {
 public:
  explicit InvalidInputError(const std::string& what) : Error(what, kExitUsage) {}
};

// A file that cannot be read, or whose contents are not what was expected.
class FileIOError : public Error {
 public:
  explicit FileIOError(const std::string& what) : Error(what, kExitInput) {}
};

// An output that cannot be written.
class OutputError : public Error {
 public:
  explicit OutputError(const std::string& what) : Error(what, kExitOutput) {}
};

// Ranks that disagree, or an error raised on another rank.
class ParallelConsistencyError : public Error {
 public:
  explicit ParallelConsistencyError(const std::string& what) : Error(what, kExitParallel) {}
};

// A stop was requested by a signal; the stage wrote its checkpoint before throwing.
class InterruptedError : public Error {
 public:
  explicit InterruptedError(const std::string& what) : Error(what, kExitInterrupted) {}
};

}  // namespace facecap

#endif  // FACECAP_UTIL_ERRORS_H_
