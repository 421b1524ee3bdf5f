// Audio files: 16-bit PCM WAV written and read here; the sound track of any video or audio
// file decoded through the ffmpeg program (Debian's ffmpeg), and a WAV muxed into an mp4 as
// its sound track.
#ifndef FACECAP_IO_AUDIO_H_
#define FACECAP_IO_AUDIO_H_

#include <string>
#include <vector>

namespace facecap::io {

struct Audio {
  int rate = 0;                // samples per second
  std::vector<float> samples;  // mono, [-1, 1]
};

// Writes mono 16-bit PCM WAV atomically (samples clipped to [-1, 1]). OutputError naming the
// file on failure.
void WriteWav(const std::string& path, const Audio& audio);

// Reads a 16-bit PCM WAV (channels averaged). FileIOError naming the file when it is missing,
// not RIFF/WAVE, or not 16-bit PCM.
Audio ReadWav(const std::string& path);

// The sound track of `path` (any format ffmpeg reads), mono at `rate` Hz. FileIOError naming
// the file when it cannot be read or has no sound track, or when ffmpeg is not installed.
Audio DecodeAudio(const std::string& path, int rate);

// Writes `out` (an mp4) with the video stream of `video` and `wav` as its AAC sound track, cut
// to the video's length; atomic (a temporary beside `out`, then a rename). `out` may equal
// `video`. OutputError on failure.
void MuxAudio(const std::string& video, const std::string& wav, const std::string& out);

}  // namespace facecap::io

#endif  // FACECAP_IO_AUDIO_H_
