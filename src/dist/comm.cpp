#include "dist/comm.h"

#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <cstring>

#include "util/errors.h"

namespace facecap::dist {
namespace {

bool g_initialised_here = false;

MPI_Comm ToMpi(int handle) { return MPI_Comm_f2c(handle); }

void Check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) {
    char msg[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(rc, msg, &len);
    throw ParallelConsistencyError(std::string("MPI error in ") + what + ": " +
                                   std::string(msg, len));
  }
}

constexpr int64_t kMaxChunk = INT_MAX / 2;

template <typename T>
void SumReduceChunked(int handle, T* data, int64_t count, int64_t max_chunk,
                      MPI_Datatype type) {
  if (max_chunk < 1 || max_chunk > INT_MAX) {
    throw Error("SumReduce: chunk of " + std::to_string(max_chunk) +
                " elements, expected 1 to INT_MAX");
  }
  if (handle < 0) return;
  for (int64_t offset = 0; offset < count; offset += max_chunk) {
    const int n = static_cast<int>(std::min(max_chunk, count - offset));
    Check(MPI_Allreduce(MPI_IN_PLACE, data + offset, n, type, MPI_SUM, ToMpi(handle)),
          "SumReduce");
  }
}

}  // namespace

bool Comm::LaunchedByMpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"}) {
    if (std::getenv(var)) return true;
  }
  // srun without --mpi still sets SLURM_PROCID; only count it when several tasks run.
  const char* ntasks = std::getenv("SLURM_STEP_NUM_TASKS");
  return ntasks && std::atoi(ntasks) > 1 && std::getenv("SLURM_PROCID");
}

void Comm::Init(int* argc, char*** argv) {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (initialised || !LaunchedByMpi()) return;
  int provided = 0;
  Check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  g_initialised_here = true;
}

void Comm::AbortWorld(int code) {
  int size = 1;
  if (MpiActive()) MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1) MPI_Abort(MPI_COMM_WORLD, code);
}

void Comm::Finalize() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (g_initialised_here && !finalized) MPI_Finalize();
}

bool Comm::MpiActive() {
  int initialised = 0, finalized = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalized);
  return initialised && !finalized;
}

Comm Comm::World() {
  if (!MpiActive()) return Single();
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return Comm(MPI_Comm_c2f(MPI_COMM_WORLD), rank, size);
}

Comm Comm::Single() { return Comm(-1, 0, 1); }

std::string Comm::LibraryVersion() {
  char version[MPI_MAX_LIBRARY_VERSION_STRING];
  int len = 0;
  MPI_Get_library_version(version, &len);
  std::string v(version, len);
  const size_t comma = v.find(',');
  return comma == std::string::npos ? v : v.substr(0, comma);
}

void Comm::Barrier() const {
  if (handle_ >= 0) Check(MPI_Barrier(ToMpi(handle_)), "Barrier");
}

void Comm::SumReduce(float* data, int64_t count, int64_t max_chunk) const {
  SumReduceChunked(handle_, data, count, max_chunk, MPI_FLOAT);
}
void Comm::SumReduce(double* data, int64_t count, int64_t max_chunk) const {
  SumReduceChunked(handle_, data, count, max_chunk, MPI_DOUBLE);
}
void Comm::SumReduce(int64_t* data, int64_t count, int64_t max_chunk) const {
  SumReduceChunked(handle_, data, count, max_chunk, MPI_INT64_T);
}

double Comm::Max(double value) const {
  if (handle_ >= 0) {
    Check(MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, ToMpi(handle_)), "Max");
  }
  return value;
}

double Comm::Min(double value) const {
  if (handle_ >= 0) {
    Check(MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MIN, ToMpi(handle_)), "Min");
  }
  return value;
}

bool Comm::AnyTrue(bool value) const { return Max(value ? 1.0 : 0.0) > 0.5; }

void Comm::Broadcast(void* data, int64_t bytes, int root) const {
  if (handle_ < 0) return;
  char* p = static_cast<char*>(data);
  for (int64_t offset = 0; offset < bytes; offset += kMaxChunk) {
    const int n = static_cast<int>(std::min(kMaxChunk, bytes - offset));
    Check(MPI_Bcast(p + offset, n, MPI_BYTE, root, ToMpi(handle_)), "Broadcast");
  }
}

void Comm::Broadcast(std::string* value, int root) const {
  if (handle_ < 0) return;
  std::vector<char> bytes(value->begin(), value->end());
  Broadcast(&bytes, root);
  value->assign(bytes.begin(), bytes.end());
}

std::vector<std::vector<uint8_t>> Comm::Gather(const std::vector<uint8_t>& mine, int root) const {
  std::vector<std::vector<uint8_t>> out;
  if (handle_ < 0) {
    out.push_back(mine);
    return out;
  }
  int64_t n = static_cast<int64_t>(mine.size());
  if (n > INT_MAX) throw ParallelConsistencyError("Gather: buffer above 2 GiB on one rank");
  int count = static_cast<int>(n);
  std::vector<int> counts(size_), displs(size_);
  Check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, root, ToMpi(handle_)),
        "Gather");
  std::vector<uint8_t> all;
  if (rank_ == root) {
    int64_t total = 0;
    for (int r = 0; r < size_; ++r) {
      displs[r] = static_cast<int>(total);
      total += counts[r];
    }
    if (total > INT_MAX) throw ParallelConsistencyError("Gather: above 2 GiB in total");
    all.resize(total);
  }
  Check(MPI_Gatherv(mine.data(), count, MPI_BYTE, all.data(), counts.data(), displs.data(),
                    MPI_BYTE, root, ToMpi(handle_)),
        "Gatherv");
  if (rank_ == root) {
    for (int r = 0; r < size_; ++r) {
      out.emplace_back(all.begin() + displs[r], all.begin() + displs[r] + counts[r]);
    }
  }
  return out;
}

std::vector<std::vector<uint8_t>> Comm::AllGather(const std::vector<uint8_t>& mine) const {
  std::vector<std::vector<uint8_t>> parts = Gather(mine, 0);
  std::vector<uint8_t> flat;
  std::vector<int64_t> sizes(size_, 0);
  if (rank_ == 0) {
    for (int r = 0; r < size_; ++r) {
      sizes[r] = static_cast<int64_t>(parts[r].size());
      flat.insert(flat.end(), parts[r].begin(), parts[r].end());
    }
  }
  Broadcast(sizes.data(), static_cast<int64_t>(sizes.size() * sizeof(int64_t)));
  Broadcast(&flat);
  parts.clear();
  int64_t offset = 0;
  for (int r = 0; r < size_; ++r) {
    parts.emplace_back(flat.begin() + offset, flat.begin() + offset + sizes[r]);
    offset += sizes[r];
  }
  return parts;
}

namespace {
bool g_exception_coordinated = false;
}  // namespace

bool ExceptionIsCoordinated() { return g_exception_coordinated; }

void CoordinateExceptions(const Comm& comm, const std::function<void()>& fn) {
  g_exception_coordinated = false;
  std::exception_ptr error;
  std::string message;
  try {
    fn();
  } catch (const std::exception& e) {
    error = std::current_exception();
    message = e.what();
  } catch (...) {
    error = std::current_exception();
    message = "unknown exception";
  }
  if (comm.IsSingle()) {
    if (error) std::rethrow_exception(error);
    return;
  }
  // The lowest failing rank's message reaches every rank.
  const double failing = comm.Min(error ? comm.rank() : static_cast<double>(comm.size()));
  if (failing >= comm.size()) return;
  const int root = static_cast<int>(failing);
  comm.Broadcast(&message, root);
  g_exception_coordinated = true;
  if (error) std::rethrow_exception(error);
  throw ParallelConsistencyError("rank " + std::to_string(root) + " failed: " + message);
}

Range BlockRange(int64_t num_items, int rank, int size) {
  const int64_t base = num_items / size, extra = num_items % size;
  Range r;
  r.begin = rank * base + std::min<int64_t>(rank, extra);
  r.end = r.begin + base + (rank < extra ? 1 : 0);
  return r;
}

struct WorkQueue::Window {
  MPI_Win win = MPI_WIN_NULL;
  int64_t* counter = nullptr;
};

WorkQueue::WorkQueue(const Comm& comm, int64_t num_items, int64_t batch)
    : comm_(comm), num_items_(num_items), batch_(std::max<int64_t>(1, batch)) {
  if (comm_.IsSingle()) return;
  window_ = new Window;
  const MPI_Aint bytes = comm_.IsMainRank() ? sizeof(int64_t) : 0;
  Check(MPI_Win_allocate(bytes, sizeof(int64_t), MPI_INFO_NULL, ToMpi(comm_.handle()),
                         &window_->counter, &window_->win),
        "MPI_Win_allocate");
  if (comm_.IsMainRank()) *window_->counter = 0;
  comm_.Barrier();
  Check(MPI_Win_lock_all(0, window_->win), "MPI_Win_lock_all");
}

WorkQueue::~WorkQueue() {
  if (!window_) return;
  MPI_Win_unlock_all(window_->win);
  MPI_Win_free(&window_->win);
  delete window_;
}

int64_t WorkQueue::Next(int64_t* count) {
  int64_t first = 0;
  if (!window_) {
    first = local_next_;
    local_next_ += batch_;
  } else {
    const int64_t increment = batch_;
    Check(MPI_Fetch_and_op(&increment, &first, MPI_INT64_T, 0, 0, MPI_SUM, window_->win),
          "MPI_Fetch_and_op");
    Check(MPI_Win_flush(0, window_->win), "MPI_Win_flush");
  }
  if (first >= num_items_) {
    if (count) *count = 0;
    return -1;
  }
  if (count) *count = std::min(batch_, num_items_ - first);
  return first;
}

}  // namespace facecap::dist
