// Fuzz target: the job-file parser, io::Config::Parse, and what the stages ask of a parsed
// job file.
//
// Feeds: the input's bytes as the text of a TOML job file. When it parses, every table (to a
// depth of 16) is listed with Tables and Keys, every key is read with every typed getter
// (bool, int, int64, float, double, string and the three arrays), the tables are checked
// against the stage tables of the jobs/ files (CheckTables), the whole config and each table
// are written back with ToToml, and the whole config's TOML must parse again.
// Failure: a crash, a sanitizer report, an exception other than facecap::Error (parse errors,
// wrong types and unknown tables are InvalidInputError, expected outcomes), or ToToml text
// that does not parse back.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "fuzz_support.h"
#include "io/config.h"

namespace facecap::fuzz {
namespace {

const std::vector<std::string>& StageTables() {
  static const std::vector<std::string> tables = {
      "run", "rig.demo", "rig.calibrate", "render", "synth.clip", "synth.samples",
      "synth.crops", "ingest", "curate.build", "curate.query", "deepfake.train",
      "deepfake.infer", "person.fit", "track", "track-oracle", "export.livelink",
      "export.gltf", "export.landmarks", "export.overlay", "eval.track", "eval.person",
      "eval.landmarks", "eval.blendshapes", "scans.synth", "blendshapes.train",
      "blendshapes.baselines"};
  return tables;
}

template <typename T>
void TryGet(const io::Config& config, const std::string& table, const std::string& key) {
  T value{};
  try {
    config.Get(table, key, &value);
  } catch (const Error&) {
  }
}

void Visit(const io::Config& config, const std::string& table, int depth, int* budget) {
  if (depth > 16 || --*budget < 0) return;
  if (!table.empty() && !config.HasTable(table)) return;  // a name with a dot in it
  for (const std::string& key : config.Keys(table)) {
    if (!config.Has(table, key)) Fail("Keys lists '" + key + "' but Has denies it");
    TryGet<bool>(config, table, key);
    TryGet<int>(config, table, key);
    TryGet<int64_t>(config, table, key);
    TryGet<float>(config, table, key);
    TryGet<double>(config, table, key);
    TryGet<std::string>(config, table, key);
    TryGet<std::vector<int>>(config, table, key);
    TryGet<std::vector<float>>(config, table, key);
    TryGet<std::vector<std::string>>(config, table, key);
    (void)config.OriginOf(table, key);
  }
  (void)config.OriginsOf(table);
  (void)config.ToToml(table);
  for (const std::string& sub : config.Tables(table)) {
    Visit(config, table.empty() ? sub : table + "." + sub, depth + 1, budget);
  }
}

}  // namespace
}  // namespace facecap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facecap;
  using namespace facecap::fuzz;
  const std::string text(reinterpret_cast<const char*>(data), size);
  io::Config config;
  try {
    config = io::Config::Parse(text, "job.toml");
  } catch (const Error&) {
    return 0;
  }
  int budget = 256;
  Visit(config, "", 0, &budget);
  try {
    config.CheckTables(StageTables());
  } catch (const Error&) {
  }
  const std::string toml = config.ToToml();
  // What ToToml writes reads back (Parse refuses nesting that would not:
  // corpus/job_file/regression_deep_dotted_keys.toml).
  try {
    (void)io::Config::Parse(toml, "written back");
  } catch (const Error& e) {
    Fail("ToToml wrote text that does not parse: " + std::string(e.what()) + "\n" + toml);
  }
  return 0;
}
