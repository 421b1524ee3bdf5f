// facecap lipsync blend | audio and eval lipsync (lipsync track is track_stage.h's):
//   lipsync blend: the mouth controls of a second source (a frontal lip video solved by
//     lipsync track, or lipsync audio's track) cross-faded into the video's solve, the source
//     aligned in time by the sound of both videos (or offset_seconds); pose and every other
//     control stay the video's; writes a track file.
//   lipsync audio: a mouth source from the video's own sound: phones recognized offline by
//     pocketsphinx (freely, or aligned to a transcript), mapped to visemes and to the rig's
//     ARKit mouth controls through dominance-function coarticulation; a track file for
//     lipsync blend.
//   eval lipsync: mouth and upper-face control errors, pose error and lip-closure detection of
//     tracks against a talking clip's truth, beside the neutral mouth; one JSON object.
#ifndef FACECAP_STAGES_LIPSYNC_STAGE_H_
#define FACECAP_STAGES_LIPSYNC_STAGE_H_

#include <string>
#include <vector>

#include "io/config.h"
#include "lipsync/phone_recognizer.h"
#include "lipsync/speech_track.h"
#include "lipsync/visemes.h"
#include "stages/stage.h"

namespace facecap::stages {

// [lipsync.blend]
struct LipsyncBlendOptions {
  std::string track = "track.h5";    // the video's solve
  std::string mouth = "mouth.h5";    // the mouth source's track
  std::string out = "blended.h5";    // the blended track
  std::string video = "";            // the video with its sound (alignment)
  std::string mouth_video = "";      // the mouth source's video with its sound (alignment)
  double offset_seconds = 0.;        // without the two videos: the mouth source's delay
  double max_offset_seconds = 2.;    // alignment searches [-max, max]
  std::vector<std::string> mouth_controls = lipsync::DefaultMouthControls();
  std::vector<float> crossfade = {1.f};  // one for every mouth control, or one each
  double edge_fade_seconds = 1.;     // the mouth source's share fades to 0 beyond its span

  template <class V>
  void Visit(V&& v) {
    v("track", track, "the video's solve (track.h5 from track)");
    v("mouth", mouth, "the mouth source's track (lipsync track of a lip video)");
    v("out", out, "the blended track (HDF5; every export and eval takes it)");
    v("video", video,
      "the tracked video, with sound: with mouth_video, the offset is measured from the two "
      "sound tracks (empty: offset_seconds)");
    v("mouth_video", mouth_video, "the mouth source's video, with the same sound");
    v("offset_seconds", offset_seconds,
      "without the two videos: how much later the mouth source's clock runs (s)");
    v("max_offset_seconds", max_offset_seconds, "the alignment searches offsets up to this (s)");
    v("mouth_controls", mouth_controls, "the controls taken from the mouth source, by name");
    v("crossfade", crossfade,
      "per mouth control, the mouth source's share in [0, 1] (one value: every control)");
    v("edge_fade_seconds", edge_fade_seconds,
      "before the mouth source's first frame and after its last, its end frames are held and "
      "their share falls linearly to 0 over this many seconds (0: the video's solve at once)");
  }
  bool Check(std::string* why) const {
    if (crossfade.size() != 1 && crossfade.size() != mouth_controls.size()) {
      *why = "crossfade needs one value or one per mouth control (" +
             std::to_string(mouth_controls.size()) + "), got " + std::to_string(crossfade.size());
      return false;
    }
    for (float c : crossfade) {
      if (!(c >= 0.f && c <= 1.f)) { *why = "crossfade values must be in [0, 1]"; return false; }
    }
    if (video.empty() != mouth_video.empty()) {
      *why = "video and mouth_video go together (the offset from both sound tracks)";
      return false;
    }
    if (!(max_offset_seconds > 0.)) { *why = "max_offset_seconds must be positive"; return false; }
    if (!(edge_fade_seconds >= 0.)) { *why = "edge_fade_seconds must be 0 or more"; return false; }
    return true;
  }
};

// Runs lipsync blend on rank 0, inside a collective exception check (every rank calls it).
// The summary counts the blended track's frames, all written by this run (other ranks: 0).
StageSummary RunLipsyncBlend(const LipsyncBlendOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

// [lipsync.audio]
struct LipsyncAudioOptions {
  std::string video = "video.mp4";   // the video whose sound is spoken
  std::string rig = "rig.h5";        // the rig whose mouth controls are written
  std::string out = "mouth_audio.h5";
  std::string transcript = "";       // the words spoken, when known
  double fps = 30.;                  // frames per second of the mouth track
  std::string model_dir = lipsync::RecognizerOptions().model_dir;
  lipsync::DominanceOptions dominance;

  template <class V>
  void Visit(V&& v) {
    v("video", video, "the video (or audio file) whose sound is the speech");
    v("rig", rig, "the rig whose mouth controls the track names (person fit's rig)");
    v("out", out, "the mouth track (HDF5) for lipsync blend");
    v("transcript", transcript,
      "the words spoken, when known: aligned to the sound with a grammar of exactly these "
      "words (empty: phones recognized freely)");
    v("fps", fps, "frames per second of the mouth track");
    v("model_dir", model_dir, "pocketsphinx's English model folder (Debian: pocketsphinx-en-us)");
    v("kappa", dominance.kappa, "exponent of the dominance functions");
    v("hold", dominance.hold, "middle fraction of a phone where its dominance is full");
    v("spread", dominance.spread, "a phone's dominance reaches this fraction of its duration further");
    v("tau0", dominance.tau0, "seconds added to every phone's dominance reach");
    v("amplitude", dominance.amplitude, "scale of the visemes' mouth poses");
  }
  bool Check(std::string* why) const {
    if (!(fps > 0. && fps <= 1000.)) { *why = "fps must be in (0, 1000]"; return false; }
    if (!(dominance.kappa > 0.f) || !(dominance.spread >= 0.f) || !(dominance.tau0 > 0.f) ||
        !(dominance.hold >= 0.f && dominance.hold <= 1.f) || !(dominance.amplitude >= 0.f)) {
      *why = "kappa and tau0 must be positive, spread and amplitude >= 0, hold in [0, 1]";
      return false;
    }
    return true;
  }
};

// Runs lipsync audio on rank 0, inside a collective exception check (every rank calls it).
// The summary counts the mouth track's frames, all written by this run (other ranks: 0).
StageSummary RunLipsyncAudio(const LipsyncAudioOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

// [eval.lipsync]
struct EvalLipsyncOptions {
  std::string truth = "clip.h5";        // the talking clip (synth clip with speech)
  std::vector<std::string> tracks;      // tracks of its video to score
  std::vector<std::string> names;       // their row names
  std::vector<std::string> mouth_controls = lipsync::DefaultMouthControls();
  float closure_gap = lipsync::kLipsMeetGap;            // lips closed at an inner gap at most this (IOD)
  double closure_tolerance_seconds = 0.04;
  bool json = true;
  std::string out = "";
  std::string gaps = "";

  template <class V>
  void Visit(V&& v) {
    v("truth", truth, "the talking clip (synth clip with speech): true weights, poses and rig");
    v("tracks", tracks, "track files of the clip's video to score");
    v("names", names, "a row name per track (empty: the file names)");
    v("mouth_controls", mouth_controls, "the controls scored as the mouth");
    v("closure_gap", closure_gap,
      "the lips are closed when their inner gap is at most this, in inter-ocular distances "
      "(the truth's rig at each row's weights)");
    v("closure_tolerance_seconds", closure_tolerance_seconds,
      "a found closure counts when its centre is this close to a true one's");
    v("json", json, "print one JSON object (false: a table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
    v("gaps", gaps,
      "also write every row's inner lip gap per frame, beside the truth's, to this CSV "
      "(row,frame,source_index,seconds,truth_gap,gap; IOD) (empty: none)");
  }
  bool Check(std::string* why) const {
    if (tracks.empty()) { *why = "tracks names no track to score"; return false; }
    if (!names.empty() && names.size() != tracks.size()) {
      *why = "names needs one name per track";
      return false;
    }
    if (!(closure_gap > 0.f)) { *why = "closure_gap must be positive"; return false; }
    if (!(closure_tolerance_seconds > 0.)) { *why = "closure_tolerance_seconds must be positive"; return false; }
    return true;
  }
};

// Runs eval lipsync on rank 0 (the other ranks return at once); the summary counts the JSON
// file, with unit "files": 1 when the JSON was written to `out`, 0 when out is empty.
StageSummary RunEvalLipsync(const EvalLipsyncOptions& options, const StageContext& ctx,
                            const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_LIPSYNC_STAGE_H_
