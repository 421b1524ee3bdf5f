#include "stages/frame_loop.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>

#include "util/errors.h"
#include "util/parallel_for.h"
#include "util/progress.h"
#include "util/signals.h"

namespace facecap::stages {

int ThreadsPerRank(int requested) {
  if (requested > 0) return requested;
  if (std::getenv("OMP_NUM_THREADS")) return std::max(1, omp_get_max_threads());
  if (const char* cpus = std::getenv("SLURM_CPUS_PER_TASK")) return std::max(1, std::atoi(cpus));
  int local_ranks = 1;
  for (const char* var : {"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_NTASKS_PER_NODE"}) {
    if (const char* v = std::getenv(var)) {
      local_ranks = std::max(1, std::atoi(v));
      break;
    }
  }
  return std::max(1, omp_get_num_procs() / local_ranks);
}

int64_t RunFrameLoop(const dist::Comm& comm, std::vector<int64_t> pending, int64_t total,
                     const FrameLoopOptions& options, const FrameCompute& compute,
                     const FrameCommit& commit) {
  comm.Broadcast(&pending);
  const int threads = ThreadsPerRank(options.threads);
  const int64_t per_round = std::max<int64_t>(1, options.batch) * comm.size();
  const int64_t num_pending = static_cast<int64_t>(pending.size());
  Progress progress(options.what, total, total - num_pending, options.progress_seconds,
                    comm.IsMainRank());
  for (int64_t round_begin = 0; round_begin < num_pending; round_begin += per_round) {
    const int64_t round_size = std::min(per_round, num_pending - round_begin);
    // This rank's positions within the round, and their results.
    std::vector<int64_t> mine;
    std::vector<std::vector<uint8_t>> results;
    auto compute_from = [&](size_t first) {  // computes mine[first, end) on the rank's threads
      results.resize(mine.size());
      ParallelFor(static_cast<int>(first), static_cast<int>(mine.size()), threads, [&](int k) {
        results[k] = compute(pending[round_begin + mine[k]], omp_get_thread_num() % threads);
      });
    };
    if (options.dynamic && !comm.IsSingle()) {
      // Claim one position per thread from a queue shared by all ranks, compute them, claim
      // again: a rank whose frames are cheap comes back sooner and takes more. Claims are made
      // by the main thread only (MPI_THREAD_FUNNELED).
      dist::WorkQueue queue(comm, round_size, std::max<int64_t>(1, threads));
      dist::CoordinateExceptions(comm, [&] {
        int64_t count = 0;
        for (int64_t first = queue.Next(&count); first >= 0; first = queue.Next(&count)) {
          const size_t begin = mine.size();
          for (int64_t p = first; p < first + count; ++p) mine.push_back(p);
          compute_from(begin);
        }
      });
    } else {
      const dist::Range range = dist::BlockRange(round_size, comm.rank(), comm.size());
      for (int64_t p = range.begin; p < range.end; ++p) mine.push_back(p);
      dist::CoordinateExceptions(comm, [&] { compute_from(0); });
    }
    // Serialize this rank's frames as (position, bytes) pairs.
    std::vector<uint8_t> packed;
    for (size_t k = 0; k < mine.size(); ++k) {
      const int64_t position = mine[k];
      const uint64_t size = results[k].size();
      const auto* p = reinterpret_cast<const uint8_t*>(&position);
      packed.insert(packed.end(), p, p + sizeof(position));
      const auto* s = reinterpret_cast<const uint8_t*>(&size);
      packed.insert(packed.end(), s, s + sizeof(size));
      packed.insert(packed.end(), results[k].begin(), results[k].end());
    }
    results.clear();
    auto gathered = comm.Gather(packed);
    dist::CoordinateExceptions(comm, [&] {
      if (!comm.IsMainRank()) return;
      std::vector<std::vector<uint8_t>> ordered(round_size);
      std::vector<bool> seen(round_size, false);
      for (const auto& part : gathered) {
        size_t offset = 0;
        while (offset < part.size()) {
          int64_t position;
          uint64_t size;
          std::memcpy(&position, part.data() + offset, sizeof(position));
          std::memcpy(&size, part.data() + offset + sizeof(position), sizeof(size));
          offset += sizeof(position) + sizeof(size);
          if (position < 0 || position >= round_size || seen[position]) {
            throw ParallelConsistencyError("frame loop: a frame was computed twice or is unknown");
          }
          seen[position] = true;
          ordered[position].assign(part.begin() + offset, part.begin() + offset + size);
          offset += size;
        }
      }
      if (std::find(seen.begin(), seen.end(), false) != seen.end()) {
        throw ParallelConsistencyError("frame loop: a frame of the round was not computed");
      }
      std::vector<int64_t> frames(pending.begin() + round_begin,
                                  pending.begin() + round_begin + round_size);
      commit(frames, ordered);
      progress.Update(total - num_pending + round_begin + round_size);
    });
    MaybeInjectFault("FACECAP_FAULT_AFTER_FRAMES", comm.rank(), total - num_pending + round_begin + round_size);
    if (comm.AnyTrue(StopRequested()) && round_begin + round_size < num_pending) {
      throw InterruptedError(options.what + ": stopped by signal after " +
                             std::to_string(total - num_pending + round_begin + round_size) +
                             " of " + std::to_string(total) +
                             " frames; the output keeps them, rerun the same command to continue");
    }
  }
  progress.Finish();
  return num_pending;
}

}  // namespace facecap::stages
