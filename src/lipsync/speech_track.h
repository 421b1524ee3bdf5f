// From phones to mouth controls, and what is done with mouth controls (paper 000 Sec. 8.1):
//   - phones with times -> per-frame ARKit mouth controls by a coarticulation model of
//     dominance functions (Cohen and Massaro 1993): each phone i pulls the mouth towards its
//     viseme's pose with a dominance D_i(t) = alpha_v exp(-(d_i(t) / tau_i)^kappa), full over
//     the middle `hold` fraction of the phone and falling off outside it (d_i is the distance
//     of t from that middle part), tau_i = spread * duration_i + tau_0, and the mouth at time
//     t is the dominance-weighted mean of the poses of all phones;
//   - a mouth source resampled onto the video's frames, with the offset between them;
//   - the blend of a video solve and a mouth source, per control;
//   - lip closures (the inner lips meeting) and their detection score.
#ifndef FACECAP_LIPSYNC_SPEECH_TRACK_H_
#define FACECAP_LIPSYNC_SPEECH_TRACK_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::lipsync {

// One phone of an utterance: its name (any alphabet), start and end in seconds, and its
// viseme (lipsync::Viseme as int).
struct PhoneSegment {
  std::string phone;
  double start = 0.;
  double end = 0.;
  int viseme = 0;
};

// The dominance functions' shape.
struct DominanceOptions {
  float kappa = 1.f;      // exponent of the dominance (1: Cohen and Massaro's exponential)
  float hold = 0.5f;      // the middle fraction of a phone where its dominance is full
  float spread = 0.15f;   // tau grows with the phone's duration by this factor
  float tau0 = 0.03f;     // seconds added to every tau
  float silence_alpha = 0.4f;     // dominance magnitude of silence (the neutral mouth)
  float closure_alpha = 1.f;      // of PP and FF (lips must meet or touch the teeth)
  float consonant_alpha = 0.5f;   // of the other consonants
  float vowel_alpha = 0.7f;       // of vowels
  float amplitude = 1.f;          // scale of every viseme pose
};

// Per-frame weights (frames x #shapes of `shape_names`, frame f at time f / fps) of the mouth
// controls that the visemes' poses name; other shapes stay 0. Phones are given in seconds of
// the same clock. Weights are clamped to [0, 1].
Eigen::MatrixXf MouthFromPhones(const std::vector<PhoneSegment>& phones,
                                const std::vector<std::string>& shape_names, int frames, double fps,
                                const DominanceOptions& options);

// Rows of `source` (at the ascending `source_times`, seconds) linearly interpolated at
// `times`; a time outside [first, last] source time gets the nearest end row, and
// (*inside)[i] = 0 for it when inside is given. InvalidInputError when the sizes differ or
// the source times are not ascending.
Eigen::MatrixXf ResampleAtTimes(const Eigen::MatrixXf& source, const std::vector<double>& source_times,
                                const std::vector<double>& times, std::vector<char>* inside = nullptr);

// The mouth source's share at each of `times` (seconds on its clock): 1 within [first, last],
// falling linearly to 0 at fade_seconds beyond either end (fade_seconds 0: 0 outside).
std::vector<float> CoverageShares(const std::vector<double>& times, double first, double last,
                                  double fade_seconds);

// (1 - c_s) video(:, s) + c_s mouth(:, s) for each shape s, c = crossfade (#shapes, in [0, 1]).
Eigen::MatrixXf BlendControls(const Eigen::MatrixXf& video, const Eigen::MatrixXf& mouth,
                              const Eigen::VectorXf& crossfade);

// The indices of `names` in `shape_names` (names that are not there are skipped).
std::vector<int> ShapeIndices(const std::vector<std::string>& shape_names,
                              const std::vector<std::string>& names);

// The inner-lip gap of each frame: the mean vertical distance between the inner upper lip
// (iBUG landmarks 61-63) and the inner lower lip (65-67) of the rig at the frame's weights,
// in units of the rig's inter-ocular distance (outer eye corners 36, 45 at the neutral).
std::vector<float> InnerLipGaps(const rig::Rig& rig, const Eigen::MatrixXf& weights);

// The inner-lip gap (IOD) at or below which the lips meet: a closure.
inline constexpr float kLipsMeetGap = 0.01f;

// Which phones the lips may meet in: with phones aligned to a transcript, only bilabials (viseme
// PP: p, b, m) and silences (in any other phone the mouth sounds a vowel or a consonant the
// lips do not close for); with phones recognized freely, whose consonants are often confused
// with one another (a heard t may be a p), every phone but a vowel (visemes AA, E, IH, OH, OU).
enum class MeetRule { kBilabialsAndSilences, kAllButVowels };

// Frames (at `times`, seconds on the phones' clock) where the sound lets the lips meet by
// `rule`; a frame outside every phone may.
std::vector<char> LipsMayMeet(const std::vector<PhoneSegment>& phones, const std::vector<double>& times,
                              MeetRule rule);

// Parts the lips of every frame where they meet (inner-lip gap at most meet_gap, in IOD, the rig
// at the frame's weights) but may_meet says they may not: jawOpen is raised by the least amount
// (to within 1e-3) that opens the gap to open_gap, or to 1 when that does not. weights: frames
// x the rig's shapes. Returns the frames changed. InvalidInputError when the rig has no jawOpen
// or the sizes differ.
int PartLipsWhereSoundForbids(const rig::Rig& rig, const std::vector<char>& may_meet, float meet_gap,
                              float open_gap, Eigen::MatrixXf* weights);

// A lip closure: a run of frames whose lip gap is at most a threshold; its centre in seconds.
struct Closure {
  int begin = 0, end = 0;  // frames [begin, end)
  double centre_seconds = 0.;
};
std::vector<Closure> FindClosures(const std::vector<float>& gaps, float threshold, double fps,
                                  int min_frames = 1);

// Detection of closures: a found closure matches a true one when their centres are within
// tolerance_seconds (each matched once, greedily by distance).
struct DetectionScore {
  int truth = 0, found = 0, matched = 0;
  double precision = 0., recall = 0., f1 = 0.;
};
DetectionScore MatchClosures(const std::vector<Closure>& truth, const std::vector<Closure>& found,
                             double tolerance_seconds);

}  // namespace facecap::lipsync

#endif  // FACECAP_LIPSYNC_SPEECH_TRACK_H_
