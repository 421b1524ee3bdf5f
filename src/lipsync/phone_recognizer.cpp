#include "lipsync/phone_recognizer.h"

#include <pocketsphinx.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include <unistd.h>

#include "lipsync/visemes.h"
#include "util/errors.h"

namespace facecap::lipsync {
namespace {

// Pocketsphinx's frames are 10 ms.
constexpr double kFrameSeconds = 0.01;

std::mutex& RecognizerMutex() {
  static std::mutex m;
  return m;
}

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// CMU dictionary entries of the words wanted and of their variants ("word(2)"): entry ->
// phones.
std::map<std::string, std::vector<std::string>> DictionaryEntries(const std::string& path,
                                                                  const std::vector<std::string>& words) {
  std::ifstream in(path);
  if (!in) throw FileIOError(path + ": cannot read the pronunciation dictionary");
  std::map<std::string, std::vector<std::string>> out;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string entry;
    ls >> entry;
    const std::string word = entry.substr(0, entry.find('('));
    if (word.empty() || std::find(words.begin(), words.end(), word) == words.end()) continue;
    std::string phone;
    while (ls >> phone) out[entry].push_back(phone);
  }
  return out;
}

// The transcript's words, lower case, punctuation dropped.
std::vector<std::string> TranscriptWords(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  for (char c : text + " ") {
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '\'') {
      word.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
    } else if (!word.empty()) {
      words.push_back(word);
      word.clear();
    }
  }
  return words;
}

struct Decoder {
  cmd_ln_t* config = nullptr;
  ps_decoder_t* ps = nullptr;
  ~Decoder() {
    if (ps) ps_free(ps);
    if (config) cmd_ln_free_r(config);
  }
};

// Runs the decoder over the samples; the segments (name, first frame, last frame).
struct Segment {
  std::string name;
  int first = 0, last = 0;
};
// The speech is decoded between pads of silence (a recognizer expects to hear one before
// and after an utterance); segment frames count from the start of the speech.
constexpr int kPadFrames = 30;

std::vector<Segment> Decode(Decoder* d, const std::vector<float>& samples) {
  const size_t pad = kPadFrames * kRecognizerRate / 100;
  std::vector<int16_t> pcm(samples.size() + 2 * pad, 0);
  for (size_t i = 0; i < samples.size(); ++i) {
    pcm[pad + i] = static_cast<int16_t>(std::lround(std::clamp(samples[i], -1.f, 1.f) * 32767.f));
  }
  ps_start_utt(d->ps);
  ps_process_raw(d->ps, pcm.data(), pcm.size(), FALSE, TRUE);
  ps_end_utt(d->ps);
  std::vector<Segment> out;
  for (ps_seg_t* it = ps_seg_iter(d->ps); it; it = ps_seg_next(it)) {
    Segment s;
    s.name = ps_seg_word(it);
    ps_seg_frames(it, &s.first, &s.last);
    s.first -= kPadFrames;
    s.last -= kPadFrames;
    if (s.last >= 0) out.push_back(s);
  }
  return out;
}

void CheckModel(const std::string& dir) {
  std::error_code ec;
  for (const char* part : {"en-us/mdef", "en-us-phone.lm.bin", "cmudict-en-us.dict"}) {
    if (!std::filesystem::exists(dir + "/" + part, ec)) {
      throw FileIOError(dir + "/" + part + ": missing (the pocketsphinx English model: Debian "
                        "package pocketsphinx-en-us)");
    }
  }
}

}  // namespace

namespace {

// The transcript's words and their dictionary entries; InvalidInputError for a transcript
// without words or with a word the dictionary lacks.
std::map<std::string, std::vector<std::string>> TranscriptPronunciations(const std::string& transcript,
                                                                         const std::string& dict,
                                                                         std::vector<std::string>* words) {
  *words = TranscriptWords(transcript);
  if (words->empty()) throw InvalidInputError("lipsync: the transcript has no words");
  std::map<std::string, std::vector<std::string>> pronunciations = DictionaryEntries(dict, *words);
  for (const std::string& w : *words) {
    if (!pronunciations.count(w)) {
      throw InvalidInputError("lipsync: '" + w + "' of the transcript is not in " + dict);
    }
  }
  return pronunciations;
}

}  // namespace

void CheckRecognizerOptions(const RecognizerOptions& options) {
  CheckModel(options.model_dir);
  if (options.transcript.empty()) return;
  std::vector<std::string> words;
  TranscriptPronunciations(options.transcript, options.model_dir + "/cmudict-en-us.dict", &words);
}

std::vector<PhoneSegment> RecognizePhones(const std::vector<float>& samples,
                                          const RecognizerOptions& options) {
  CheckModel(options.model_dir);
  const std::string hmm = options.model_dir + "/en-us";
  const std::string dict = options.model_dir + "/cmudict-en-us.dict";
  std::vector<std::string> words;
  std::map<std::string, std::vector<std::string>> pronunciations;
  std::string grammar_path;
  if (!options.transcript.empty()) {
    pronunciations = TranscriptPronunciations(options.transcript, dict, &words);
    // A grammar of exactly the transcript, with optional pauses.
    grammar_path = (std::filesystem::temp_directory_path() /
                    ("facecap_transcript_" + std::to_string(::getpid()) + ".gram")).string();
    std::ofstream g(grammar_path);
    g << "#JSGF V1.0;\ngrammar transcript;\npublic <utterance> =";
    for (const std::string& w : words) g << " " << w;
    g << ";\n";
  }
  std::lock_guard<std::mutex> lock(RecognizerMutex());
  Decoder d;
  if (grammar_path.empty()) {
    d.config = cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", hmm.c_str(), "-allphone",
                           (options.model_dir + "/en-us-phone.lm.bin").c_str(), "-backtrace", "yes",
                           "-beam", "1e-20", "-pbeam", "1e-20", "-lw", "2.0", "-dither", "yes",
                           "-seed", "1", "-samprate", "16000",
                           "-logfn", "/dev/null", nullptr);
  } else {
    // Wide beams: with the default ones the search loses synthetic voices' paths before the
    // grammar's end. Both modes dither the samples (seeded: the same sound gives the same
    // phones); without it, digital silence stalls the grammar search.
    d.config = cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", hmm.c_str(), "-dict", dict.c_str(),
                           "-jsgf", grammar_path.c_str(), "-beam", "1e-100", "-pbeam", "1e-100",
                           "-wbeam", "1e-100", "-dither", "yes", "-seed", "1", "-samprate", "16000",
                           "-logfn", "/dev/null", nullptr);
  }
  if (!d.config) throw FileIOError(hmm + ": pocketsphinx rejected its configuration");
  d.ps = ps_init(d.config);
  if (!grammar_path.empty()) std::filesystem::remove(grammar_path);
  if (!d.ps) throw FileIOError(hmm + ": pocketsphinx could not load the model");
  const std::vector<Segment> segments = Decode(&d, samples);
  if (segments.empty()) {
    throw InvalidInputError(grammar_path.empty()
                                ? "lipsync: pocketsphinx recognized nothing in the sound"
                                : "lipsync: the transcript could not be aligned to the sound "
                                  "(pocketsphinx found no path through its words)");
  }
  std::vector<PhoneSegment> out;
  auto add = [&](const std::string& phone, double start, double end) {
    if (end <= start) return;
    PhoneSegment p;
    const int v = VisemeOfArpabet(phone);
    p.phone = v == static_cast<int>(Viseme::kSilence) ? "SIL" : Upper(phone);
    p.viseme = std::max(0, v);
    p.start = start;
    p.end = end;
    out.push_back(p);
  };
  for (const Segment& s : segments) {
    const double start = std::max(0, s.first) * kFrameSeconds, end = (s.last + 1) * kFrameSeconds;
    if (grammar_path.empty()) {
      add(s.name, start, end);
      continue;
    }
    // A word of the transcript (the pronunciation the decoder chose): its dictionary phones
    // share its time equally.
    const auto it = pronunciations.find(s.name);
    if (it == pronunciations.end()) {
      add("SIL", start, end);
      continue;
    }
    const int n = static_cast<int>(it->second.size());
    for (int k = 0; k < n; ++k) {
      add(it->second[k], start + (end - start) * k / n, start + (end - start) * (k + 1) / n);
    }
  }
  return out;
}

std::vector<std::string> ModelPhones(const std::string& model_dir) {
  const std::string path = model_dir + "/en-us/mdef";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileIOError(path + ": cannot read the model definition");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // The binary model definition lists its base phones as NUL-terminated names, the first
  // of them the filler +NSN+.
  const size_t at = bytes.find(std::string("+NSN+\0", 6));
  if (at == std::string::npos) throw FileIOError(path + ": no phone list found");
  std::vector<std::string> phones;
  size_t p = at;
  while (p < bytes.size()) {
    const size_t end = bytes.find('\0', p);
    if (end == std::string::npos || end == p) break;
    const std::string name = bytes.substr(p, end - p);
    const bool ok = std::all_of(name.begin(), name.end(), [](char c) {
      return std::isupper(static_cast<unsigned char>(c)) || c == '+';
    });
    if (!ok) break;
    phones.push_back(name);
    p = end + 1;
  }
  return phones;
}

}  // namespace facecap::lipsync
