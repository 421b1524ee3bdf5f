// Opening the output of a resumable stage (rank 0).
//
// - The final file exists and was made with the same configuration: it is up to date, nothing
//   to do.
// - A `.partial` file exists and was made with the same configuration: continue it.
// - A `.partial` made with another configuration: InvalidInputError that says so (delete it or
//   rerun with the same options), never a silent mix of two configurations.
// - Otherwise: a new `.partial` file.
// The configuration hash is kept in the root attribute `config_hash`.
#ifndef FACECAP_STAGES_RESUMABLE_H_
#define FACECAP_STAGES_RESUMABLE_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "io/hdf5.h"
#include "stages/frame_loop.h"
#include "stages/stage.h"

namespace facecap::stages {

struct ResumableOutput {
  io::H5File file;          // open .partial file (not open when up_to_date)
  bool up_to_date = false;  // the final file already holds this configuration's result
  bool resumed = false;     // continuing a .partial file
};

ResumableOutput OpenResumableOutput(const std::string& path, const std::string& config_text,
                                    const io::Provenance& provenance);

// The output of a resumable per-frame stage (frame_loop.h), as every rank learns it.
struct FrameOutput {
  ResumableOutput output;        // rank 0: the open file
  bool up_to_date = false;       // every rank: the final file holds this configuration's result
  std::vector<int64_t> pending;  // rank 0: the frames not done yet, ascending
};

// Collective. Rank 0 opens (or continues) `out`, the output of `stage` over `num_frames`
// work items (`units`: what the log calls them); for a new or continued file,
// `prepare(file, resumed)` creates its datasets (and, when not resumed, what is written once),
// and the done mask `mask` lists the pending items. Logs that a run continues or that the
// output is up to date.
FrameOutput OpenFrameOutput(const StageContext& ctx, const io::Config& resolved,
                            const std::string& stage, const std::string& out, int64_t num_frames,
                            const std::function<void(io::H5File* file, bool resumed)>& prepare,
                            const std::string& units = "frames",
                            const std::string& mask = "/progress/done");

// The end of a resumable per-frame stage (collective): RunFrameLoop over `pending`, then rank
// 0 commits `output` (renames NAME.partial to NAME). Returns RunFrameLoop's count.
int64_t RunFrameLoopAndCommit(const dist::Comm& comm, std::vector<int64_t> pending, int64_t total,
                              const FrameLoopOptions& options, const FrameCompute& compute,
                              const FrameCommit& commit, ResumableOutput* output);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RESUMABLE_H_
