#include "nn/deepfake_io.h"

#include <vector>

#include "util/errors.h"

namespace facecap::nn {

namespace {

const char kWeights[] = "/weights";
const char kTraining[] = "/training";
const char kAveraged[] = "/averaged_weights";

void WriteSlots(io::H5File* file, const std::string& group, const DeepfakeModel& model,
                const float* buffer) {
  for (const TensorSlot& s : model.ParameterLayout()) {
    file->Write<float>(group + "/" + s.name, s.shape, buffer + s.offset);
  }
}

// Reads every tensor of the layout from `group` into `buffer`; collects every problem first.
void ReadSlots(const io::H5File& file, const std::string& group, const DeepfakeModel& model,
               float* buffer) {
  std::string problems;
  int num_problems = 0;
  auto problem = [&](const std::string& text) {
    if (num_problems++ < 12) problems += "\n  " + text;
  };
  for (const TensorSlot& s : model.ParameterLayout()) {
    const std::string name = group + "/" + s.name;
    if (!file.Exists(name)) {
      problem(name + " is missing");
      continue;
    }
    const io::Shape shape = file.DatasetShape(name);
    if (shape != s.shape) {
      problem(name + " has shape " + io::ShapeToString(shape) + ", the network expects " +
              io::ShapeToString(s.shape));
    }
  }
  if (num_problems > 0) {
    if (num_problems > 12) problems += "\n  ... and " + std::to_string(num_problems - 12) + " more";
    throw FileIOError(file.path() + ": " + std::to_string(num_problems) + " tensor(s) of " + group +
                      " do not fit the network:" + problems);
  }
  for (const TensorSlot& s : model.ParameterLayout()) {
    const std::vector<float> v = file.Read<float>(group + "/" + s.name, s.shape);
    std::copy(v.begin(), v.end(), buffer + s.offset);
  }
}

}  // namespace

void WriteNetworkOptions(io::H5File* file, const DeepfakeNetworkOptions& options) {
  file->CreateGroups(std::string(kWeights) + "/x");
  DeepfakeNetworkOptions o = options;
  o.Visit([&](const char* key, int& value, const char*) {
    file->SetAttribute(kWeights, key, static_cast<int64_t>(value));
  });
}

DeepfakeNetworkOptions ReadNetworkOptions(const io::H5File& file) {
  DeepfakeNetworkOptions o;
  if (!file.Exists(kWeights)) {
    throw FileIOError(file.path() + ": no /weights group; is this a deepfake model file?");
  }
  o.Visit([&](const char* key, int& value, const char*) {
    const std::string name = key;
    if (!file.HasAttribute(kWeights, key) &&
        (name == "skips" || name == "decoder_b_width" || name == "palette_colors" ||
         name == "input_skip_width")) {
      value = 0;  // files written before these options existed: their behaviour then
      return;
    }
    if (!file.HasAttribute(kWeights, key)) {
      throw FileIOError(file.path() + ": /weights lacks the attribute '" + key +
                        "' of the network architecture");
    }
    value = static_cast<int>(file.GetIntAttribute(kWeights, key));
  });
  std::string why;
  if (!o.Check(&why)) throw FileIOError(file.path() + ": /weights describes no valid network: " + why);
  return o;
}

void WriteWeights(io::H5File* file, DeepfakeModel* model) {
  model->ParametersToHost();
  WriteNetworkOptions(file, model->options());
  WriteSlots(file, kWeights, *model, model->parameters());
  file->SetAttribute(kWeights, "tensor_count", static_cast<int64_t>(model->ParameterLayout().size()));
  file->SetAttribute(kWeights, "parameter_count", model->num_parameters());
}

void ReadWeights(const io::H5File& file, DeepfakeModel* model) {
  if (file.HasAttribute(kWeights, "parameter_count") &&
      file.GetIntAttribute(kWeights, "parameter_count") != model->num_parameters()) {
    // Still read on to name the tensors that differ; this only adds the totals.
    try {
      ReadSlots(file, kWeights, *model, model->parameters());
    } catch (const FileIOError& e) {
      throw FileIOError(std::string(e.what()) + "\n  (the file holds " +
                        std::to_string(file.GetIntAttribute(kWeights, "parameter_count")) +
                        " parameters, the network has " + std::to_string(model->num_parameters()) + ")");
    }
    throw FileIOError(file.path() + ": /weights holds " +
                      std::to_string(file.GetIntAttribute(kWeights, "parameter_count")) +
                      " parameters, the network has " + std::to_string(model->num_parameters()));
  }
  ReadSlots(file, kWeights, *model, model->parameters());
  model->ParametersWritten();
}

void WriteAveragedWeights(io::H5File* file, const DeepfakeModel& model, const float* averaged,
                          double decay) {
  WriteSlots(file, kAveraged, model, averaged);
  file->SetAttribute(kAveraged, "decay", decay);
  file->SetAttribute(kAveraged, "meaning",
                     std::string("exponential moving average of /weights over the training steps"));
}

bool ReadAveragedWeights(const io::H5File& file, const DeepfakeModel& model, float* averaged) {
  if (!file.Exists(kAveraged)) return false;
  ReadSlots(file, kAveraged, model, averaged);
  return true;
}

void WriteTrainingState(io::H5File* file, DeepfakeTrainer* trainer, const TrainingState& state) {
  trainer->OptimizerStateToHost();
  WriteSlots(file, "/optimizer/first_moment", trainer->model(), trainer->first_moments());
  WriteSlots(file, "/optimizer/second_moment", trainer->model(), trainer->second_moments());
  file->CreateGroups(std::string(kTraining) + "/x");
  file->SetAttribute(kTraining, "step", state.step);
  file->SetAttribute(kTraining, "rng_seed", static_cast<int64_t>(state.rng_seed));
  file->SetAttribute(kTraining, "rng_streams",
                     std::string("batches of step s on rank r draw from Rng(rng_seed, s * 65536 + r)"));
}

TrainingState ReadTrainingState(const io::H5File& file, DeepfakeTrainer* trainer) {
  if (!file.Exists(kTraining) || !file.HasAttribute(kTraining, "step")) {
    throw FileIOError(file.path() + ": no /training state; not a deepfake checkpoint");
  }
  ReadSlots(file, "/optimizer/first_moment", trainer->model(), trainer->first_moments());
  ReadSlots(file, "/optimizer/second_moment", trainer->model(), trainer->second_moments());
  trainer->OptimizerStateWritten();
  TrainingState state;
  state.step = file.GetIntAttribute(kTraining, "step");
  state.rng_seed = static_cast<uint64_t>(file.GetIntAttribute(kTraining, "rng_seed"));
  trainer->set_step(state.step);
  return state;
}

}  // namespace facecap::nn
