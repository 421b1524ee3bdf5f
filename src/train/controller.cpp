#include "train/controller.h"

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <vector>

#include "util/errors.h"
#include "util/log.h"
#include "util/progress.h"
#include "util/random.h"
#include "util/signals.h"

namespace facecap::train {
namespace {

constexpr char kTraining[] = "/training";

// Where a run starts (rank 0 decides, every rank learns it).
struct Start {
  int64_t step = 0;
  int32_t resumed = 0;     // the state was read from a checkpoint or a finished model
  int32_t up_to_date = 0;  // OUT holds the finished training
};

// Rank 0: the checkpoint, else the finished model, when one exists and was made from the same
// data and options; its state read into the network when training continues from it.
Start OpenExisting(const ControllerOptions& o, Network* network) {
  Start start;
  const std::string checkpoint = CheckpointPath(o.out);
  std::string source;
  if (io::H5File::IsHdf5(checkpoint)) {
    source = checkpoint;
  } else if (io::H5File::IsHdf5(o.out)) {
    source = o.out;
  }
  if (source.empty()) return start;
  const io::H5File f = io::H5File::OpenRead(source);
  const std::string old = f.HasAttribute(kTraining, "identity_hash")
                              ? f.GetStringAttribute(kTraining, "identity_hash")
                              : "";
  if (old != o.identity) {
    throw InvalidInputError(source + " was trained with other data or options; rerun with the "
                            "same options to continue it, or delete it to start over");
  }
  if (!f.HasAttribute(kTraining, "step")) {
    throw FileIOError(source + ": no /training@step; not a checkpoint of " + o.name);
  }
  start.step = f.GetIntAttribute(kTraining, "step");
  if (source == o.out && (!o.continue_finished || start.step >= o.steps)) {
    start.up_to_date = 1;
    return start;
  }
  network->ReadState(f);
  start.resumed = 1;
  FC_INFO("{}: continuing {} at step {}", o.name, source, start.step);
  return start;
}

// Every rank's parameter hash; ParallelConsistencyError on every rank when they differ.
std::vector<uint64_t> CheckSameWeights(const ControllerOptions& o, const dist::Comm& comm,
                                       Network* network, int64_t step) {
  const uint64_t mine = network->ParameterHash();
  std::vector<uint8_t> bytes(sizeof(mine));
  std::memcpy(bytes.data(), &mine, sizeof(mine));
  std::vector<uint64_t> hashes;
  for (const auto& b : comm.AllGather(bytes)) {
    uint64_t h;
    std::memcpy(&h, b.data(), sizeof(h));
    hashes.push_back(h);
  }
  for (size_t r = 1; r < hashes.size(); ++r) {
    if (hashes[r] != hashes[0]) {
      throw ParallelConsistencyError(o.name + ": after step " + std::to_string(step) + " rank " +
                                     std::to_string(r) + " holds other weights (hash " +
                                     HexHash(hashes[r]) + ") than rank 0 (" + HexHash(hashes[0]) +
                                     ")");
    }
  }
  return hashes;
}

// The checkpoint, or with `final` the model file (which replaces the checkpoint), after the
// ranks' weights were found equal. Returns the parameter hash.
uint64_t Save(const ControllerOptions& o, const dist::Comm& comm, Network* network,
              int64_t done, bool final) {
  const std::vector<uint64_t> hashes = CheckSameWeights(o, comm, network, done);
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    io::H5File f = io::H5File::CreateAtomic(final ? o.out : CheckpointPath(o.out));
    f.WriteProvenance(o.provenance);
    if (final) {
      network->WriteModel(&f, done);
    } else {
      network->WriteState(&f, done);
    }
    if (!f.Exists(kTraining)) f.CreateGroups(std::string(kTraining) + "/x");
    std::string joined;
    for (uint64_t h : hashes) joined += (joined.empty() ? "" : ",") + HexHash(h);
    f.SetAttribute(kTraining, "network", o.name);
    f.SetAttribute(kTraining, "step", done);
    f.SetAttribute(kTraining, "identity_hash", o.identity);
    f.SetAttribute(kTraining, "rank_weight_hashes", joined);
    f.Commit();
    if (final) std::filesystem::remove(CheckpointPath(o.out));
    FC_INFO("{}: {} at step {}; weights identical on {} rank(s) (hash {})", o.name,
            final ? "model written" : "checkpoint", done, comm.size(), HexHash(hashes[0]));
  });
  return hashes[0];
}

// Progress lines: the losses' means since the last line, the rate and the ETA (rank 0).
class ProgressLines {
 public:
  ProgressLines(const ControllerOptions& o, const Network& network, int64_t start_step)
      : o_(o), network_(network), start_step_(start_step),
        window_(static_cast<size_t>(network.NumLosses()), 0.0) {}

  void Add(const double* losses, int64_t done, bool stop, bool main_rank) {
    for (size_t k = 0; k < window_.size(); ++k) window_[k] += losses[k];
    ++window_steps_;
    const Clock::time_point now = Clock::now();
    const double since_line = std::chrono::duration<double>(now - last_line_).count();
    if (!main_rank || !(since_line >= o_.progress_seconds || done == o_.steps || stop)) return;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = static_cast<double>(done - start_step_) / std::max(elapsed, 1e-9);
    for (double& w : window_) w /= window_steps_;
    FC_INFO("{}: step {}/{} ({:.1f}%)  {}  {:.2f} steps/s  ETA {}", o_.name, done, o_.steps,
            100.0 * static_cast<double>(done) / static_cast<double>(std::max<int64_t>(o_.steps, 1)),
            network_.FormatLosses(done, window_.data()), rate,
            Progress::FormatSeconds(static_cast<double>(o_.steps - done) / rate));
    std::fill(window_.begin(), window_.end(), 0.0);
    window_steps_ = 0;
    last_line_ = now;
  }
  double Seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  const ControllerOptions& o_;
  const Network& network_;
  const int64_t start_step_;
  std::vector<double> window_;
  int window_steps_ = 0;
  const Clock::time_point start_ = Clock::now();
  Clock::time_point last_line_ = start_;
};

}  // namespace

std::string CheckpointPath(const std::string& out) { return out + ".checkpoint"; }

std::vector<int> RankShareOfBatch(int count, int batch, uint64_t seed, uint64_t epoch, int in_epoch, int rank,
                                  int ranks, int* batch_size) {
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  Rng rng(seed, epoch);
  for (int i = count - 1; i > 0; --i) std::swap(order[i], order[static_cast<int>(rng.UniformInt(i + 1))]);
  const int begin = in_epoch * batch, end = std::min(count, begin + batch);
  std::vector<int> mine;
  for (int b = begin + rank; b < end; b += ranks) mine.push_back(order[b]);
  *batch_size = std::max(0, end - begin);
  return mine;
}

std::string HexHash(uint64_t hash) {
  char text[24];
  std::snprintf(text, sizeof(text), "%016" PRIx64, hash);
  return text;
}

TrainResult Train(const ControllerOptions& o, const dist::Comm& comm, Network* network) {
  Start start;
  dist::CoordinateExceptions(comm, [&] {
    if (comm.IsMainRank()) start = OpenExisting(o, network);
  });
  comm.Broadcast(&start, sizeof(start));
  TrainResult result;
  result.start_step = start.step;
  if (start.up_to_date) {
    if (comm.IsMainRank()) FC_INFO("{}: {} is up to date ({} steps)", o.name, o.out, start.step);
    result.up_to_date = true;
    return result;
  }
  network->BroadcastState(comm, start.resumed != 0);

  const int num_losses = network->NumLosses();
  std::vector<double> reduced(static_cast<size_t>(num_losses) + 1);
  ProgressLines progress(o, *network, start.step);
  for (int64_t step = start.step; step < o.steps; ++step) {
    network->Backward(step, reduced.data());
    comm.SumReduce(network->gradients(), network->num_gradients());
    network->Apply(step);
    const int64_t done = step + 1;
    MaybeInjectFault("FACECAP_FAULT_AFTER_STEPS", comm.rank(), done);
    // The losses of the global batch and whether any rank was asked to stop, in one reduction.
    reduced[num_losses] = StopRequested() ? 1.0 : 0.0;
    comm.SumReduce(reduced.data(), num_losses + 1);
    const bool stop = reduced[num_losses] > 0;
    progress.Add(reduced.data(), done, stop, comm.IsMainRank());
    network->AfterStep(done);
    if (stop) {
      Save(o, comm, network, done, false);
      throw InterruptedError(o.name + ": stopped by signal " + std::to_string(StopSignal()) +
                             " at step " + std::to_string(done) + "; " + CheckpointPath(o.out) +
                             " holds the checkpoint, rerun the same command to continue");
    }
    if (o.checkpoint_every > 0 && done % o.checkpoint_every == 0 && done < o.steps) {
      Save(o, comm, network, done, false);
    }
  }
  result.steps_run = std::max<int64_t>(o.steps - start.step, 0);
  result.seconds = progress.Seconds();
  result.hash = Save(o, comm, network, std::max(o.steps, start.step), true);
  return result;
}

}  // namespace facecap::train
