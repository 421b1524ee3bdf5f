// Visemes: the mouth shapes of speech (paper 000 Sec. 8.1 blends a mouth-only solve into the
// video's). Phones of two alphabets map onto one set of 15 visemes (the set of the common
// real-time lip-sync runtimes: silence, PP, FF, TH, DD, kk, CH, SS, nn, RR, aa, E, ih, oh,
// ou), and each viseme is a pose of the rig's ARKit mouth controls:
//   - ARPAbet, the 39 phones of CMU's dictionary and pocketsphinx's English model, plus its
//     silence and filler units (SIL, +NSN+, +SPN+, ...), all silence;
//   - IPA, as espeak-ng reports the phones it speaks (stress and length marks ignored).
#ifndef FACECAP_LIPSYNC_VISEMES_H_
#define FACECAP_LIPSYNC_VISEMES_H_

#include <string>
#include <utility>
#include <vector>

namespace facecap::lipsync {

enum class Viseme : int {
  kSilence = 0, kPP, kFF, kTH, kDD, kKK, kCH, kSS, kNN, kRR, kAA, kE, kIH, kOH, kOU
};
inline constexpr int kNumVisemes = 15;

const char* VisemeName(Viseme v);

// The viseme of an ARPAbet phone (case-insensitive, a trailing stress digit ignored); silence
// for SIL and filler units (names in '+' or '<'); -1 as an int for any other name.
int VisemeOfArpabet(const std::string& phone);

// The viseme of an IPA phone as espeak-ng writes it (UTF-8; stress marks, length marks and
// tie bars ignored; diphthongs by their first vowel); -1 for a phone it does not know.
int VisemeOfIpa(const std::string& phone);

// The viseme's pose: (ARKit control name, weight in [0, 1]) pairs; every control not listed
// is 0. Silence is the neutral (empty).
const std::vector<std::pair<std::string, float>>& VisemePose(Viseme v);

// The ARKit controls of the mouth group: jawOpen and the 23 mouth* controls, the controls a
// mouth-only solve frees and a blend takes from the mouth source.
const std::vector<std::string>& DefaultMouthControls();

}  // namespace facecap::lipsync

#endif  // FACECAP_LIPSYNC_VISEMES_H_
