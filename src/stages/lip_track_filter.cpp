#include "stages/lip_track_filter.h"

#include <algorithm>
#include <filesystem>
#include <utility>
#include <vector>

#include "io/audio.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "lipsync/audio_align.h"
#include "lipsync/speech_track.h"
#include "stages/track_file.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {

namespace {

using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

constexpr int kMinRestFrames = 3;
constexpr int kSoundRate = 16000;
constexpr float kPartedGap = 0.02f;  // the inner-lip gap (IOD) that parted lips are opened to

// The sound to find the silent frames in: the option, else the frames file's source video.
std::string SoundPath(const std::string& frames, const LipTrackFilterOptions& o) {
  if (!o.sound.empty() || frames.empty()) return o.sound;
  io::H5File f = io::H5File::OpenRead(frames);
  if (!f.Exists("/sources/files")) return "";
  const std::vector<std::string> files = f.ReadStrings("/sources/files");
  return files.size() == 1 ? files[0] : "";
}

float Median(std::vector<float>* v) {
  std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
  return (*v)[v->size() / 2];
}

// The lip video's sound at 16 kHz, its path in *path (no samples: none, warned).
io::Audio LipSound(const std::string& track, const std::string& frames, const LipTrackFilterOptions& o,
                   std::string* path) {
  *path = SoundPath(frames, o);
  if (path->empty()) {
    FC_WARN("lipsync track: no sound to find the mouth at rest and the phones in (give sound); {} is "
            "neither calibrated nor checked against the phones", track);
    return {};
  }
  try {
    return io::DecodeAudio(*path, kSoundRate);
  } catch (const FileIOError& e) {
    if (!o.sound.empty()) throw;  // a sound given and unreadable is an error
    FC_WARN("lipsync track: {}; {} is neither calibrated nor checked against the phones", e.what(), track);
    return {};
  }
}

// The per-shape median of the weights over the solved silent frames (empty: no calibration,
// warned).
std::vector<float> RestBias(const TrackTimeline& t, const std::string& track, const io::Audio& audio,
                            const std::string& sound, const LipTrackFilterOptions& o, int* rest_frames) {
  if (audio.samples.empty()) return {};
  const std::vector<char> silent =
      lipsync::SilentFrames(audio.samples, audio.rate, t.times, o.silence_db, o.rest_margin_seconds);
  std::vector<int64_t> rest;
  for (int64_t f = 0; f < t.frames(); ++f) {
    if (silent[f] && t.Solved(f)) rest.push_back(f);
  }
  *rest_frames = static_cast<int>(rest.size());
  if (*rest_frames < kMinRestFrames) {
    FC_WARN("lipsync track: {} solved frames are silent in {} (at least {} needed); {} is not calibrated",
            rest.size(), sound, kMinRestFrames, track);
    return {};
  }
  std::vector<float> bias(t.names.size());
  std::vector<float> column(rest.size());
  for (size_t s = 0; s < bias.size(); ++s) {
    for (size_t k = 0; k < rest.size(); ++k) column[k] = t.weights(rest[k], static_cast<int>(s));
    bias[s] = Median(&column);
  }
  return bias;
}

// Parts the lips of the solved frames where the sound's phones forbid a closure (the rig's
// jawOpen column of *w raised); returns the frames changed.
int PartLips(const TrackTimeline& t, const std::string& rig_path, const io::Audio& audio,
             const LipTrackFilterOptions& o, RowMatrixF* w) {
  const rig::Rig rig = io::ReadRigFile(rig_path);
  lipsync::RecognizerOptions recognizer;
  recognizer.model_dir = o.model_dir;
  recognizer.transcript = o.transcript;
  std::vector<lipsync::PhoneSegment> phones;
  try {
    phones = lipsync::RecognizePhones(audio.samples, recognizer);
  } catch (const InvalidInputError& e) {
    if (!o.transcript.empty()) throw;  // words given that the sound does not carry
    FC_WARN("lipsync track: {}; the lips are not checked against the phones", e.what());
    return 0;
  }
  std::vector<char> may = lipsync::LipsMayMeet(
      phones, t.times,
      o.transcript.empty() ? lipsync::MeetRule::kAllButVowels : lipsync::MeetRule::kBilabialsAndSilences);
  for (int64_t f = 0; f < t.frames(); ++f) {
    if (!t.Solved(f)) may[f] = 1;
  }
  std::vector<int> column(rig.NumShapes(), -1);
  for (int s = 0; s < rig.NumShapes(); ++s) {
    const auto it = std::find(t.names.begin(), t.names.end(), rig.shapes[s].name);
    if (it != t.names.end()) column[s] = static_cast<int>(it - t.names.begin());
  }
  Eigen::MatrixXf in_rig = Eigen::MatrixXf::Zero(t.frames(), rig.NumShapes());
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (column[s] >= 0) in_rig.col(s) = w->col(column[s]);
  }
  const int parted = lipsync::PartLipsWhereSoundForbids(rig, may, lipsync::kLipsMeetGap, kPartedGap, &in_rig);
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (column[s] >= 0) w->col(column[s]) = in_rig.col(s);
  }
  int spoken = 0;
  for (const auto& p : phones) spoken += p.viseme != 0;
  FC_INFO("lipsync track: {} phones ({} spoken{}); the lips parted in {} frames where they met in {}",
          phones.size(), spoken, o.transcript.empty() ? ", recognized freely" : ", transcript aligned", parted,
          o.transcript.empty() ? "a vowel" : "a phone other than a bilabial or a silence");
  return parted;
}

// The running median over `window` frames of every column, the ends repeated.
RowMatrixF RunningMedian(const RowMatrixF& w, int window) {
  if (window <= 1) return w;
  const int64_t n = w.rows();
  const int h = window / 2;
  RowMatrixF out(w.rows(), w.cols());
  std::vector<float> v(window);
  for (int s = 0; s < w.cols(); ++s) {
    for (int64_t f = 0; f < n; ++f) {
      for (int k = -h; k <= h; ++k) v[k + h] = w(std::clamp<int64_t>(f + k, 0, n - 1), s);
      out(f, s) = Median(&v);
    }
  }
  return out;
}

// The largest few of the bias, for the log.
std::string LargestControls(const std::vector<float>& bias, const std::vector<std::string>& names) {
  std::vector<std::pair<float, std::string>> largest;
  for (size_t s = 0; s < bias.size(); ++s) {
    if (bias[s] > 0.f) largest.emplace_back(bias[s], names[s]);
  }
  std::sort(largest.rbegin(), largest.rend());
  std::string listed;
  for (size_t k = 0; k < std::min<size_t>(largest.size(), 4); ++k) {
    listed += (k ? ", " : "") + largest[k].second + " " + std::to_string(largest[k].first).substr(0, 5);
  }
  return std::to_string(largest.size()) + " controls" + (listed.empty() ? "" : " (" + listed + ")");
}

}  // namespace

bool LipTrackFilterOptions::Check(std::string* why) const {
  if (!(silence_db < 0.)) { *why = "silence_db must be negative (dB below the loudest frame)"; return false; }
  if (!(rest_margin_seconds >= 0.)) { *why = "rest_margin_seconds must be >= 0"; return false; }
  if (median_frames < 1 || median_frames % 2 == 0) { *why = "median_frames must be odd and >= 1"; return false; }
  return true;
}

void CheckLipTrackSound(const LipTrackFilterOptions& o) {
  if ((o.rest_calibration || o.part_lips) && !o.sound.empty()) io::DecodeAudio(o.sound, kSoundRate);
  if (o.part_lips) {
    lipsync::RecognizerOptions recognizer;
    recognizer.model_dir = o.model_dir;
    recognizer.transcript = o.transcript;
    lipsync::CheckRecognizerOptions(recognizer);
  }
}

void FilterLipTrack(const std::string& track, const std::string& frames, const std::string& rig,
                    const LipTrackFilterOptions& o) {
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
  std::string sound;
  const io::Audio audio = o.rest_calibration || o.part_lips ? LipSound(track, frames, o, &sound) : io::Audio();
  int rest_frames = 0;
  const std::vector<float> bias =
      o.rest_calibration ? RestBias(t, track, audio, sound, o, &rest_frames) : std::vector<float>();
  RowMatrixF filtered = t.weights;
  for (size_t s = 0; s < bias.size(); ++s) {
    const int c = static_cast<int>(s);
    filtered.col(c) = (t.weights.col(c).array() - bias[s]).cwiseMax(0.f).cwiseMin(1.f).matrix();
  }
  filtered = RunningMedian(filtered, o.median_frames);
  const int parted = o.part_lips && !audio.samples.empty() ? PartLips(t, rig, audio, o, &filtered) : 0;
  if (!had_solved && bias.empty() && o.median_frames <= 1 && parted == 0) return;  // nothing to change

  const std::string partial = io::H5File::PartialPath(track);
  std::error_code ec;
  std::filesystem::copy_file(track, partial, std::filesystem::copy_options::overwrite_existing, ec);
  if (ec) throw OutputError(partial + ": cannot copy " + track + ": " + ec.message());
  {
    io::H5File f = io::H5File::OpenReadWrite(partial);
    if (!had_solved) {
      f.WriteMatrix("/track/weights_solved", t.weights);
      f.SetAttribute("/track/weights_solved", "meaning",
                     std::string("the solve's weights; /track/weights are these less the rest bias "
                                 "(clamped to [0, 1]), then a running median over median_frames, then "
                                 "jawOpen raised where the lips met outside a bilabial or a silence"));
    }
    f.SetAttribute("/track/weights_solved", "median_frames", static_cast<int64_t>(o.median_frames));
    f.SetAttribute("/track/weights_solved", "lips_parted_frames", static_cast<int64_t>(parted));
    f.WriteFrames<float>("/track/weights", 0, t.frames(), filtered.data());
    if (f.Exists("/track/rest_bias")) f.Remove("/track/rest_bias");
    if (!bias.empty()) {
      f.WriteVector<float>("/track/rest_bias", bias);
      f.SetAttribute("/track/rest_bias", "meaning",
                     std::string("per shape, the median of the solve's weights over the frames at rest "
                                 "(silent), subtracted from /track/weights_solved"));
      f.SetAttribute("/track/rest_bias", "rest_frames", static_cast<int64_t>(rest_frames));
      f.SetAttribute("/track/rest_bias", "sound", sound);
    }
    f.Close();
  }
  std::filesystem::rename(partial, track, ec);
  if (ec) throw OutputError(track + ": cannot rename " + partial + ": " + ec.message());
  if (!bias.empty()) {
    FC_INFO("lipsync track: the mouth at rest from {} silent frames of {}: {} held there, subtracted",
            rest_frames, std::filesystem::absolute(sound).string(), LargestControls(bias, t.names));
  }
  FC_INFO("lipsync track: running median over {} frames -> {}", o.median_frames, track);
}

}  // namespace facecap::stages
