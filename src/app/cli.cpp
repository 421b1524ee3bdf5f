#include "app/cli.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>

#include "util/errors.h"

namespace facecap::app {

std::string NumberFlagToToml(const std::string& text, bool integral) {
  // The decimal grammar only: from_chars alone would also take "inf", "nan" and hex digits
  // after a prefix, and stops quietly at the first character it does not read.
  size_t i = 0;
  const size_t n = text.size();
  const auto digits = [&] {
    const size_t start = i;
    while (i < n && text[i] >= '0' && text[i] <= '9') ++i;
    return i - start;
  };
  if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
  const size_t sign_end = i;
  size_t mantissa_digits = digits();
  if (!integral && i < n && text[i] == '.') {
    ++i;
    mantissa_digits += digits();
  }
  if (mantissa_digits == 0) return "";
  if (!integral && i < n && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return "";
  }
  if (i != n) return "";
  const bool negative = text[0] == '-';
  const char* first = text.data() + sign_end;
  const char* last = text.data() + n;
  char buffer[64];
  if (integral) {
    uint64_t magnitude = 0;
    const auto parsed = std::from_chars(first, last, magnitude);
    if (parsed.ec != std::errc() || parsed.ptr != last) return "";
    if (magnitude > (negative ? uint64_t{1} << 63 : uint64_t{INT64_MAX})) return "";
    const auto printed = std::to_chars(buffer, buffer + sizeof(buffer), magnitude);
    return (negative ? "-" : "") + std::string(buffer, printed.ptr);
  }
  double value = 0;
  const auto parsed = std::from_chars(first, last, value);
  if (parsed.ec != std::errc() || parsed.ptr != last || !std::isfinite(value)) return "";
  if (negative) value = -value;
  // Shortest round-trip form: "0.5", "1e+20", "3"; all of them TOML literals.
  const auto printed = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, printed.ptr);
}

namespace {

// `valid` and the instance tables [STAGE-NAME] of valid stage tables that the job's [run] stages
// names, so that one stage of a job with instances runs alone with --job.
std::vector<std::string> WithRunInstances(const io::Config& config, std::vector<std::string> valid) {
  if (!config.Has("run", "stages") || !config.IsArray("run", "stages")) return valid;
  std::vector<std::string> named;
  config.Get("run", "stages", &named);
  const std::vector<std::string> stage_tables = valid;
  for (const std::string& entry : named) {
    const size_t dash = entry.find('-');
    if (dash == std::string::npos) continue;
    AddInstanceTables(stage_tables, entry.substr(0, dash), entry, &valid);
  }
  return valid;
}

}  // namespace

void AddInstanceTables(const std::vector<std::string>& tables, const std::string& stage,
                       const std::string& instance, std::vector<std::string>* out) {
  if (std::find(tables.begin(), tables.end(), stage) == tables.end()) return;  // not a stage
  for (const std::string& t : tables) {
    if (t == stage || t.compare(0, stage.size() + 1, stage + ".") == 0) {
      out->push_back(instance + t.substr(stage.size()));
    }
  }
}

io::Config BuildConfig(const StageFlags& flags) {
  io::Config config = flags.job.empty() ? io::Config() : io::Config::Load(flags.job);
  for (const auto& assignment : flags.sets) config.SetAssignment(assignment);
  for (const auto& [key, text] : flags.overrides) {
    const auto [table, name] = io::OptionPlace(flags.table, key);
    config.SetFromText(table, name, text, FlagName(key));
  }
  if (flags.job_tables) config.CheckTables(WithRunInstances(config, *flags.job_tables));
  return config;
}

std::string JoinCommandLine(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    const bool quote = arg.find_first_of(" \t'\"") != std::string::npos || arg.empty();
    if (quote) {
      std::string q = "'";
      for (char c : arg) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      arg = q + "'";
    }
    line += (i ? " " : "") + arg;
  }
  return line;
}

}  // namespace facecap::app
