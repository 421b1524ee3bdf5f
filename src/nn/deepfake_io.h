// Deepfake weights and training state in HDF5, one dataset per tensor named by its module path
// (readable with h5py: f["/weights/encoder/down0/weight"]), never pickles:
//
//   /weights/<module path>                  float32, the parameter's shape
//   /weights                                attributes: the DeepfakeNetworkOptions fields,
//                                           tensor_count, parameter_count
//   /optimizer/first_moment/<module path>   Adam m (checkpoints only)
//   /optimizer/second_moment/<module path>  Adam v
//   /training                               attributes: step, rng_seed, rng_streams
//   /averaged_weights/<module path>         the exponential moving average of the weights
//                                           (runs with average_decay > 0); attribute decay
//
// Reading checks every shape against the network and names every tensor that does not fit.
#ifndef FACECAP_NN_DEEPFAKE_IO_H_
#define FACECAP_NN_DEEPFAKE_IO_H_

#include <cstdint>
#include <string>

#include "io/hdf5.h"
#include "nn/deepfake.h"

namespace facecap::nn {

// The architecture stored with the weights (FileIOError when absent).
void WriteNetworkOptions(io::H5File* file, const DeepfakeNetworkOptions& options);
DeepfakeNetworkOptions ReadNetworkOptions(const io::H5File& file);

void WriteWeights(io::H5File* file, DeepfakeModel* model);
// FileIOError naming the file and every missing or wrongly shaped tensor.
void ReadWeights(const io::H5File& file, DeepfakeModel* model);

// The moving average of the weights, ParameterLayout() of the model, in /averaged_weights.
void WriteAveragedWeights(io::H5File* file, const DeepfakeModel& model, const float* averaged,
                          double decay);
// False when the file has no averaged weights; FileIOError when they do not fit the network.
bool ReadAveragedWeights(const io::H5File& file, const DeepfakeModel& model, float* averaged);

// What a training run needs to continue exactly: Adam moments, the step, and the seed of the
// counter-based sampling (batches are drawn from Rng(rng_seed, step * 65536 + rank), so
// (seed, step) is the whole random state).
struct TrainingState {
  int64_t step = 0;
  uint64_t rng_seed = 0;
};
void WriteTrainingState(io::H5File* file, DeepfakeTrainer* trainer, const TrainingState& state);
TrainingState ReadTrainingState(const io::H5File& file, DeepfakeTrainer* trainer);

}  // namespace facecap::nn

#endif  // FACECAP_NN_DEEPFAKE_IO_H_
