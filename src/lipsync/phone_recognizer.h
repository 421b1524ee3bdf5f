// Phones from speech, offline: pocketsphinx (Debian's pocketsphinx with its US English
// acoustic model, pocketsphinx-en-us) recognizes ARPAbet phones with their times, either
// freely (its phone language model) or, when the transcript is known, by aligning the
// transcript's words (a grammar of exactly those words, CMU's dictionary for their phones).
#ifndef FACECAP_LIPSYNC_PHONE_RECOGNIZER_H_
#define FACECAP_LIPSYNC_PHONE_RECOGNIZER_H_

#include <string>
#include <vector>

#include "lipsync/speech_track.h"

namespace facecap::lipsync {

struct RecognizerOptions {
  // The model folder (holding en-us/, en-us-phone.lm.bin and cmudict-en-us.dict).
  std::string model_dir = "/usr/share/pocketsphinx/model/en-us";
  // The words spoken, when known ("": recognize phones freely).
  std::string transcript;
};

// The sample rate the recognizer needs.
inline constexpr int kRecognizerRate = 16000;

// Phones (ARPAbet names, visemes set) of mono 16 kHz speech, in seconds from its start;
// silences and fillers as SIL. FileIOError when the model is missing; InvalidInputError for a
// transcript word the dictionary lacks.
std::vector<PhoneSegment> RecognizePhones(const std::vector<float>& samples,
                                          const RecognizerOptions& options);

// What RecognizePhones checks before decoding: the model's files are there (FileIOError), and
// every word of a transcript is in its dictionary (InvalidInputError).
void CheckRecognizerOptions(const RecognizerOptions& options);

// The ARPAbet phones (and fillers) of the acoustic model's phone set, read from its model
// definition; FileIOError when it cannot be read.
std::vector<std::string> ModelPhones(const std::string& model_dir);

}  // namespace facecap::lipsync

#endif  // FACECAP_LIPSYNC_PHONE_RECOGNIZER_H_
