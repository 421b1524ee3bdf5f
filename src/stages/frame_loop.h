// The per-frame work loop of a resumable, distributed stage.
//
// Rank 0 knows which frames are still pending (the output's DoneMask); they are cut into
// rounds of ranks x batch frames. In each round every rank computes its frames (statically, or
// handed out one by one through a WorkQueue when per-frame costs are uneven), with OpenMP
// threads inside the rank, and returns one byte buffer per frame. Rank 0 gathers the buffers
// and calls `commit` with the round's frames in ascending order: the stage writes them and
// marks them done. After each round, a SIGTERM/SIGUSR1 on any rank stops every rank with
// InterruptedError (exit code 75): what was committed stays, and a rerun continues. An
// exception on one rank becomes an exception on every rank.
//
// Each frame's result must depend only on the frame (seed it by its index), so the output is
// the same for any number of ranks and threads.
#ifndef FACECAP_STAGES_FRAME_LOOP_H_
#define FACECAP_STAGES_FRAME_LOOP_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dist/comm.h"

namespace facecap::stages {

struct FrameLoopOptions {
  std::string what = "frames";   // label of the progress lines
  int64_t batch = 16;            // frames per rank per round
  bool dynamic = false;          // hand frames out with the dynamic WorkQueue
  int threads = 0;               // OpenMP threads per rank (0: the default)
  double progress_seconds = 5.0; // interval of the progress lines
};

// compute(frame, thread) runs on any rank, possibly on several threads at once (thread is in
// [0, threads)); commit(frames, results) runs on rank 0 only.
using FrameCompute = std::function<std::vector<uint8_t>(int64_t frame, int thread)>;
using FrameCommit = std::function<void(const std::vector<int64_t>& frames,
                                       const std::vector<std::vector<uint8_t>>& results)>;

// Runs the loop. `pending` is read on rank 0 and broadcast; `total` and `already_done` are
// for the progress lines. Returns the number of frames computed by this run, by all ranks
// together (the same on every rank).
int64_t RunFrameLoop(const dist::Comm& comm, std::vector<int64_t> pending, int64_t total,
                     const FrameLoopOptions& options, const FrameCompute& compute,
                     const FrameCommit& commit);

// Threads a rank should use: OMP_NUM_THREADS when set, else the cores divided among the ranks
// sharing this node.
int ThreadsPerRank(int requested);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_FRAME_LOOP_H_
