// Progress lines for long work that read well in a batch log: one plain line at most every
// `interval_seconds` (and at the end) with done/total, percentage, rate and ETA. No carriage
// returns, so Slurm output files stay readable.
//   [12:00:01 info] synth samples: 1200/4000 (30.0%)  412.3 /s  ETA 6.8 s
#ifndef FACECAP_UTIL_PROGRESS_H_
#define FACECAP_UTIL_PROGRESS_H_

#include <chrono>
#include <cstdint>
#include <string>

namespace facecap {

class Progress {
 public:
  // `already_done` counts work finished by an earlier (resumed) run: it is shown in the count
  // but does not enter the rate.
  Progress(std::string what, int64_t total, int64_t already_done = 0,
           double interval_seconds = 5.0, bool enabled = true);
  // Sets the number of finished items; prints a line when the interval has passed.
  void Update(int64_t done);
  // Prints the final line with the total time.
  void Finish();
  // "ETA 1 min 12 s" style formatting, exposed for tests.
  static std::string FormatSeconds(double seconds);
  // The line that Update would print now, exposed for tests.
  std::string Line(int64_t done) const;

 private:
  using Clock = std::chrono::steady_clock;
  std::string what_;
  int64_t total_;
  int64_t start_done_;
  int64_t done_ = 0;
  double interval_;
  bool enabled_;
  bool finished_ = false;
  Clock::time_point start_;
  Clock::time_point last_print_;
};

}  // namespace facecap

#endif  // FACECAP_UTIL_PROGRESS_H_
