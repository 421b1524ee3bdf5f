#include "stages/lipsync_rest.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "io/audio.h"
#include "io/hdf5.h"
#include "lipsync/audio_align.h"
#include "stages/track_file.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {

namespace {

constexpr int kMinRestFrames = 3;
constexpr int kSoundRate = 16000;

// The sound to find the silent frames in: the option, else the frames file's source video.
std::string SoundPath(const std::string& frames, const RestCalibrationOptions& o) {
  if (!o.sound.empty() || frames.empty()) return o.sound;
  io::H5File f = io::H5File::OpenRead(frames);
  if (!f.Exists("/sources/files")) return "";
  const std::vector<std::string> files = f.ReadStrings("/sources/files");
  return files.size() == 1 ? files[0] : "";
}

}  // namespace

bool RestCalibrationOptions::Check(std::string* why) const {
  if (!(silence_db < 0.)) { *why = "silence_db must be negative (dB below the loudest frame)"; return false; }
  if (!(rest_margin_seconds >= 0.)) { *why = "rest_margin_seconds must be >= 0"; return false; }
  return true;
}

void CalibrateRest(const std::string& track, const std::string& frames, const RestCalibrationOptions& o) {
  if (!o.rest_calibration) return;
  const std::string sound = SoundPath(frames, o);
  if (sound.empty()) {
    FC_WARN("lipsync track: no sound to find the mouth at rest in (give sound); {} is not calibrated", track);
    return;
  }
  io::Audio audio;
  try {
    audio = io::DecodeAudio(sound, kSoundRate);
  } catch (const FileIOError& e) {
    if (!o.sound.empty()) throw;  // a sound given and unreadable is an error
    FC_WARN("lipsync track: {}; {} is not calibrated", e.what(), track);
    return;
  }
  TrackTimeline t = ReadTimeline(track);
  bool had_solved = false;
  {
    io::H5File f = io::H5File::OpenRead(track);
    had_solved = f.Exists("/track/weights_solved");
    if (had_solved) {
      f.CheckShape("/track/weights_solved", {t.frames(), static_cast<int64_t>(t.names.size())});
      t.weights = f.ReadMatrix<float>("/track/weights_solved");
    }
  }
  const std::vector<char> silent =
      lipsync::SilentFrames(audio.samples, audio.rate, t.times, o.silence_db, o.rest_margin_seconds);
  std::vector<int64_t> rest;
  for (int64_t f = 0; f < t.frames(); ++f) {
    if (silent[f] && t.Solved(f)) rest.push_back(f);
  }
  if (static_cast<int>(rest.size()) < kMinRestFrames) {
    FC_WARN("lipsync track: {} solved frames are silent in {} (at least {} needed); {} is not calibrated",
            rest.size(), sound, kMinRestFrames, track);
    return;
  }
  const int S = static_cast<int>(t.names.size());
  std::vector<float> bias(S);
  std::vector<float> column(rest.size());
  for (int s = 0; s < S; ++s) {
    for (size_t k = 0; k < rest.size(); ++k) column[k] = t.weights(rest[k], s);
    std::nth_element(column.begin(), column.begin() + column.size() / 2, column.end());
    bias[s] = column[column.size() / 2];
  }
  auto calibrated = t.weights;
  for (int64_t f = 0; f < t.frames(); ++f) {
    for (int s = 0; s < S; ++s) calibrated(f, s) = std::clamp(t.weights(f, s) - bias[s], 0.f, 1.f);
  }
  const std::string partial = io::H5File::PartialPath(track);
  std::error_code ec;
  std::filesystem::copy_file(track, partial, std::filesystem::copy_options::overwrite_existing, ec);
  if (ec) throw OutputError(partial + ": cannot copy " + track + ": " + ec.message());
  {
    io::H5File f = io::H5File::OpenReadWrite(partial);
    if (!had_solved) {
      f.WriteMatrix("/track/weights_solved", t.weights);
      f.SetAttribute("/track/weights_solved", "meaning",
                     std::string("the solve's weights before the rest calibration"));
    }
    f.WriteFrames<float>("/track/weights", 0, t.frames(), calibrated.data());
    if (f.Exists("/track/rest_bias")) f.Remove("/track/rest_bias");
    f.WriteVector<float>("/track/rest_bias", bias);
    f.SetAttribute("/track/rest_bias", "meaning",
                   std::string("per shape, the median of the solve's weights over the frames at rest "
                               "(silent), subtracted from /track/weights_solved"));
    f.SetAttribute("/track/rest_bias", "rest_frames", static_cast<int64_t>(rest.size()));
    f.SetAttribute("/track/rest_bias", "sound", sound);
    f.Close();
  }
  std::filesystem::rename(partial, track, ec);
  if (ec) throw OutputError(track + ": cannot rename " + partial + ": " + ec.message());
  std::vector<std::pair<float, std::string>> largest;
  for (int s = 0; s < S; ++s) {
    if (bias[s] > 0.f) largest.emplace_back(bias[s], t.names[s]);
  }
  std::sort(largest.rbegin(), largest.rend());
  std::string listed;
  for (size_t k = 0; k < std::min<size_t>(largest.size(), 4); ++k) {
    listed += (k ? ", " : "") + largest[k].second + " " + std::to_string(largest[k].first).substr(0, 5);
  }
  FC_INFO("lipsync track: the mouth at rest from {} silent frames of {}: {} controls held there{}{} "
          "subtracted -> {}", rest.size(), sound, largest.size(), listed.empty() ? "" : " (", 
          listed.empty() ? "" : listed + ")", track);
}

}  // namespace facecap::stages
