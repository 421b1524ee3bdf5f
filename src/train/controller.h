// The one data-parallel training loop of facecap's networks.
//
// A network supplies its model, its batches and its losses (train::Network); the controller
// does the rest, the same way for every network:
//   - resume: a checkpoint (OUT.checkpoint) or a finished model made from the same data and
//     options (the identity hash) continues; one made from others is refused (exit 3);
//   - rank 0's weights and optimizer state are broadcast to every rank;
//   - each step: every rank's backward pass on its share of the global batch, the gradients
//     summed over the ranks (dist::Comm::SumReduce), the optimizer step, then one reduction of
//     the losses and the stop flag;
//   - progress lines with the losses' means since the last line, steps per second and an ETA;
//   - checkpoints every `checkpoint_every` steps and when a stop is requested (SIGTERM or
//     SIGUSR1: checkpoint, then InterruptedError, exit 75), written atomically, with every
//     rank's parameter hash checked equal first (ParallelConsistencyError otherwise);
//   - fault injection for the restart tests (FACECAP_FAULT_AFTER_STEPS, util/signals.h).
//
// Checkpoint and model files share one layout: the network's own datasets (its weights and
// optimizer state, WriteState) and the controller's attributes on /training:
//   network             the trainer's name ("deepfake train")
//   step                optimizer steps done
//   identity_hash       hash of the data and options that define the result
//   rank_weight_hashes  every rank's parameter hash (hex, comma-separated), all equal
// plus the provenance attributes on the root that every facecap file carries.
#ifndef FACECAP_TRAIN_CONTROLLER_H_
#define FACECAP_TRAIN_CONTROLLER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "dist/comm.h"
#include "io/hdf5.h"

namespace facecap::train {

class Network {
 public:
  virtual ~Network() = default;

  // Number of loss values Backward reports.
  virtual int NumLosses() const = 0;
  // Forward and backward on this rank's share of global step `step` (0-based), leaving the
  // gradients in gradients(); gradients and `losses` (NumLosses() values) are scaled so that
  // their sums over the ranks are the global batch's.
  virtual void Backward(int64_t step, double* losses) = 0;
  virtual float* gradients() = 0;
  virtual int64_t num_gradients() const = 0;
  // The optimizer step of global step `step` on the summed gradients, and what follows it
  // (weight averages).
  virtual void Apply(int64_t step) = 0;
  // A hash of the parameters; equal on every rank while training is consistent.
  virtual uint64_t ParameterHash() = 0;

  // Rank 0: everything a continued run needs (weights, optimizer state, running averages)
  // into `file`, after `steps_done` steps; and back. ReadState throws FileIOError naming the
  // file when it does not fit the network.
  virtual void WriteState(io::H5File* file, int64_t steps_done) = 0;
  virtual void ReadState(const io::H5File& file) = 0;
  // Rank 0's state (initial, or read by ReadState when `resumed`) onto every rank.
  virtual void BroadcastState(const dist::Comm& comm, bool resumed) = 0;
  // Rank 0: the finished model's datasets (default: the state, so that it can be trained
  // further).
  virtual void WriteModel(io::H5File* file, int64_t steps_done) { WriteState(file, steps_done); }

  // The losses of a progress line, given their means over the steps since the last line;
  // `done` is the steps done.
  virtual std::string FormatLosses(int64_t done, const double* means) const = 0;
  // Called on every rank after each step (previews); `done` is the steps done.
  virtual void AfterStep(int64_t done) { (void)done; }
};

struct ControllerOptions {
  std::string name;             // log prefix and /training@network: "deepfake train"
  std::string out;              // model file; OUT.checkpoint while training
  std::string identity;         // hash of the data and options that define the result
  io::Provenance provenance;    // root attributes of the checkpoint and model files
  int64_t steps = 0;            // optimizer steps in all
  int64_t checkpoint_every = 0; // steps between checkpoints (0: on a stop and at the end only)
  double progress_seconds = 10; // seconds between progress lines
  // A finished model of the same identity trained for fewer steps is trained further (its
  // WriteModel must then hold the whole state); otherwise a finished model is up to date.
  bool continue_finished = false;
};

struct TrainResult {
  bool up_to_date = false;   // OUT already held this training; nothing was done
  int64_t start_step = 0;    // the step this run started from
  int64_t steps_run = 0;     // optimizer steps this run made
  double seconds = 0;        // wall time of those steps
  uint64_t hash = 0;         // the final parameter hash, equal on every rank
};

// The items rank `rank` of `ranks` takes of batch `in_epoch` of an epoch: the epoch is a
// permutation of [0, count) drawn from Rng(seed, epoch), the same on every rank, cut into
// batches of `batch` items (the last may be short); each rank takes every ranks-th item of
// the batch, starting at its rank. *batch_size: the batch's size over all ranks.
std::vector<int> RankShareOfBatch(int count, int batch, uint64_t seed, uint64_t epoch, int in_epoch, int rank,
                                  int ranks, int* batch_size);

// OUT.checkpoint.
std::string CheckpointPath(const std::string& out);
std::string HexHash(uint64_t hash);

// Trains `network` to options.steps (collective: every rank calls it). Throws
// InterruptedError after a checkpoint when a stop was requested, InvalidInputError when an
// existing checkpoint or model was made from other data or options.
TrainResult Train(const ControllerOptions& options, const dist::Comm& comm, Network* network);

}  // namespace facecap::train

#endif  // FACECAP_TRAIN_CONTROLLER_H_
