// The MPI layer: the only code in facecap that includes <mpi.h> (in dist/*.cpp).
//
// Comm wraps a communicator with a single-rank mode, so every algorithm and test runs the same
// with or without mpirun. MPI is initialised only when the process was started by a launcher
// (mpirun, srun); a plain `facecap ...` runs in single-rank mode.
#ifndef FACECAP_DIST_COMM_H_
#define FACECAP_DIST_COMM_H_

#include <climits>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace facecap::dist {

class Comm {
 public:
  // Initialises MPI (MPI_THREAD_FUNNELED) when launched by mpirun/srun; idempotent.
  static void Init(int* argc, char*** argv);
  static void Finalize();
  // Ends every rank of the world with exit code `code` (MPI_Abort) when several run: for an
  // error that only this rank saw, so that no other rank waits for it in a collective.
  static void AbortWorld(int code);
  static bool MpiActive();
  // True when environment variables of mpirun or srun say this process is one of several.
  static bool LaunchedByMpi();
  // The world communicator, or a single-rank communicator when MPI is not active.
  static Comm World();
  static Comm Single();
  // The MPI library's version string ("Open MPI v4.1.4, ...") or "none".
  static std::string LibraryVersion();

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool IsMainRank() const { return rank_ == 0; }
  bool IsSingle() const { return handle_ < 0; }

  // The most elements one MPI call of SumReduce passes: MPI counts are int, so larger
  // buffers (gradients of big networks) go in several calls.
  static constexpr int64_t kMaxReduceChunk = INT_MAX / 2;

  void Barrier() const;
  // In-place sum over ranks (allreduce) of data[0, count), in calls of at most `max_chunk`
  // elements (in [1, INT_MAX]; tests pass a small one to exercise the split).
  void SumReduce(float* data, int64_t count, int64_t max_chunk = kMaxReduceChunk) const;
  void SumReduce(double* data, int64_t count, int64_t max_chunk = kMaxReduceChunk) const;
  void SumReduce(int64_t* data, int64_t count, int64_t max_chunk = kMaxReduceChunk) const;
  double Max(double value) const;
  double Min(double value) const;
  bool AnyTrue(bool value) const;
  // Broadcast `bytes` bytes from root, chunked.
  void Broadcast(void* data, int64_t bytes, int root = 0) const;
  void Broadcast(std::string* value, int root = 0) const;
  template <typename T>
  void Broadcast(std::vector<T>* values, int root = 0) const {
    int64_t n = static_cast<int64_t>(values->size());
    Broadcast(&n, sizeof(n), root);
    values->resize(n);
    Broadcast(values->data(), n * static_cast<int64_t>(sizeof(T)), root);
  }
  // Gathers each rank's byte buffer on root (empty vector on other ranks), in rank order.
  std::vector<std::vector<uint8_t>> Gather(const std::vector<uint8_t>& mine, int root = 0) const;
  // Sends each rank's byte buffer to every rank, in rank order.
  std::vector<std::vector<uint8_t>> AllGather(const std::vector<uint8_t>& mine) const;
  // The underlying MPI handle as a Fortran integer (-1 in single-rank mode).
  int handle() const { return handle_; }

 private:
  Comm(int handle, int rank, int size) : handle_(handle), rank_(rank), size_(size) {}
  int handle_ = -1;
  int rank_ = 0;
  int size_ = 1;
};

// Runs fn on every rank; if it throws on any rank, every rank throws: the failing rank its own
// exception, the others a ParallelConsistencyError that names the failing rank and its message.
// fn must not enter a collective that a failing rank would skip.
void CoordinateExceptions(const Comm& comm, const std::function<void()>& fn);
// True when the exception in flight was thrown on every rank by CoordinateExceptions (every
// rank is on its way out, so they can finalize together instead of aborting).
bool ExceptionIsCoordinated();

// Contiguous block of `num_items` for this rank: [begin, end).
struct Range {
  int64_t begin = 0;
  int64_t end = 0;
};
Range BlockRange(int64_t num_items, int rank, int size);

// A dynamic work queue over items [0, num_items): each Next() hands out the next unclaimed item
// to whichever rank asks (an atomic fetch-and-add on rank 0 through MPI one-sided
// communication), so ranks with cheap items take more. Returns -1 when all are claimed.
// Collective constructor and destructor.
class WorkQueue {
 public:
  WorkQueue(const Comm& comm, int64_t num_items, int64_t batch = 1);
  ~WorkQueue();
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;
  // Claims the next batch; returns its first item (-1 when none is left) and sets *count.
  int64_t Next(int64_t* count = nullptr);

 private:
  const Comm& comm_;
  int64_t num_items_;
  int64_t batch_;
  int64_t local_next_ = 0;  // single-rank mode
  struct Window;
  Window* window_ = nullptr;
};

}  // namespace facecap::dist

#endif  // FACECAP_DIST_COMM_H_
