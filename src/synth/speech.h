// A talking person for lip-sync truth (paper 000 Sec. 8.1): espeak-ng speaks a text to audio
// with the time of every phone, and a speaker's coarticulation turns the phones into the
// mouth controls of the performance.
//
// The speaker's coarticulation is deliberately another model than the dominance functions
// that facecap's audio-only mouth source uses (lipsync/speech_track.h), with its own mouth
// pose for each viseme, so that scoring that source against this truth is not circular: each
// phone's viseme pose is held over a raised-cosine window that opens `lead` before the phone
// and closes `lag` after it, windows are mixed by priority (lip closures first, then vowels,
// then other consonants), the mix is smoothed by a forward-backward exponential filter, and
// each person has their own lead, lag, smoothing, overall amplitude and per-control gains
// (from the identity seed).
#ifndef FACECAP_SYNTH_SPEECH_H_
#define FACECAP_SYNTH_SPEECH_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "lipsync/speech_track.h"
#include "rig/rig.h"
#include "synth/clip.h"

namespace facecap::synth {

struct SpeechAudio {
  int rate = 22050;                            // samples per second
  std::vector<float> samples;                  // mono, [-1, 1]
  std::vector<lipsync::PhoneSegment> phones;   // IPA names, seconds from the audio's start
};

// espeak-ng speaks `text` (UTF-8) with `voice` (an espeak-ng voice name: "en", "en-us",
// "en+f3", ...). InvalidInputError for an unknown voice or an empty text. Thread-safe
// (each utterance is spoken by a child process); the same text and voice give the same samples.
SpeechAudio Speak(const std::string& text, const std::string& voice);

// Shifts every phone by `seconds` (where the speech starts in a clip).
std::vector<lipsync::PhoneSegment> ShiftPhones(std::vector<lipsync::PhoneSegment> phones,
                                               double seconds);

// A person's way of articulating.
struct SpeakerStyle {
  float lead_seconds = 0.04f;      // the mouth moves towards a phone this much before it
  float lag_seconds = 0.025f;      // and leaves it this much after
  float smoothing_seconds = 0.025f;  // time constant of the forward-backward smoothing
  float amplitude = 1.f;           // scale of every pose
  Eigen::VectorXf gains;           // per mouth control of lipsync::DefaultMouthControls()
};
// The style of person `identity_seed` (0: the mean style, all gains 1).
SpeakerStyle SpeakerStyleOf(int identity_seed);

// The mouth controls (frames x #shape_names; shapes outside the mouth group 0) of a person
// with `style` speaking `phones` (seconds of the clip's clock), frame f at f / fps.
Eigen::MatrixXf SpeakerMouth(const std::vector<lipsync::PhoneSegment>& phones,
                             const std::vector<std::string>& shape_names, int frames, double fps,
                             const SpeakerStyle& style);

// Makes a clip's performance a talking one: the mouth controls (lipsync::DefaultMouthControls)
// of every frame become the speaker's mouth for `phones`; the rest of the performance (upper
// face, jaw sideways, head motion, blinks) is kept. With `lips_view`, the performance is the
// one a frontal lip-sync source shows: the head frontal and still (no rotation, no offset) and
// every control outside the mouth group at the neutral.
void ApplySpeech(const rig::Rig& rig, const std::vector<lipsync::PhoneSegment>& phones,
                 const SpeakerStyle& style, double fps, bool lips_view,
                 std::vector<ClipFrameParams>* frames);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_SPEECH_H_
