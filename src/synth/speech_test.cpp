// Talking-person truth: espeak-ng's speech and phone times, every phone it speaks mapped to a
// viseme, a speaker's mouth that closes the lips on bilabials, and the frontal lip view.
#include "synth/speech.h"

#include <cmath>

#include <gtest/gtest.h>

#include "lipsync/audio_align.h"
#include "lipsync/phone_recognizer.h"
#include "lipsync/visemes.h"
#include "rig/arkit.h"
#include "rig/demo_head.h"
#include "util/errors.h"

namespace facecap::synth {
namespace {

const char* const kText =
    "The quick brown fox jumps over the lazy dog. Bob made a map of Paris; "
    "she will judge the thin vision of that azure rhythm, yes.";

TEST(Speech, EspeakSpeaksWithPhoneTimesAndEveryPhoneHasAViseme) {
  const SpeechAudio a = Speak(kText, "en");
  ASSERT_GT(a.rate, 8000);
  const double seconds = static_cast<double>(a.samples.size()) / a.rate;
  EXPECT_GT(seconds, 4.);
  ASSERT_GT(a.phones.size(), 60u);
  double previous_end = 0.;
  for (const auto& p : a.phones) {
    EXPECT_GE(lipsync::VisemeOfIpa(p.phone), 0) << "no viseme for '" << p.phone << "'";
    EXPECT_GE(p.start, previous_end - 1e-9);
    EXPECT_GT(p.end, p.start);
    EXPECT_LE(p.end, seconds + 1e-9);
    previous_end = p.end;
  }
  // Loud where it speaks.
  double energy = 0.;
  for (float x : a.samples) energy += x * x;
  EXPECT_GT(std::sqrt(energy / a.samples.size()), 0.01);
  // Deterministic, and other voices differ.
  EXPECT_EQ(Speak(kText, "en").samples, a.samples);
  EXPECT_NE(Speak(kText, "en+f3").samples.size(), 0u);
  EXPECT_THROW(Speak(kText, "no-such-voice"), InvalidInputError);
  EXPECT_THROW(Speak("", "en"), InvalidInputError);
}

TEST(Speech, SpeakerClosesTheLipsOnBilabialsAndOpensThemOnVowels) {
  rig::DemoHeadOptions options;
  options.resolution = 60;
  const rig::Rig rig = rig::MakeDemoHead(options);
  std::vector<std::string> names;
  for (const auto& s : rig.shapes) names.push_back(s.name);
  const std::vector<lipsync::PhoneSegment> phones = ShiftPhones(Speak("Bob made a map.", "en").phones, 0.3);
  const double fps = 30.;
  const int frames = static_cast<int>((phones.back().end + 0.5) * fps);
  const Eigen::MatrixXf w = SpeakerMouth(phones, names, frames, fps, SpeakerStyleOf(7));
  EXPECT_TRUE((w.array() >= 0.f).all() && (w.array() <= 1.f).all());
  EXPECT_EQ(w.col(rig.ShapeIndex("browInnerUp")).norm(), 0.f);
  const std::vector<float> gaps = lipsync::InnerLipGaps(rig, w);
  // At the centre of each bilabial the lips nearly meet; at the centre of each open vowel
  // they are apart.
  int bilabials = 0, vowels = 0;
  for (const auto& p : phones) {
    const int f = static_cast<int>(std::lround(0.5 * (p.start + p.end) * fps));
    if (p.viseme == static_cast<int>(lipsync::Viseme::kPP)) {
      EXPECT_LT(gaps[f], 0.01f) << p.phone << " at " << p.start;
      ++bilabials;
    } else if (p.viseme == static_cast<int>(lipsync::Viseme::kAA) && p.end - p.start > 0.06) {
      EXPECT_GT(gaps[f], 0.03f) << p.phone << " at " << p.start;
      ++vowels;
    }
  }
  EXPECT_GE(bilabials, 4);
  EXPECT_GE(vowels, 1);
  // Two people articulate differently.
  EXPECT_GT((SpeakerMouth(phones, names, frames, fps, SpeakerStyleOf(8)) - w).cwiseAbs().maxCoeff(), 0.05f);
}

TEST(Speech, LipsViewIsFrontalAndStillOutsideTheMouth) {
  rig::DemoHeadOptions options;
  options.resolution = 60;
  options.num_identity_modes = 4;
  const rig::Rig rig = rig::MakeDemoHead(options);
  ClipOptions o;
  o.frames = 60;
  o.size = 32;
  std::vector<ClipFrameParams> talking = MakeClipTrajectory(rig, o);
  std::vector<ClipFrameParams> lips = talking;
  const auto phones = ShiftPhones(Speak("Bob made a map.", "en").phones, 0.2);
  ApplySpeech(rig, phones, SpeakerStyleOf(3), o.fps, false, &talking);
  ApplySpeech(rig, phones, SpeakerStyleOf(3), o.fps, true, &lips);
  const int jaw = rig.ShapeIndex("jawOpen"), blink = rig.ShapeIndex("eyeBlinkLeft");
  float jaw_max = 0.f;
  for (int f = 0; f < o.frames; ++f) {
    EXPECT_EQ(talking[f].weights[jaw], lips[f].weights[jaw]);
    jaw_max = std::max(jaw_max, lips[f].weights[jaw]);
    EXPECT_EQ(lips[f].yaw, 0.f);
    EXPECT_EQ(lips[f].pitch, 0.f);
    EXPECT_EQ(lips[f].weights[blink], 0.f);
    EXPECT_EQ(lips[f].translation_offset.norm(), 0.f);
  }
  EXPECT_GT(jaw_max, 0.2f);
}

TEST(PhoneRecognizer, EveryPhoneOfTheEnglishModelHasAViseme) {
  const std::vector<std::string> phones = lipsync::ModelPhones(lipsync::RecognizerOptions().model_dir);
  EXPECT_GE(phones.size(), 42u);  // 39 phones, silence and two fillers
  for (const std::string& p : phones) EXPECT_GE(lipsync::VisemeOfArpabet(p), 0) << p;
  EXPECT_NE(std::find(phones.begin(), phones.end(), "ZH"), phones.end());
}

// The fraction of 10 ms frames whose recognized viseme is the spoken one.
double VisemeAgreement(const std::vector<lipsync::PhoneSegment>& truth,
                       const std::vector<lipsync::PhoneSegment>& found, double seconds) {
  auto at = [](const std::vector<lipsync::PhoneSegment>& phones, double t) {
    for (const auto& p : phones) {
      if (t >= p.start && t < p.end) return p.viseme;
    }
    return 0;
  };
  int same = 0, frames = 0;
  for (double t = 0.; t < seconds; t += 0.01) {
    const int v = at(truth, t);
    if (v == 0) continue;  // speech frames only
    ++frames;
    same += at(found, t) == v;
  }
  return frames ? static_cast<double>(same) / frames : 0.;
}

TEST(PhoneRecognizer, FindsEspeaksVisemesFreelyAndBetterWithTheTranscript) {
  const char* text = "Peter bought a bamboo umbrella, and Maria made warm apple pie.";
  const SpeechAudio a = Speak(text, "en");
  const std::vector<float> pcm = lipsync::ResampleAudio(a.samples, a.rate, lipsync::kRecognizerRate);
  const double seconds = static_cast<double>(a.samples.size()) / a.rate;
  lipsync::RecognizerOptions options;
  const auto free = lipsync::RecognizePhones(pcm, options);
  ASSERT_GT(free.size(), 20u);
  options.transcript = text;
  const auto aligned = lipsync::RecognizePhones(pcm, options);
  ASSERT_GT(aligned.size(), 30u);
  const double free_agreement = VisemeAgreement(a.phones, free, seconds);
  const double aligned_agreement = VisemeAgreement(a.phones, aligned, seconds);
  std::printf("viseme agreement with espeak-ng over speech frames: free %.3f, transcript %.3f\n",
              free_agreement, aligned_agreement);
  EXPECT_GT(free_agreement, 0.3);
  EXPECT_GT(aligned_agreement, free_agreement);
  options.transcript = "Peter bought a zqxwv.";
  EXPECT_THROW(lipsync::RecognizePhones(pcm, options), InvalidInputError);
}

}  // namespace
}  // namespace facecap::synth
