// Numbers, strings and lists in the JSON objects that evaluations print: 6 significant digits,
// null for a value that is not finite.
#ifndef FACECAP_UTIL_JSON_H_
#define FACECAP_UTIL_JSON_H_

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace facecap {

inline std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char text[64];
  std::snprintf(text, sizeof(text), "%.6g", v);
  return text;
}

inline std::string JsonList(const std::vector<double>& values) {
  std::string out = "[";
  for (size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + JsonNumber(values[i]);
  return out + "]";
}

// A JSON string literal, quotes included.
inline std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char code[8];
      std::snprintf(code, sizeof(code), "\\u%04x", static_cast<unsigned>(c));
      out += code;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace facecap

#endif  // FACECAP_UTIL_JSON_H_
