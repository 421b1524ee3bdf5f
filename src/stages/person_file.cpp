#include "stages/person_file.h"

#include <cmath>
#include <utility>

#include "io/hdf5.h"
#include "util/errors.h"

namespace facecap::stages {

LandmarkNoise ReadLandmarkNoise(const std::string& path) {
  LandmarkNoise noise;
  const io::H5File f = io::H5File::OpenRead(path);
  if (!f.Exists(kLandmarkNoisePath)) return noise;
  std::vector<double> px = f.ReadVector<double>(kLandmarkNoisePath);
  const int64_t size = f.HasAttribute(kLandmarkNoisePath, "crop_size")
                           ? f.GetIntAttribute(kLandmarkNoisePath, "crop_size")
                           : 0;
  if (px.size() != 68) {
    throw FileIOError(path + ": " + kLandmarkNoisePath + " holds " + std::to_string(px.size()) +
                      " values, not one per landmark (68)");
  }
  for (double v : px) {
    if (!(std::isfinite(v) && v > 0.)) {
      throw FileIOError(path + ": " + kLandmarkNoisePath + " must be finite and positive");
    }
  }
  if (size < 1) throw FileIOError(path + ": " + kLandmarkNoisePath + " has no crop_size of 1 or more");
  noise.px = std::move(px);
  noise.crop_size = size;
  return noise;
}

}  // namespace facecap::stages
