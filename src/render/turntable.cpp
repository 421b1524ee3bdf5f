#include "render/turntable.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "util/errors.h"

namespace facecap::render {
namespace {

// The i-th of count evenly spaced values in [low, high], ends included; the centre when
// count is 1.
float EvenlySpaced(int i, int count, float low, float high) {
  if (count <= 1) return 0.5f * (low + high);
  return low + (high - low) * static_cast<float>(i) / static_cast<float>(count - 1);
}

}  // namespace

std::vector<std::pair<float, float>> TurntableAngles(int num_views, float pitch_min,
                                                     float pitch_max, float yaw_min,
                                                     float yaw_max) {
  const bool finite = std::isfinite(pitch_min) && std::isfinite(pitch_max) &&
                      std::isfinite(yaw_min) && std::isfinite(yaw_max);
  if (num_views < 1 || !finite || pitch_min > pitch_max || yaw_min > yaw_max) {
    std::ostringstream message;
    message << "TurntableAngles: need num_views >= 1 and finite ranges with min <= max, got "
            << num_views << " views, pitch [" << pitch_min << ", " << pitch_max << "], yaw ["
            << yaw_min << ", " << yaw_max << "]";
    throw InvalidInputError(message.str());
  }
  const float pitch_range = pitch_max - pitch_min;
  const float yaw_range = yaw_max - yaw_min;
  int num_rows = 1;
  if (pitch_range > 0.f) {
    num_rows = yaw_range > 0.f
                   ? static_cast<int>(std::lround(std::sqrt(num_views * pitch_range / yaw_range)))
                   : num_views;
    num_rows = std::clamp(num_rows, 1, num_views);
  }
  std::vector<std::pair<float, float>> angles;
  angles.reserve(num_views);
  const int base_row_size = num_views / num_rows;
  const int rows_with_extra_view = num_views % num_rows;
  for (int row = 0; row < num_rows; ++row) {
    const int row_size = base_row_size + (row < rows_with_extra_view ? 1 : 0);
    const float pitch = EvenlySpaced(row, num_rows, pitch_min, pitch_max);
    for (int i = 0; i < row_size; ++i) {
      const int column = row % 2 == 0 ? i : row_size - 1 - i;  // serpentine
      angles.emplace_back(pitch, EvenlySpaced(column, row_size, yaw_min, yaw_max));
    }
  }
  return angles;
}

std::vector<rig::RigidPose> TurntablePoses(int num_views, float pitch_min, float pitch_max,
                                           float yaw_min, float yaw_max,
                                           const rig::RigidPose& base_pose) {
  std::vector<rig::RigidPose> poses;
  for (const auto& [pitch, yaw] :
       TurntableAngles(num_views, pitch_min, pitch_max, yaw_min, yaw_max)) {
    rig::RigidPose pose = base_pose;
    pose.pitch = pitch;
    pose.yaw = yaw;
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace facecap::render
