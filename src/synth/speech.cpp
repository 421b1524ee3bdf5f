#include "synth/speech.h"

#include <espeak-ng/speak_lib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sys/wait.h>
#include <unistd.h>

#include "lipsync/visemes.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {
namespace {

struct Collected {
  std::vector<int16_t> samples;
  std::vector<std::pair<std::string, int>> phone_starts;  // (IPA, ms)
};

// What the callback fills, in the process that speaks.
Collected* g_collecting = nullptr;

int Collect(short* wav, int count, espeak_EVENT* events) {
  Collected* c = g_collecting;
  if (!c) return 0;
  for (espeak_EVENT* e = events; e && e->type != espeakEVENT_LIST_TERMINATED; ++e) {
    if (e->type == espeakEVENT_PHONEME) {
      char name[9] = {0};
      std::memcpy(name, e->id.string, 8);
      // audio_position: ms from the start of the utterance's audio.
      c->phone_starts.emplace_back(name, e->audio_position);
    }
  }
  if (wav) c->samples.insert(c->samples.end(), wav, wav + count);
  return 0;
}

// In a child process: espeak-ng speaks and the result goes to `fd`. Status byte 0, the rate,
// the samples and the phones; or status 1 and a message.
[[noreturn]] void SpeakInChild(const std::string& text, const std::string& voice, int fd) {
  ByteWriter w;
  const int rate = espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0, nullptr,
                                     espeakINITIALIZE_PHONEME_EVENTS | espeakINITIALIZE_PHONEME_IPA |
                                         espeakINITIALIZE_DONT_EXIT);
  std::string error;
  Collected c;
  if (rate <= 0) {
    error = "espeak-ng could not start (is espeak-ng-data installed?)";
  } else if (espeak_SetVoiceByName(voice.c_str()) != EE_OK) {
    error = "espeak-ng has no voice '" + voice + "' (espeak-ng --voices lists them; variants as en+f3)";
  } else {
    espeak_SetSynthCallback(Collect);
    g_collecting = &c;
    if (espeak_Synth(text.c_str(), text.size() + 1, 0, POS_CHARACTER, 0, espeakCHARS_UTF8, nullptr,
                     nullptr) != EE_OK) {
      error = "espeak-ng failed to speak the text";
    }
    espeak_Synchronize();
  }
  if (error.empty()) {
    w.Put<uint8_t>(0);
    w.Put<int32_t>(rate);
    w.PutVector(c.samples);
    w.Put<uint64_t>(c.phone_starts.size());
    for (const auto& [name, ms] : c.phone_starts) {
      w.PutArray(name.data(), name.size());
      w.Put<int32_t>(ms);
    }
  } else {
    w.Put<uint8_t>(1);
    w.PutArray(error.data(), error.size());
  }
  const std::vector<uint8_t>& bytes = w.bytes();
  size_t at = 0;
  while (at < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + at, bytes.size() - at);
    if (n <= 0) _exit(2);
    at += static_cast<size_t>(n);
  }
  close(fd);
  _exit(0);
}

}  // namespace

SpeechAudio Speak(const std::string& text, const std::string& voice) {
  if (text.empty()) throw InvalidInputError("speech: the text is empty");
  // espeak-ng keeps state from one utterance to the next (its pitch flutter and noise
  // generators), so each utterance is spoken by a fresh child process: the same text and
  // voice give the same samples, whatever was spoken before.
  int fds[2];
  if (pipe(fds) != 0) throw FileIOError("speech: cannot make a pipe for espeak-ng");
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    throw FileIOError("speech: cannot start a process for espeak-ng");
  }
  if (pid == 0) {
    close(fds[0]);
    SpeakInChild(text, voice, fds[1]);
  }
  close(fds[1]);
  std::vector<uint8_t> bytes;
  uint8_t buffer[65536];
  ssize_t n = 0;
  while ((n = read(fds[0], buffer, sizeof(buffer))) > 0) bytes.insert(bytes.end(), buffer, buffer + n);
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty()) {
    throw FileIOError("speech: the espeak-ng process failed");
  }
  ByteReader r(bytes);
  if (r.Get<uint8_t>() != 0) {
    const std::vector<char> message = r.GetVector<char>();
    throw InvalidInputError("speech: " + std::string(message.begin(), message.end()));
  }
  SpeechAudio out;
  out.rate = r.Get<int32_t>();
  const std::vector<int16_t> samples = r.GetVector<int16_t>();
  out.samples.reserve(samples.size());
  for (int16_t x : samples) out.samples.push_back(x / 32768.f);
  const uint64_t count = r.Get<uint64_t>();
  std::vector<std::pair<std::string, int>> starts;
  for (uint64_t i = 0; i < count; ++i) {
    const std::vector<char> name = r.GetVector<char>();
    starts.emplace_back(std::string(name.begin(), name.end()), r.Get<int32_t>());
  }
  const int n_phones = static_cast<int>(starts.size());
  for (int i = 0; i < n_phones; ++i) {
    lipsync::PhoneSegment p;
    p.phone = starts[i].first;
    p.start = starts[i].second / 1000.;
    p.end = i + 1 < n_phones ? starts[i + 1].second / 1000.
                             : static_cast<double>(out.samples.size()) / out.rate;
    const int v = lipsync::VisemeOfIpa(p.phone);
    p.viseme = v < 0 ? 0 : v;
    if (p.end > p.start) out.phones.push_back(p);
  }
  if (out.samples.empty()) throw FileIOError("speech: espeak-ng produced no audio");
  return out;
}

std::vector<lipsync::PhoneSegment> ShiftPhones(std::vector<lipsync::PhoneSegment> phones,
                                               double seconds) {
  for (auto& p : phones) {
    p.start += seconds;
    p.end += seconds;
  }
  return phones;
}

SpeakerStyle SpeakerStyleOf(int identity_seed) {
  SpeakerStyle s;
  const int C = static_cast<int>(lipsync::DefaultMouthControls().size());
  s.gains = Eigen::VectorXf::Ones(C);
  if (identity_seed == 0) return s;
  Rng rng(static_cast<uint64_t>(identity_seed), 0x5BEEC4u);
  s.lead_seconds = static_cast<float>(rng.Uniform(0.02, 0.07));
  s.lag_seconds = static_cast<float>(rng.Uniform(0.01, 0.045));
  s.smoothing_seconds = static_cast<float>(rng.Uniform(0.015, 0.035));
  s.amplitude = static_cast<float>(rng.Uniform(0.8, 1.2));
  for (int c = 0; c < C; ++c) s.gains[c] = static_cast<float>(rng.Uniform(0.75, 1.25));
  return s;
}

namespace {

// The speaker's own mouth pose of each viseme: not lipsync::VisemePose, which the audio-only
// mouth source maps phones to, so that the truth does not share that source's poses.
const std::vector<std::pair<std::string, float>>& SpeakerPose(lipsync::Viseme v) {
  using Pose = std::vector<std::pair<std::string, float>>;
  static const Pose kPoses[lipsync::kNumVisemes] = {
      {},
      {{"mouthClose", 0.2f}, {"mouthPressLeft", 0.35f}, {"mouthPressRight", 0.35f},
       {"mouthRollUpper", 0.15f}, {"mouthRollLower", 0.3f}},
      {{"jawOpen", 0.05f}, {"mouthRollLower", 0.45f}, {"mouthUpperUpLeft", 0.15f},
       {"mouthUpperUpRight", 0.15f}, {"mouthPressLeft", 0.1f}, {"mouthPressRight", 0.1f}},
      {{"jawOpen", 0.12f}, {"mouthLowerDownLeft", 0.1f}, {"mouthLowerDownRight", 0.1f}},
      {{"jawOpen", 0.18f}, {"mouthStretchLeft", 0.1f}, {"mouthStretchRight", 0.1f},
       {"mouthLowerDownLeft", 0.1f}, {"mouthLowerDownRight", 0.1f}},
      {{"jawOpen", 0.3f}, {"mouthStretchLeft", 0.05f}, {"mouthStretchRight", 0.05f}},
      {{"jawOpen", 0.1f}, {"mouthFunnel", 0.4f}, {"mouthPucker", 0.3f}, {"mouthUpperUpLeft", 0.1f},
       {"mouthUpperUpRight", 0.1f}},
      {{"jawOpen", 0.06f}, {"mouthSmileLeft", 0.25f}, {"mouthSmileRight", 0.25f},
       {"mouthStretchLeft", 0.2f}, {"mouthStretchRight", 0.2f}},
      {{"jawOpen", 0.12f}, {"mouthLowerDownLeft", 0.08f}, {"mouthLowerDownRight", 0.08f}},
      {{"jawOpen", 0.12f}, {"mouthPucker", 0.45f}, {"mouthFunnel", 0.2f}},
      {{"jawOpen", 0.5f}, {"mouthLowerDownLeft", 0.4f}, {"mouthLowerDownRight", 0.4f},
       {"mouthStretchLeft", 0.1f}, {"mouthStretchRight", 0.1f}},
      {{"jawOpen", 0.3f}, {"mouthSmileLeft", 0.3f}, {"mouthSmileRight", 0.3f},
       {"mouthLowerDownLeft", 0.15f}, {"mouthLowerDownRight", 0.15f}},
      {{"jawOpen", 0.15f}, {"mouthSmileLeft", 0.35f}, {"mouthSmileRight", 0.35f},
       {"mouthStretchLeft", 0.15f}, {"mouthStretchRight", 0.15f}},
      {{"jawOpen", 0.35f}, {"mouthFunnel", 0.6f}, {"mouthPucker", 0.15f}},
      {{"jawOpen", 0.1f}, {"mouthPucker", 0.8f}, {"mouthFunnel", 0.3f}},
  };
  return kPoses[std::clamp(static_cast<int>(v), 0, lipsync::kNumVisemes - 1)];
}

}  // namespace

Eigen::MatrixXf SpeakerMouth(const std::vector<lipsync::PhoneSegment>& phones,
                             const std::vector<std::string>& shape_names, int frames, double fps,
                             const SpeakerStyle& style) {
  using lipsync::Viseme;
  const int S = static_cast<int>(shape_names.size());
  const std::vector<std::string>& mouth = lipsync::DefaultMouthControls();
  // Viseme poses over the shapes, with the person's gains.
  Eigen::MatrixXf poses = Eigen::MatrixXf::Zero(lipsync::kNumVisemes, S);
  for (int v = 0; v < lipsync::kNumVisemes; ++v) {
    for (const auto& [name, weight] : SpeakerPose(static_cast<Viseme>(v))) {
      const auto it = std::find(mouth.begin(), mouth.end(), name);
      const float gain = it != mouth.end() && style.gains.size() == static_cast<int>(mouth.size())
                             ? style.gains[it - mouth.begin()] : 1.f;
      for (int s : lipsync::ShapeIndices(shape_names, {name})) {
        poses(v, s) = std::min(1.f, style.amplitude * gain * weight);
      }
    }
  }
  auto priority = [](int viseme) {
    switch (static_cast<Viseme>(viseme)) {
      case Viseme::kSilence: return 0.3;
      case Viseme::kPP: return 4.;
      case Viseme::kFF: return 2.5;
      case Viseme::kAA: case Viseme::kE: case Viseme::kIH: case Viseme::kOH: case Viseme::kOU:
        return 1.;
      default: return 0.6;
    }
  };
  // A finer internal clock, so that the smoothing does not depend on the frame rate.
  const double step = 0.002;
  const int fine = static_cast<int>(std::ceil(frames / fps / step)) + 2;
  Eigen::MatrixXf mix = Eigen::MatrixXf::Zero(fine, S);
  for (int i = 0; i < fine; ++i) {
    const double t = i * step;
    double total = 0.05;  // the rest pose holds a little everywhere
    Eigen::VectorXf sum = Eigen::VectorXf::Zero(S);
    for (const auto& p : phones) {
      const double a = p.start - style.lead_seconds, b = p.end + style.lag_seconds;
      if (t <= a || t >= b) continue;
      const double w = priority(p.viseme) * 0.5 * (1. - std::cos(2. * M_PI * (t - a) / (b - a)));
      total += w;
      if (p.viseme > 0) sum += static_cast<float>(w) * poses.row(p.viseme).transpose();
    }
    mix.row(i) = (sum / static_cast<float>(total)).transpose();
  }
  // Forward-backward exponential smoothing (zero phase).
  const float k = static_cast<float>(1. - std::exp(-step / std::max(1e-4f, style.smoothing_seconds)));
  for (int i = 1; i < fine; ++i) mix.row(i) += k * (mix.row(i - 1) - mix.row(i));
  for (int i = fine - 2; i >= 0; --i) mix.row(i) += k * (mix.row(i + 1) - mix.row(i));
  Eigen::MatrixXf out(frames, S);
  for (int f = 0; f < frames; ++f) {
    const int i = std::min(fine - 1, static_cast<int>(std::lround(f / fps / step)));
    out.row(f) = mix.row(i).cwiseMax(0.f).cwiseMin(1.f);
  }
  return out;
}

void ApplySpeech(const rig::Rig& rig, const std::vector<lipsync::PhoneSegment>& phones,
                 const SpeakerStyle& style, double fps, bool lips_view,
                 std::vector<ClipFrameParams>* frames) {
  std::vector<std::string> names;
  for (const auto& shape : rig.shapes) names.push_back(shape.name);
  const std::vector<int> mouth = lipsync::ShapeIndices(names, lipsync::DefaultMouthControls());
  if (mouth.empty()) {
    throw InvalidInputError("speech: the rig has none of the ARKit mouth controls (jawOpen, mouth*)");
  }
  const Eigen::MatrixXf talking =
      SpeakerMouth(phones, names, static_cast<int>(frames->size()), fps, style);
  for (size_t f = 0; f < frames->size(); ++f) {
    ClipFrameParams& p = (*frames)[f];
    if (lips_view) {
      p.pitch = p.yaw = p.roll = 0.f;
      p.translation_offset.setZero();
      p.weights.setZero();
    }
    for (int s : mouth) p.weights[s] = talking(static_cast<int>(f), s);
  }
}

}  // namespace facecap::synth
