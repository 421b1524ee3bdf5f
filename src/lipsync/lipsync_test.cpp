// Lip-sync pieces: phone-to-viseme tables, the dominance coarticulation, resampling with an
// offset, the blend's limits, lip closures and their detection score, and the recovery of a
// known offset between two recordings.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "lipsync/audio_align.h"
#include "lipsync/speech_track.h"
#include "lipsync/visemes.h"
#include "rig/arkit.h"
#include "rig/demo_head.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::lipsync {
namespace {

TEST(Visemes, ArpabetPhonesOfCmuDictionaryAllMap) {
  for (const char* p : {"AA", "AE", "AH", "AO", "AW", "AY", "B", "CH", "D", "DH", "EH", "ER", "EY",
                        "F", "G", "HH", "IH", "IY", "JH", "K", "L", "M", "N", "NG", "OW", "OY",
                        "P", "R", "S", "SH", "T", "TH", "UH", "UW", "V", "W", "Y", "Z", "ZH",
                        "SIL", "+NSN+", "+SPN+", "ah1", "iy0"}) {
    EXPECT_GE(VisemeOfArpabet(p), 0) << p;
  }
  EXPECT_EQ(VisemeOfArpabet("M"), static_cast<int>(Viseme::kPP));
  EXPECT_EQ(VisemeOfArpabet("uw1"), static_cast<int>(Viseme::kOU));
  EXPECT_EQ(VisemeOfArpabet("Q"), -1);
}

TEST(Visemes, IpaPhonesWithMarks) {
  EXPECT_EQ(VisemeOfIpa("p"), static_cast<int>(Viseme::kPP));
  EXPECT_EQ(VisemeOfIpa("\xCB\x88" "a\xC9\xAA"), static_cast<int>(Viseme::kAA));  // stressed "aI"
  EXPECT_EQ(VisemeOfIpa("t\xCA\x83"), static_cast<int>(Viseme::kCH));            // t + esh
  EXPECT_EQ(VisemeOfIpa("u\xCB\x90"), static_cast<int>(Viseme::kOU));            // long u
  EXPECT_EQ(VisemeOfIpa(""), static_cast<int>(Viseme::kSilence));
  EXPECT_EQ(VisemeOfIpa("\xE2\x82\xAC"), -1);  // the euro sign is no phone
}

TEST(Visemes, PosesNameArkitMouthControls) {
  for (int v = 0; v < kNumVisemes; ++v) {
    for (const auto& [name, weight] : VisemePose(static_cast<Viseme>(v))) {
      EXPECT_GE(rig::ArkitIndex(name), 0) << name;
      EXPECT_NE(std::find(DefaultMouthControls().begin(), DefaultMouthControls().end(), name),
                DefaultMouthControls().end()) << name;
      EXPECT_GT(weight, 0.f);
      EXPECT_LE(weight, 1.f);
    }
  }
  for (const std::string& name : DefaultMouthControls()) EXPECT_GE(rig::ArkitIndex(name), 0) << name;
}

TEST(Dominance, HeldPhoneReachesItsPoseAndSilenceIsNeutral) {
  const std::vector<std::string>& names = rig::ArkitShapeNames();
  // 0.5 s of silence, 0.6 s of "aa", 1.5 s of silence.
  std::vector<PhoneSegment> phones = {{"SIL", 0.0, 0.5, 0},
                                      {"AA", 0.5, 1.1, static_cast<int>(Viseme::kAA)},
                                      {"SIL", 1.1, 2.6, 0}};
  const Eigen::MatrixXf w = MouthFromPhones(phones, names, 78, 30., DominanceOptions());
  const int jaw = rig::ArkitIndex("jawOpen");
  EXPECT_NEAR(w(24, jaw), 0.6f, 0.1f);  // 0.8 s, the middle of the vowel
  EXPECT_LT(w(1, jaw), 0.05f);
  EXPECT_LT(w(75, jaw), 0.05f);
  EXPECT_EQ(w(24, rig::ArkitIndex("browInnerUp")), 0.f);
  EXPECT_TRUE((w.array() >= 0.f).all() && (w.array() <= 1.f).all());
}

TEST(Blend, ZeroCrossfadeIsTheVideoAndFullIsTheMouth) {
  Rng rng(3, 0);
  Eigen::MatrixXf video(20, 6), mouth(20, 6);
  for (int i = 0; i < video.size(); ++i) {
    video.data()[i] = static_cast<float>(rng.Uniform());
    mouth.data()[i] = static_cast<float>(rng.Uniform());
  }
  EXPECT_EQ(BlendControls(video, mouth, Eigen::VectorXf::Zero(6)), video);
  Eigen::VectorXf c = Eigen::VectorXf::Zero(6);
  c[1] = c[4] = 1.f;
  const Eigen::MatrixXf b = BlendControls(video, mouth, c);
  for (int s = 0; s < 6; ++s) EXPECT_EQ(b.col(s), (s == 1 || s == 4 ? mouth : video).col(s));
  c[2] = 0.25f;
  EXPECT_FLOAT_EQ(BlendControls(video, mouth, c)(3, 2), 0.75f * video(3, 2) + 0.25f * mouth(3, 2));
  EXPECT_THROW(BlendControls(video, mouth.topRows(19), c), InvalidInputError);
}

TEST(Blend, ResampleReadsTheSourceAtItsTimes) {
  // A source at 50 fps whose value is its own time; read at 25 fps 0.3 s later.
  Eigen::MatrixXf source(100, 1);
  std::vector<double> source_times(100);
  for (int i = 0; i < 100; ++i) {
    source_times[i] = i / 50.;
    source(i, 0) = static_cast<float>(source_times[i]);
  }
  std::vector<double> times;
  for (int f = 0; f < 20; ++f) times.push_back(f / 25. + 0.3);
  std::vector<char> inside;
  const Eigen::MatrixXf r = ResampleAtTimes(source, source_times, times, &inside);
  for (int f = 0; f < 20; ++f) {
    EXPECT_NEAR(r(f, 0), f / 25.f + 0.3f, 1e-5f) << f;
    EXPECT_TRUE(inside[f]);
  }
  // Held at the ends, and flagged outside.
  const Eigen::MatrixXf held = ResampleAtTimes(source, source_times, {-1., 5.}, &inside);
  EXPECT_FLOAT_EQ(held(0, 0), 0.f);
  EXPECT_FLOAT_EQ(held(1, 0), 99 / 50.f);
  EXPECT_FALSE(inside[0]);
  EXPECT_FALSE(inside[1]);
  source_times[5] = source_times[4];
  EXPECT_THROW(ResampleAtTimes(source, source_times, times), InvalidInputError);
}

TEST(Blend, CoverageFadesOutLinearlyBeyondTheSourceSpan) {
  // The source spans [1, 3] s; a fade of 0.5 s.
  const std::vector<float> s = CoverageShares({0., 0.5, 0.75, 1., 2., 3., 3.25, 3.5, 4.}, 1., 3., 0.5);
  const std::vector<float> expected = {0.f, 0.f, 0.5f, 1.f, 1.f, 1.f, 0.5f, 0.f, 0.f};
  ASSERT_EQ(s.size(), expected.size());
  for (size_t i = 0; i < s.size(); ++i) EXPECT_NEAR(s[i], expected[i], 1e-6f) << i;
  // No fade: the source counts inside its span only.
  const std::vector<float> hard = CoverageShares({0.99, 1., 3., 3.01}, 1., 3., 0.);
  EXPECT_EQ(hard, (std::vector<float>{0.f, 1.f, 1.f, 0.f}));
}

TEST(Silence, FramesFarFromSoundAreSilentAndOthersNot) {
  // 16 kHz: 0.5 s of faint noise, 1 s of a tone, 0.5 s of faint noise; frames at 25 fps to 2.4 s.
  constexpr int kRate = 16000;
  std::vector<float> samples(2 * kRate);
  Rng rng(5, 0);
  for (size_t i = 0; i < samples.size(); ++i) {
    const double t = static_cast<double>(i) / kRate;
    samples[i] = t >= 0.5 && t < 1.5 ? 0.5f * static_cast<float>(std::sin(2 * M_PI * 220 * t))
                                     : 1e-4f * static_cast<float>(rng.Normal());
  }
  std::vector<double> times;
  for (int f = 0; f < 60; ++f) times.push_back(f / 25.);
  const std::vector<char> silent = SilentFrames(samples, kRate, times, -40., 0.1);
  ASSERT_EQ(silent.size(), times.size());
  for (int f = 0; f < 60; ++f) {
    const double t = times[f];
    if (t <= 0.36 || (t >= 1.66 && t < 2.0)) {      // quiet, 0.1 s from the tone
      EXPECT_TRUE(silent[f]) << t;
    }
    if (t >= 0.48 && t <= 1.52) {                  // the tone
      EXPECT_FALSE(silent[f]) << t;
    }
    if ((t > 0.42 && t < 0.5) || (t > 1.5 && t < 1.58)) {  // within the margin
      EXPECT_FALSE(silent[f]) << t;
    }
    if (t > 2.0) {                                 // after the sound
      EXPECT_FALSE(silent[f]) << t;
    }
  }
  // Loud: the frames at 0.52-1.48 s; silent: 0-0.40 s and 1.60-2.00 s, 11 frames each.
  EXPECT_EQ(std::count(silent.begin(), silent.end(), 1), 22);
  // All-zero sound has no loud frame to be below: nothing is silent.
  const std::vector<char> none = SilentFrames(std::vector<float>(kRate, 0.f), kRate, times, -40., 0.1);
  EXPECT_EQ(std::count(none.begin(), none.end(), 1), 0);
}

TEST(Closures, FoundAndMatchedWithinTolerance) {
  std::vector<float> gaps(100, 0.1f);
  for (int f = 10; f < 14; ++f) gaps[f] = 0.f;   // centre 11.5 -> 0.383 s
  for (int f = 50; f < 52; ++f) gaps[f] = 0.f;   // centre 50.5 -> 1.683 s
  const std::vector<Closure> truth = FindClosures(gaps, 0.01f, 30.);
  ASSERT_EQ(truth.size(), 2u);
  EXPECT_NEAR(truth[0].centre_seconds, 11.5 / 30., 1e-9);
  std::vector<Closure> found = truth;
  found[0].centre_seconds += 0.03;
  found[1].centre_seconds += 0.05;  // outside 40 ms
  Closure extra;
  extra.centre_seconds = 3.;
  found.push_back(extra);
  const DetectionScore s = MatchClosures(truth, found, 0.04);
  EXPECT_EQ(s.matched, 1);
  EXPECT_NEAR(s.precision, 1. / 3., 1e-12);
  EXPECT_NEAR(s.recall, 0.5, 1e-12);
  EXPECT_NEAR(s.f1, 0.4, 1e-12);
}

TEST(Closures, DemoHeadLipsMeetAtNeutralAndPartWithTheJaw) {
  rig::DemoHeadOptions options;
  options.resolution = 60;
  const rig::Rig rig = rig::MakeDemoHead(options);
  Eigen::MatrixXf w = Eigen::MatrixXf::Zero(2, rig.NumShapes());
  w(1, rig::ArkitIndex("jawOpen")) = 0.5f;
  const std::vector<float> gaps = InnerLipGaps(rig, w);
  EXPECT_LT(std::abs(gaps[0]), 0.02f);
  EXPECT_GT(gaps[1], 0.05f);
}

TEST(Closures, LipsMayMeetAtBilabialsAndSilencesOnly) {
  const std::vector<PhoneSegment> phones = {{"SIL", 0.0, 0.2, 0},
                                            {"M", 0.2, 0.3, static_cast<int>(Viseme::kPP)},
                                            {"UW", 0.3, 0.5, static_cast<int>(Viseme::kOU)},
                                            {"F", 0.5, 0.6, static_cast<int>(Viseme::kFF)}};
  const std::vector<double> times = {0.1, 0.25, 0.3, 0.45, 0.55, 0.7};
  const std::vector<char> aligned = LipsMayMeet(phones, times, MeetRule::kBilabialsAndSilences);
  const std::vector<char> expected = {1, 1, 0, 0, 0, 1};  // silence, m, uw (from its start), f, after
  EXPECT_EQ(aligned, expected);
  const std::vector<char> free = LipsMayMeet(phones, times, MeetRule::kAllButVowels);
  const std::vector<char> only_vowels_forbid = {1, 1, 0, 0, 1, 1};
  EXPECT_EQ(free, only_vowels_forbid);
}

TEST(Closures, LipsPartOnlyWhereTheSoundForbidsAndJustEnough) {
  rig::DemoHeadOptions options;
  options.resolution = 60;
  const rig::Rig rig = rig::MakeDemoHead(options);
  const int jaw = rig::ArkitIndex("jawOpen");
  Eigen::MatrixXf w = Eigen::MatrixXf::Zero(3, rig.NumShapes());
  w(2, jaw) = 0.5f;  // already open
  const Eigen::MatrixXf before = w;
  const std::vector<char> may = {1, 0, 0};
  const int parted = PartLipsWhereSoundForbids(rig, may, kLipsMeetGap, 0.03f, &w);
  EXPECT_EQ(parted, 1);
  EXPECT_EQ(w.row(0), before.row(0));  // a closure the sound allows stays
  EXPECT_EQ(w.row(2), before.row(2));  // open lips stay
  const std::vector<float> gaps = InnerLipGaps(rig, w);
  EXPECT_GE(gaps[1], 0.03f);
  EXPECT_LT(gaps[1], 0.035f);          // the least jawOpen that opens them
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (s != jaw) {
      EXPECT_EQ(w(1, s), before(1, s));
    }
  }
  Eigen::MatrixXf wrong = Eigen::MatrixXf::Zero(2, rig.NumShapes());
  EXPECT_THROW(PartLipsWhereSoundForbids(rig, may, kLipsMeetGap, 0.03f, &wrong), InvalidInputError);
}

// Bursts of noise with random loudness: the same recording delayed by a known time.
TEST(AudioAlign, RecoversAKnownOffset) {
  const int rate = 16000;
  Rng rng(11, 0);
  std::vector<float> a(rate * 4, 0.f);
  double t = 0.1;
  while (t < 3.8) {
    const int begin = static_cast<int>(t * rate), length = static_cast<int>(rng.Uniform(0.05, 0.2) * rate);
    const double loud = rng.Uniform(0.1, 0.8);
    for (int i = begin; i < std::min<int>(begin + length, a.size()); ++i) a[i] = static_cast<float>(loud * rng.Normal());
    t += rng.Uniform(0.1, 0.4);
  }
  for (double shift_ms : {137., -64., 0.}) {
    const int shift = static_cast<int>(std::lround(shift_ms * rate / 1000.));
    std::vector<float> b(a.size(), 0.f);
    for (int i = 0; i < static_cast<int>(a.size()); ++i) {
      const int j = i - shift;
      if (j >= 0 && j < static_cast<int>(a.size())) b[i] = a[j] + 0.01f * static_cast<float>(rng.Normal());
    }
    const AlignResult r = EstimateOffset(a, b, rate, AlignOptions());
    EXPECT_NEAR(r.offset_seconds * 1000., shift_ms, 5.) << shift_ms;
    EXPECT_GT(r.peak, 0.5);
  }
  EXPECT_THROW(EstimateOffset(std::vector<float>(100), a, rate, AlignOptions()), InvalidInputError);
}

}  // namespace
}  // namespace facecap::lipsync
