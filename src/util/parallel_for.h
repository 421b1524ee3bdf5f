// ParallelFor over [begin, end) with OpenMP threads; inline on one thread (as Ceres's
// ParallelFor). Exceptions thrown by fn on any thread are rethrown on the caller's thread.
#ifndef FACECAP_UTIL_PARALLEL_FOR_H_
#define FACECAP_UTIL_PARALLEL_FOR_H_

#include <exception>
#include <functional>
#include <mutex>

namespace facecap {

// The thread count used when a caller passes num_threads <= 0 (OMP_NUM_THREADS or cores).
int DefaultNumThreads();

template <typename Fn>
void ParallelFor(int begin, int end, int num_threads, Fn&& fn) {
  if (num_threads <= 0) num_threads = DefaultNumThreads();
  if (num_threads == 1 || end - begin <= 1) {
    for (int i = begin; i < end; ++i) fn(i);
    return;
  }
  std::exception_ptr error;
  std::mutex error_mutex;
#pragma omp parallel for num_threads(num_threads) schedule(dynamic, 1)
  for (int i = begin; i < end; ++i) {
    try {
      fn(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace facecap

#endif  // FACECAP_UTIL_PARALLEL_FOR_H_
