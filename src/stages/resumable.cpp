#include "stages/resumable.h"

#include <filesystem>

#include "dist/comm.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {

ResumableOutput OpenResumableOutput(const std::string& path, const std::string& config_text,
                                    const io::Provenance& provenance) {
  ResumableOutput out;
  const std::string hash = io::ConfigHash(config_text);
  if (io::H5File::IsHdf5(path)) {
    try {
      io::H5File existing = io::H5File::OpenRead(path);
      if (existing.HasAttribute("/", "config_hash") &&
          existing.GetStringAttribute("/", "config_hash") == hash) {
        out.up_to_date = true;
        return out;
      }
    } catch (const FileIOError&) {
      // Unreadable: recompute it.
    }
  }
  const std::string partial = io::H5File::PartialPath(path);
  if (io::H5File::IsHdf5(partial)) {
    bool resumed = false;
    io::H5File file = io::H5File::OpenOrCreatePartial(path, &resumed);
    if (resumed) {
      const std::string old = file.HasAttribute("/", "config_hash")
                                  ? file.GetStringAttribute("/", "config_hash")
                                  : std::string();
      if (old != hash) {
        throw InvalidInputError(partial + " holds an interrupted run with other options; rerun "
                                "with the same options to continue it, or delete it to start over");
      }
      out.file = std::move(file);
      out.resumed = true;
      return out;
    }
  }
  out.file = io::H5File::CreateAtomic(path);
  out.file.WriteProvenance(provenance);
  out.file.SetAttribute("/", "config_hash", hash);
  return out;
}

FrameOutput OpenFrameOutput(const StageContext& ctx, const io::Config& resolved,
                            const std::string& stage, const std::string& out, int64_t num_frames,
                            const std::function<void(io::H5File* file, bool resumed)>& prepare,
                            const std::string& units, const std::string& mask) {
  FrameOutput result;
  int32_t up_to_date = 0;
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    result.output = OpenResumableOutput(out, resolved.ToToml(), MakeProvenance(ctx, stage, resolved));
    if (result.output.up_to_date) {
      up_to_date = 1;
      return;
    }
    prepare(&result.output.file, result.output.resumed);
    io::DoneMask done(&result.output.file, num_frames, mask);
    result.pending = done.Pending();
    if (result.output.resumed) {
      FC_INFO("{}: continuing {}: {} of {} {} already done", stage, io::H5File::PartialPath(out),
              done.NumDone(), num_frames, units);
    }
  });
  ctx.comm.Broadcast(&up_to_date, sizeof(up_to_date));
  result.up_to_date = up_to_date != 0;
  if (result.up_to_date && ctx.comm.IsMainRank()) FC_INFO("{}: {} is up to date", stage, out);
  return result;
}

int64_t RunFrameLoopAndCommit(const dist::Comm& comm, std::vector<int64_t> pending, int64_t total,
                              const FrameLoopOptions& options, const FrameCompute& compute,
                              const FrameCommit& commit, ResumableOutput* output) {
  const int64_t computed = RunFrameLoop(comm, std::move(pending), total, options, compute, commit);
  dist::CoordinateExceptions(comm, [&] {
    if (comm.IsMainRank()) output->file.Commit();
  });
  return computed;
}

}  // namespace facecap::stages
