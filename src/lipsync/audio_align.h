// The offset between two recordings of the same sound (a lip-sync source and the main video):
// the cross-correlation of their onset envelopes (the positive change of log energy in short
// frames), refined to below a frame by a parabola through the peak.
#ifndef FACECAP_LIPSYNC_AUDIO_ALIGN_H_
#define FACECAP_LIPSYNC_AUDIO_ALIGN_H_

#include <vector>

namespace facecap::lipsync {

struct AlignOptions {
  double hop_seconds = 0.005;     // envelope frame step
  double window_seconds = 0.02;   // envelope frame length
  double max_offset_seconds = 2.; // offsets searched: [-max, max]
};

// Onset envelope of mono samples at `rate` Hz: one value per hop, zero-mean, unit variance.
std::vector<float> OnsetEnvelope(const std::vector<float>& samples, int rate,
                                 const AlignOptions& options);

struct AlignResult {
  double offset_seconds = 0.;  // b's sound happens this much later than a's
  double peak = 0.;            // normalized cross-correlation at the offset, in [-1, 1]
};
// The offset of b against a (both mono at `rate`). InvalidInputError when either is shorter
// than a few windows.
AlignResult EstimateOffset(const std::vector<float>& a, const std::vector<float>& b, int rate,
                           const AlignOptions& options);

// Mono samples from `from_rate` to `to_rate` Hz: windowed-sinc interpolation low-passed below
// half the lower rate.
std::vector<float> ResampleAudio(const std::vector<float>& samples, int from_rate, int to_rate);

// The frames at `times` (seconds) when the sound is silent: the RMS of the samples over one
// frame interval (the median step of `times`) around the frame is at least `silence_db` below
// the loudest frame's, and no louder frame is within `margin_seconds`. A frame outside the
// sound is not silent. All-silent sound (no frame above the threshold) gives no silent frames.
std::vector<char> SilentFrames(const std::vector<float>& samples, int rate, const std::vector<double>& times,
                               double silence_db, double margin_seconds);

}  // namespace facecap::lipsync

#endif  // FACECAP_LIPSYNC_AUDIO_ALIGN_H_
