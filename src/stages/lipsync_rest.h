// The rest calibration of a lip video's solve (lipsync track): where the lip video's sound is
// silent the mouth is at rest, so the controls the solve holds there are what the translation
// of a resting mouth asks for, not motion. Their median over the silent frames is subtracted
// from every frame (clamped to [0, 1]), as a capture is zeroed on the actor's neutral.
#ifndef FACECAP_STAGES_LIPSYNC_REST_H_
#define FACECAP_STAGES_LIPSYNC_REST_H_

#include <string>

namespace facecap::stages {

struct RestCalibrationOptions {
  bool rest_calibration = true;  // subtract the controls held at the silent frames
  std::string sound = "";        // the lip video with its sound (empty: the frames file's source)
  double silence_db = -40.;      // silent: the frame's sound this far below the loudest frame's
  double rest_margin_seconds = 0.1;  // and no louder frame this close

  template <class V>
  void Visit(V&& v) {
    v("rest_calibration", rest_calibration,
      "zero the solve on the mouth at rest: the median of every control over the frames where "
      "the lip video's sound is silent is subtracted from every frame (clamped to [0, 1]); the "
      "solve's own weights stay in /track/weights_solved");
    v("sound", sound,
      "the lip video (or any file ffmpeg reads) whose sound tells the silent frames (empty: the "
      "video that frames was ingested from)");
    v("silence_db", silence_db, "a frame is silent when its sound is this many dB below the loudest frame's");
    v("rest_margin_seconds", rest_margin_seconds,
      "and when no louder frame is this close (the mouth moves before and after a sound)");
  }
  bool Check(std::string* why) const;
};

// Calibrates the track file `track` in place (atomically: a copy beside it, then a rename),
// from its /track/weights_solved when a calibration wrote one, so that a rerun gives the same
// file. `frames` is the ingest output the track was solved from (empty: none). Without a
// sound (none given and the source video has none), or with fewer than 3 silent solved
// frames, warns and leaves the track as solved; a sound given that cannot be read is a
// FileIOError.
// Runs on the calling rank alone.
void CalibrateRest(const std::string& track, const std::string& frames, const RestCalibrationOptions& o);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_LIPSYNC_REST_H_
