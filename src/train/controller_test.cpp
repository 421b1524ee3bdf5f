// The training controller on a small least-squares network, in one process: training lowers
// the loss, a stopped run and a finished model trained further continue to the bitwise result
// of a straight run, a finished model is up to date, and a checkpoint of other options is
// refused. (Two and three ranks: the deepfake and blendshape trainers' tests.)
#include "train/controller.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/testing.h"
#include "util/errors.h"
#include "util/signals.h"

namespace facecap::train {
namespace {

// w minimizing the mean of (x_i . w - y_i)^2 over 16 fixed rows, by gradient descent with
// momentum; the momentum is the optimizer state a checkpoint must carry.
class LeastSquares : public Network {
 public:
  static constexpr int kRows = 16, kCols = 3;
  explicit LeastSquares(int stop_after = -1) : stop_after_(stop_after) {
    for (int i = 0; i < kRows; ++i) {
      double y = 0;
      for (int j = 0; j < kCols; ++j) {
        x_[i][j] = std::sin(1.0 + i * 0.7 + j * 1.3);
        y += (j + 1.0) * x_[i][j];
      }
      y_[i] = y;
    }
  }
  int NumLosses() const override { return 1; }
  void Backward(int64_t, double* losses) override {
    std::fill(gradient_.begin(), gradient_.end(), 0.f);
    double loss = 0;
    for (int i = 0; i < kRows; ++i) {
      double r = -y_[i];
      for (int j = 0; j < kCols; ++j) r += x_[i][j] * w_[j];
      loss += r * r / kRows;
      for (int j = 0; j < kCols; ++j) gradient_[j] += static_cast<float>(2 * r * x_[i][j] / kRows);
    }
    losses[0] = loss;
  }
  float* gradients() override { return gradient_.data(); }
  int64_t num_gradients() const override { return kCols; }
  // A stop requested during step `stop_after_` (as a signal would be).
  void Apply(int64_t step) override {
    if (step + 1 == stop_after_) RequestStop(15);
    for (int j = 0; j < kCols; ++j) {
      momentum_[j] = 0.5f * momentum_[j] + gradient_[j];
      w_[j] -= 0.1f * momentum_[j];
    }
  }
  uint64_t ParameterHash() override {
    uint64_t h = 1469598103934665603ull;
    for (float v : w_) {
      uint32_t bits;
      std::memcpy(&bits, &v, sizeof(bits));
      h = (h ^ bits) * 1099511628211ull;
    }
    return h;
  }
  void WriteState(io::H5File* file, int64_t) override {
    file->WriteVector<float>("/weights/w", w_);
    file->WriteVector<float>("/optimizer/momentum", momentum_);
  }
  void ReadState(const io::H5File& file) override {
    w_ = file.ReadVector<float>("/weights/w", kCols);
    momentum_ = file.ReadVector<float>("/optimizer/momentum", kCols);
  }
  void BroadcastState(const dist::Comm& comm, bool) override {
    comm.Broadcast(&w_);
    comm.Broadcast(&momentum_);
  }
  std::string FormatLosses(int64_t, const double* means) const override {
    return "mse " + std::to_string(means[0]);
  }
  const std::vector<float>& w() const { return w_; }

 private:
  double x_[kRows][kCols];
  double y_[kRows];
  std::vector<float> w_ = std::vector<float>(kCols, 0.f);
  std::vector<float> momentum_ = std::vector<float>(kCols, 0.f);
  std::vector<float> gradient_ = std::vector<float>(kCols, 0.f);
  int stop_after_;
};

class Controller : public ::testing::Test {
 protected:
  ControllerOptions Options(const std::string& name, int64_t steps) const {
    ControllerOptions o;
    o.name = "toy train";
    o.out = dir_.File(name);
    o.identity = "toy-identity";
    o.provenance.stage = "toy train";
    o.steps = steps;
    o.checkpoint_every = 4;
    o.progress_seconds = 1e9;
    return o;
  }
  static std::vector<float> Weights(const std::string& path) {
    return io::H5File::OpenRead(path).ReadVector<float>("/weights/w");
  }
  void TearDown() override { ClearStopRequest(); }
  testing::TempDir dir_;
  const dist::Comm comm_ = dist::Comm::Single();
};

TEST_F(Controller, TrainsAndWritesTheModelWithItsTrainingRecord) {
  LeastSquares net;
  double first = 0;
  net.Backward(0, &first);
  const TrainResult r = Train(Options("straight.h5", 60), comm_, &net);
  EXPECT_FALSE(r.up_to_date);
  EXPECT_EQ(r.steps_run, 60);
  double last = 0;
  net.Backward(60, &last);
  EXPECT_LT(last, 1e-3 * first);
  const io::H5File f = io::H5File::OpenRead(dir_.File("straight.h5"));
  EXPECT_EQ(f.GetIntAttribute("/training", "step"), 60);
  EXPECT_EQ(f.GetStringAttribute("/training", "identity_hash"), "toy-identity");
  EXPECT_EQ(f.GetStringAttribute("/training", "rank_weight_hashes"), HexHash(r.hash));
  EXPECT_FALSE(std::filesystem::exists(CheckpointPath(dir_.File("straight.h5"))));
}

TEST_F(Controller, StoppedRunContinuesToTheStraightResult) {
  LeastSquares straight;
  Train(Options("straight.h5", 10), comm_, &straight);
  LeastSquares stopped(6);
  EXPECT_THROW(Train(Options("stopped.h5", 10), comm_, &stopped), InterruptedError);
  const std::string checkpoint = CheckpointPath(dir_.File("stopped.h5"));
  ASSERT_TRUE(std::filesystem::exists(checkpoint));
  EXPECT_EQ(io::H5File::OpenRead(checkpoint).GetIntAttribute("/training", "step"), 6);
  EXPECT_FALSE(std::filesystem::exists(dir_.File("stopped.h5")));
  ClearStopRequest();
  LeastSquares resumed;
  const TrainResult r = Train(Options("stopped.h5", 10), comm_, &resumed);
  EXPECT_EQ(r.start_step, 6);
  EXPECT_EQ(r.steps_run, 4);
  EXPECT_EQ(resumed.w(), straight.w());
  EXPECT_EQ(Weights(dir_.File("stopped.h5")), Weights(dir_.File("straight.h5")));
}

TEST_F(Controller, FinishedModelIsUpToDateOrTrainedFurtherWhenAllowed) {
  LeastSquares straight;
  Train(Options("straight.h5", 12), comm_, &straight);
  LeastSquares again;
  EXPECT_TRUE(Train(Options("straight.h5", 12), comm_, &again).up_to_date);
  // Without continue_finished a finished model is up to date even for more steps.
  EXPECT_TRUE(Train(Options("straight.h5", 20), comm_, &again).up_to_date);

  LeastSquares shorter;
  Train(Options("longer.h5", 7), comm_, &shorter);
  ControllerOptions longer = Options("longer.h5", 12);
  longer.continue_finished = true;
  LeastSquares further;
  const TrainResult r = Train(longer, comm_, &further);
  EXPECT_EQ(r.start_step, 7);
  EXPECT_EQ(Weights(dir_.File("longer.h5")), Weights(dir_.File("straight.h5")));
}

TEST_F(Controller, RefusesACheckpointOfOtherOptions) {
  LeastSquares stopped(3);
  EXPECT_THROW(Train(Options("other.h5", 10), comm_, &stopped), InterruptedError);
  ClearStopRequest();
  ControllerOptions other = Options("other.h5", 10);
  other.identity = "other-identity";
  LeastSquares net;
  try {
    Train(other, comm_, &net);
    FAIL() << "a checkpoint of other options was continued";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(CheckpointPath(other.out)), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace facecap::train
