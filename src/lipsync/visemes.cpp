#include "lipsync/visemes.h"

#include <algorithm>
#include <cctype>

namespace facecap::lipsync {
namespace {

// The code points of a UTF-8 string (malformed sequences are skipped byte by byte).
std::vector<char32_t> CodePoints(const std::string& s) {
  std::vector<char32_t> out;
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    size_t extra = 0;
    char32_t cp = c;
    if ((c >> 5) == 0x6) { cp = c & 0x1F; extra = 1; }
    else if ((c >> 4) == 0xE) { cp = c & 0x0F; extra = 2; }
    else if ((c >> 3) == 0x1E) { cp = c & 0x07; extra = 3; }
    else if (c >= 0x80) { ++i; continue; }
    bool ok = i + extra < s.size();
    for (size_t k = 1; k <= extra && ok; ++k) {
      const unsigned char cc = static_cast<unsigned char>(s[i + k]);
      ok = (cc >> 6) == 0x2;
      cp = (cp << 6) | (cc & 0x3F);
    }
    if (ok) out.push_back(cp);
    i += ok ? extra + 1 : 1;
  }
  return out;
}

// Marks that do not change the viseme: primary and secondary stress, length, half-length,
// tie bars, the syllabic mark, and espeak-ng's separators.
bool IsModifier(char32_t c) {
  return c == U'\u02C8' || c == U'\u02CC' || c == U'\u02D0' || c == U'\u02D1' || c == U'\u0361' ||
         c == U'\u035C' || c == U'\u0329' || c == U'_' || c == U'\'' || c == U',' || c == U':' ||
         c == U' ' || c == U'-';
}

}  // namespace

const char* VisemeName(Viseme v) {
  static const char* const kNames[kNumVisemes] = {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS",
                                                  "nn", "RR", "aa", "E", "ih", "oh", "ou"};
  const int i = static_cast<int>(v);
  return i >= 0 && i < kNumVisemes ? kNames[i] : "?";
}

int VisemeOfArpabet(const std::string& phone) {
  if (phone.empty()) return -1;
  if (phone.front() == '+' || phone.front() == '<' || phone.front() == '[') {
    return static_cast<int>(Viseme::kSilence);
  }
  std::string p;
  for (char c : phone) p.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
  while (!p.empty() && std::isdigit(static_cast<unsigned char>(p.back()))) p.pop_back();
  struct Entry { const char* phone; Viseme viseme; };
  static const Entry kTable[] = {
      {"SIL", Viseme::kSilence},
      {"P", Viseme::kPP},  {"B", Viseme::kPP},  {"M", Viseme::kPP},
      {"F", Viseme::kFF},  {"V", Viseme::kFF},
      {"TH", Viseme::kTH}, {"DH", Viseme::kTH},
      {"T", Viseme::kDD},  {"D", Viseme::kDD},
      {"K", Viseme::kKK},  {"G", Viseme::kKK},  {"NG", Viseme::kKK}, {"HH", Viseme::kKK},
      {"CH", Viseme::kCH}, {"JH", Viseme::kCH}, {"SH", Viseme::kCH}, {"ZH", Viseme::kCH},
      {"S", Viseme::kSS},  {"Z", Viseme::kSS},
      {"N", Viseme::kNN},  {"L", Viseme::kNN},  {"Y", Viseme::kIH},
      {"R", Viseme::kRR},  {"ER", Viseme::kRR}, {"W", Viseme::kOU},
      {"AA", Viseme::kAA}, {"AE", Viseme::kAA}, {"AH", Viseme::kAA}, {"AY", Viseme::kAA},
      {"AW", Viseme::kAA},
      {"EH", Viseme::kE},  {"EY", Viseme::kE},
      {"IH", Viseme::kIH}, {"IY", Viseme::kIH},
      {"AO", Viseme::kOH}, {"OW", Viseme::kOH}, {"OY", Viseme::kOH},
      {"UH", Viseme::kOU}, {"UW", Viseme::kOU},
  };
  for (const Entry& e : kTable) {
    if (p == e.phone) return static_cast<int>(e.viseme);
  }
  return -1;
}

int VisemeOfIpa(const std::string& phone) {
  std::vector<char32_t> cps = CodePoints(phone);
  cps.erase(std::remove_if(cps.begin(), cps.end(), IsModifier), cps.end());
  if (cps.empty()) return static_cast<int>(Viseme::kSilence);
  // Affricates first: t + esh, d + ezh.
  if (cps.size() >= 2 && (cps[0] == U't' || cps[0] == U'd') &&
      (cps[1] == U'\u0283' || cps[1] == U'\u0292')) {
    return static_cast<int>(Viseme::kCH);
  }
  struct Entry { char32_t cp; Viseme viseme; };
  static const Entry kTable[] = {
      {U'p', Viseme::kPP}, {U'b', Viseme::kPP}, {U'm', Viseme::kPP},
      {U'f', Viseme::kFF}, {U'v', Viseme::kFF},
      {U'\u03B8', Viseme::kTH}, {U'\u00F0', Viseme::kTH},                 // theta, eth
      {U't', Viseme::kDD}, {U'd', Viseme::kDD}, {U'\u027E', Viseme::kDD},  // flap
      {U'\u0294', Viseme::kDD},                                           // glottal stop
      {U'k', Viseme::kKK}, {U'g', Viseme::kKK}, {U'\u0261', Viseme::kKK}, {U'\u014B', Viseme::kKK},
      {U'h', Viseme::kKK}, {U'x', Viseme::kKK},
      {U'\u0283', Viseme::kCH}, {U'\u0292', Viseme::kCH},                 // esh, ezh
      {U's', Viseme::kSS}, {U'z', Viseme::kSS},
      {U'n', Viseme::kNN}, {U'l', Viseme::kNN}, {U'\u026B', Viseme::kNN},  // dark l
      {U'j', Viseme::kIH},
      {U'r', Viseme::kRR}, {U'\u0279', Viseme::kRR}, {U'\u025A', Viseme::kRR},  // turned r, rhotic schwa
      {U'\u025D', Viseme::kRR}, {U'\u025C', Viseme::kRR},                        // open-mid central
      {U'w', Viseme::kOU},
      {U'a', Viseme::kAA}, {U'\u0251', Viseme::kAA}, {U'\u00E6', Viseme::kAA},  // alpha, ash
      {U'\u0250', Viseme::kAA}, {U'\u028C', Viseme::kAA}, {U'\u0259', Viseme::kAA},  // turned a, wedge, schwa
      {U'e', Viseme::kE}, {U'\u025B', Viseme::kE},                        // epsilon
      {U'i', Viseme::kIH}, {U'\u026A', Viseme::kIH}, {U'\u1D7B', Viseme::kIH},  // small cap I, barred I
      {U'\u0268', Viseme::kIH},
      {U'o', Viseme::kOH}, {U'\u0254', Viseme::kOH}, {U'\u0252', Viseme::kOH},  // open o, turned alpha
      {U'u', Viseme::kOU}, {U'\u028A', Viseme::kOU}, {U'\u0289', Viseme::kOU},  // upsilon, barred u
  };
  for (const Entry& e : kTable) {
    if (cps[0] == e.cp) return static_cast<int>(e.viseme);
  }
  return -1;
}

const std::vector<std::pair<std::string, float>>& VisemePose(Viseme v) {
  using Pose = std::vector<std::pair<std::string, float>>;
  static const Pose kPoses[kNumVisemes] = {
      {},
      {{"mouthClose", 0.3f}, {"mouthPressLeft", 0.5f}, {"mouthPressRight", 0.5f},
       {"mouthRollLower", 0.2f}},
      {{"jawOpen", 0.08f}, {"mouthRollLower", 0.6f}, {"mouthUpperUpLeft", 0.25f},
       {"mouthUpperUpRight", 0.25f}},
      {{"jawOpen", 0.15f}, {"mouthStretchLeft", 0.1f}, {"mouthStretchRight", 0.1f}},
      {{"jawOpen", 0.2f}, {"mouthStretchLeft", 0.15f}, {"mouthStretchRight", 0.15f}},
      {{"jawOpen", 0.25f}, {"mouthStretchLeft", 0.1f}, {"mouthStretchRight", 0.1f}},
      {{"jawOpen", 0.15f}, {"mouthFunnel", 0.55f}, {"mouthPucker", 0.2f}},
      {{"jawOpen", 0.08f}, {"mouthStretchLeft", 0.3f}, {"mouthStretchRight", 0.3f},
       {"mouthSmileLeft", 0.15f}, {"mouthSmileRight", 0.15f}},
      {{"jawOpen", 0.15f}, {"mouthStretchLeft", 0.1f}, {"mouthStretchRight", 0.1f}},
      {{"jawOpen", 0.15f}, {"mouthFunnel", 0.3f}, {"mouthPucker", 0.35f}},
      {{"jawOpen", 0.6f}, {"mouthLowerDownLeft", 0.3f}, {"mouthLowerDownRight", 0.3f}},
      {{"jawOpen", 0.35f}, {"mouthStretchLeft", 0.3f}, {"mouthStretchRight", 0.3f},
       {"mouthSmileLeft", 0.2f}, {"mouthSmileRight", 0.2f}},
      {{"jawOpen", 0.2f}, {"mouthSmileLeft", 0.3f}, {"mouthSmileRight", 0.3f},
       {"mouthStretchLeft", 0.2f}, {"mouthStretchRight", 0.2f}},
      {{"jawOpen", 0.4f}, {"mouthFunnel", 0.5f}},
      {{"jawOpen", 0.15f}, {"mouthPucker", 0.7f}, {"mouthFunnel", 0.2f}},
  };
  const int i = std::clamp(static_cast<int>(v), 0, kNumVisemes - 1);
  return kPoses[i];
}

const std::vector<std::string>& DefaultMouthControls() {
  static const std::vector<std::string> kControls = {
      "jawOpen",           "mouthClose",         "mouthFunnel",         "mouthPucker",
      "mouthLeft",         "mouthRight",         "mouthSmileLeft",      "mouthSmileRight",
      "mouthFrownLeft",    "mouthFrownRight",    "mouthDimpleLeft",     "mouthDimpleRight",
      "mouthStretchLeft",  "mouthStretchRight",  "mouthRollLower",      "mouthRollUpper",
      "mouthShrugLower",   "mouthShrugUpper",    "mouthPressLeft",      "mouthPressRight",
      "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",  "mouthUpperUpRight"};
  return kControls;
}

}  // namespace facecap::lipsync
