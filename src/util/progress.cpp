#include "util/progress.h"

#include <cmath>

#include "util/log.h"

namespace facecap {

Progress::Progress(std::string what, int64_t total, int64_t already_done, double interval_seconds,
                   bool enabled)
    : what_(std::move(what)),
      total_(total),
      start_done_(already_done),
      done_(already_done),
      interval_(interval_seconds),
      enabled_(enabled),
      start_(Clock::now()),
      last_print_(Clock::now()) {}

std::string Progress::FormatSeconds(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  char buf[64];
  if (seconds < 60) {
    std::snprintf(buf, sizeof(buf), "%.1f s", seconds);
  } else if (seconds < 3600) {
    std::snprintf(buf, sizeof(buf), "%d min %02d s", static_cast<int>(seconds) / 60,
                  static_cast<int>(seconds) % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%d h %02d min", static_cast<int>(seconds) / 3600,
                  (static_cast<int>(seconds) % 3600) / 60);
  }
  return buf;
}

std::string Progress::Line(int64_t done) const {
  const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  const double rate = elapsed > 0 ? (done - start_done_) / elapsed : 0.0;
  const double pct = total_ > 0 ? 100.0 * done / total_ : 100.0;
  const double eta = rate > 0 ? (total_ - done) / rate : NAN;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s: %lld/%lld (%.1f%%)  %.1f /s  ETA %s", what_.c_str(),
                static_cast<long long>(done), static_cast<long long>(total_), pct, rate,
                FormatSeconds(eta).c_str());
  return buf;
}

void Progress::Update(int64_t done) {
  done_ = done;
  if (!enabled_) return;
  const auto now = Clock::now();
  if (std::chrono::duration<double>(now - last_print_).count() >= interval_) {
    last_print_ = now;
    FC_INFO("{}", Line(done));
  }
}

void Progress::Finish() {
  if (finished_) return;
  finished_ = true;
  if (!enabled_) return;
  const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  const double rate = elapsed > 0 ? (done_ - start_done_) / elapsed : 0.0;
  FC_INFO("{}: {}/{} done in {} ({:.1f} /s)", what_, done_, total_, FormatSeconds(elapsed), rate);
}

}  // namespace facecap
