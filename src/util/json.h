// Numbers and lists in the JSON objects that evaluations print: 6 significant digits,
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

}  // namespace facecap

#endif  // FACECAP_UTIL_JSON_H_
