#include "io/audio.h"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "io/atomic_file.h"
#include "util/errors.h"

namespace facecap::io {
namespace {

void PutU32(std::string* s, uint32_t v) {
  for (int i = 0; i < 4; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void PutU16(std::string* s, uint16_t v) {
  s->push_back(static_cast<char>(v & 0xFF));
  s->push_back(static_cast<char>(v >> 8));
}
uint32_t GetU32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}
uint16_t GetU16(const std::string& s, size_t at) {
  return static_cast<uint16_t>(static_cast<unsigned char>(s[at]) |
                               (static_cast<unsigned char>(s[at + 1]) << 8));
}

// A path quoted for /bin/sh.
std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out.push_back(c);
  }
  return out + "'";
}

bool HaveFfmpeg() { return std::system("command -v ffmpeg >/dev/null 2>&1") == 0; }

}  // namespace

void WriteWav(const std::string& path, const Audio& audio) {
  if (audio.rate <= 0) throw OutputError(path + ": cannot write a WAV at " + std::to_string(audio.rate) + " Hz");
  std::string data;
  data.reserve(audio.samples.size() * 2);
  for (float x : audio.samples) {
    const int v = static_cast<int>(std::lround(std::clamp(x, -1.f, 1.f) * 32767.f));
    PutU16(&data, static_cast<uint16_t>(static_cast<int16_t>(v)));
  }
  std::string s = "RIFF";
  PutU32(&s, static_cast<uint32_t>(36 + data.size()));
  s += "WAVEfmt ";
  PutU32(&s, 16);
  PutU16(&s, 1);  // PCM
  PutU16(&s, 1);  // mono
  PutU32(&s, static_cast<uint32_t>(audio.rate));
  PutU32(&s, static_cast<uint32_t>(audio.rate * 2));
  PutU16(&s, 2);
  PutU16(&s, 16);
  s += "data";
  PutU32(&s, static_cast<uint32_t>(data.size()));
  s += data;
  WriteFileAtomically(path, s);
}

Audio ReadWav(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileIOError(path + ": cannot open the WAV file");
  const std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (s.size() < 12 || s.compare(0, 4, "RIFF") != 0 || s.compare(8, 4, "WAVE") != 0) {
    throw FileIOError(path + ": not a RIFF/WAVE file");
  }
  int channels = 0, bits = 0, format = 0;
  Audio audio;
  size_t at = 12;
  while (at + 8 <= s.size()) {
    const std::string id = s.substr(at, 4);
    const uint32_t size = GetU32(s, at + 4);
    const size_t body = at + 8;
    if (body + size > s.size()) throw FileIOError(path + ": chunk '" + id + "' runs past the end of the file");
    if (id == "fmt " && size >= 16) {
      format = GetU16(s, body);
      channels = GetU16(s, body + 2);
      audio.rate = static_cast<int>(GetU32(s, body + 4));
      bits = GetU16(s, body + 14);
    } else if (id == "data") {
      if (format != 1 || bits != 16 || channels < 1 || audio.rate <= 0) {
        throw FileIOError(path + ": only 16-bit PCM WAV is read (format " + std::to_string(format) +
                          ", " + std::to_string(bits) + " bits, " + std::to_string(channels) +
                          " channels)");
      }
      const size_t frames = size / (2 * channels);
      audio.samples.resize(frames);
      for (size_t i = 0; i < frames; ++i) {
        float sum = 0.f;
        for (int c = 0; c < channels; ++c) {
          sum += static_cast<int16_t>(GetU16(s, body + 2 * (i * channels + c))) / 32768.f;
        }
        audio.samples[i] = sum / channels;
      }
      return audio;
    }
    at = body + size + (size & 1);
  }
  throw FileIOError(path + ": no fmt and data chunks (not a WAV file?)");
}

Audio DecodeAudio(const std::string& path, int rate) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw FileIOError(path + ": no such file");
  if (!HaveFfmpeg()) throw FileIOError(path + ": decoding its sound needs the ffmpeg program (Debian package ffmpeg)");
  const std::string command = "ffmpeg -nostdin -loglevel error -i " + ShellQuote(path) +
                              " -vn -ac 1 -ar " + std::to_string(rate) + " -f s16le - 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw FileIOError(path + ": cannot run ffmpeg to decode its sound");
  Audio audio;
  audio.rate = rate;
  int16_t buffer[4096];
  size_t n = 0;
  while ((n = std::fread(buffer, sizeof(int16_t), 4096, pipe)) > 0) {
    for (size_t i = 0; i < n; ++i) audio.samples.push_back(buffer[i] / 32768.f);
  }
  const int status = pclose(pipe);
  if (status != 0 || audio.samples.empty()) {
    throw FileIOError(path + ": ffmpeg found no sound track to decode");
  }
  return audio;
}

void MuxAudio(const std::string& video, const std::string& wav, const std::string& out) {
  if (!HaveFfmpeg()) throw OutputError(out + ": adding sound needs the ffmpeg program (Debian package ffmpeg)");
  const std::string temporary = out + ".tmp.mp4";
  const std::string command = "ffmpeg -nostdin -loglevel error -y -i " + ShellQuote(video) + " -i " +
                              ShellQuote(wav) + " -map 0:v:0 -map 1:a:0 -c:v copy -c:a aac -b:a 96k "
                              "-shortest " + ShellQuote(temporary) + " 2>/dev/null";
  const int status = std::system(command.c_str());
  std::error_code ec;
  if (status != 0 || !std::filesystem::exists(temporary, ec)) {
    std::filesystem::remove(temporary, ec);
    throw OutputError(out + ": ffmpeg could not mux " + wav + " into " + video);
  }
  std::filesystem::rename(temporary, out, ec);
  if (ec) throw OutputError(out + ": cannot rename " + temporary + ": " + ec.message());
}

}  // namespace facecap::io
