// What lipsync track does to the lip video's solve after solving it, frame by frame:
// - the rest calibration: where the lip video's sound is silent the mouth is at rest, so the
//   controls the solve holds there are what the translation of a resting mouth asks for, not
//   motion. Their median over the silent frames is subtracted from every frame (clamped to
//   [0, 1]), as a capture is zeroed on the actor's neutral;
// - a running median over a few frames per control: a control that moves for one frame
//   against both neighbours (the lips parting for a frame inside a closure) is the
//   translation's flicker; a closure of two frames stays;
// - the lips part where the sound says they cannot meet: in the sound's phones (pocketsphinx,
//   aligned to a transcript when one is given, else recognized freely) a frame whose lips meet
//   (a barely open mouth that the blurred lip video draws closed) gets the least jawOpen that
//   parts them when it lies in a vowel, or, with a transcript, in any phone but a bilabial
//   (p, b, m) or a silence (lipsync::MeetRule).
#ifndef FACECAP_STAGES_LIP_TRACK_FILTER_H_
#define FACECAP_STAGES_LIP_TRACK_FILTER_H_

#include <string>

#include "lipsync/phone_recognizer.h"

namespace facecap::stages {

struct LipTrackFilterOptions {
  bool rest_calibration = true;      // subtract the controls held at the silent frames
  std::string sound = "";            // the lip video with its sound (empty: the frames file's source)
  double silence_db = -40.;          // silent: the frame's sound this far below the loudest frame's
  double rest_margin_seconds = 0.1;  // and no louder frame this close
  int median_frames = 3;             // running median window (1: none)
  bool part_lips = true;             // part the lips where the sound's phones forbid a closure
  std::string transcript = "";       // the lip video's words, when known
  std::string model_dir = lipsync::RecognizerOptions().model_dir;

  template <class V>
  void Visit(V&& v) {
    v("rest_calibration", rest_calibration,
      "zero the solve on the mouth at rest: the median of every control over the frames where "
      "the lip video's sound is silent is subtracted from every frame (clamped to [0, 1])");
    v("sound", sound,
      "the lip video (or any file ffmpeg reads) whose sound tells the silent frames and the "
      "phones (empty: the video that frames was ingested from, its path as ingest recorded it)");
    v("silence_db", silence_db, "a frame is silent when its sound is this many dB below the loudest frame's");
    v("rest_margin_seconds", rest_margin_seconds,
      "and when no louder frame is this close (the mouth moves before and after a sound)");
    v("median_frames", median_frames,
      "then a running median of every control over this many frames, odd (1: none): removes a "
      "one-frame flicker and keeps a closure of two frames (the solve's own weights stay in "
      "/track/weights_solved)");
    v("part_lips", part_lips,
      "then part the lips where the sound's phones say they cannot meet: a frame whose inner lips "
      "meet (gap at most 0.01 IOD) in a vowel, or with a transcript in any phone but a bilabial "
      "(p, b, m) or a silence, gets the least jawOpen that opens them to 0.02 IOD");
    v("transcript", transcript,
      "the words the lip video speaks, when known: its phones are aligned to them (empty: phones "
      "recognized freely, which may hear a closing m or b as a vowel and part closed lips; give "
      "the words where they are known)");
    v("model_dir", model_dir, "pocketsphinx's English model folder (Debian: pocketsphinx-en-us)");
  }
  bool Check(std::string* why) const;
};

// Filters the track file `track` (solved with the rig file `rig`) in place (atomically: a copy beside it, then a rename), from
// its /track/weights_solved when an earlier filtering wrote one, so that a rerun gives the same
// file. `frames` is the ingest output the track was solved from (empty: none). Without a sound
// (none given and the source video has none), or with fewer than 3 silent solved frames, the
// calibration is skipped with a warning, as is the parting without a sound or when free
// recognition finds no phone in it; a sound given that cannot be read is a FileIOError, a
// transcript the sound cannot be aligned to an InvalidInputError.
// Runs on the calling rank alone.
void FilterLipTrack(const std::string& track, const std::string& frames, const std::string& rig,
                    const LipTrackFilterOptions& o);

// Before the solve, so that bad input fails the stage before it writes anything: a sound given
// (o.sound, with the calibration or the parting on) must be readable (FileIOError naming the
// file), and with the parting on the phone recognizer's model must be there (FileIOError) and
// every word of the transcript in its dictionary (InvalidInputError).
void CheckLipTrackSound(const LipTrackFilterOptions& o);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_LIP_TRACK_FILTER_H_
