// What person fit (`facecap person fit`) measures beside the person's rig in its output: the
// rig itself is under /rig (io/rig_io.h); the fit's own results are under /person.
#ifndef FACECAP_STAGES_PERSON_FILE_H_
#define FACECAP_STAGES_PERSON_FILE_H_

#include <cstdint>
#include <string>
#include <vector>

namespace facecap::stages {

// Per landmark (68, iBUG order), the RMS distance of the frames' detected point to the
// projection of the person's landmark vertex at the frames' solved poses, in pixels of the
// fit's crops; the attribute crop_size gives their width.
inline constexpr const char* kLandmarkNoisePath = "/person/landmark_noise_px";

struct LandmarkNoise {
  std::vector<double> px;  // 68 values; empty: the file records none
  int64_t crop_size = 0;   // width of the crops px is measured in
  // Point l's noise in pixels of a crop `size` wide.
  double AtSize(int l, int size) const { return px[l] * size / static_cast<double>(crop_size); }
};

// The landmark noise `path` records; px empty when it records none (a rig that person fit did
// not make, or a fit without landmark placement). FileIOError for a count other than 68, a
// value that is not finite and positive, or a crop size below 1.
LandmarkNoise ReadLandmarkNoise(const std::string& path);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_PERSON_FILE_H_
