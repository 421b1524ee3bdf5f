// Job files (TOML). A job file has one table per stage ([rig.demo], [synth.samples], ...);
// each stage's options struct maps one to one onto its table through the struct's
// Visit(visitor) method:
//
//   struct SynthSamplesOptions {
//     int count = 4000;  // number of samples
//     template <class V> void Visit(V&& v) { v("count", count, "number of samples"); }
//     bool Check(std::string* why) const;
//   };
//
// A key "group.name" groups an option by concern: it lives in the stage table's sub-table
// ([deepfake.train.loss] name = ...), while its flag stays --name.
//
// LoadOptions() fills a struct from a table and its group sub-tables (an unknown key or
// sub-table is an error that lists the valid ones; a value of the wrong type names the key and
// the type expected); StoreOptions() writes the resolved values back, so the resolved
// configuration can be stored in every output. CheckTables() rejects a table that no stage
// reads. Every error names where the value came from: the job file, `--set`, or the flag.
// toml++ stays inside config.cpp.
#ifndef FACECAP_IO_CONFIG_H_
#define FACECAP_IO_CONFIG_H_

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "util/errors.h"

namespace facecap::io {

class Config {
 public:
  Config();
  ~Config();
  Config(const Config& other);
  Config& operator=(const Config& other);

  // Reads a TOML file; FileIOError when missing, InvalidInputError (with line and column)
  // when it does not parse.
  static Config Load(const std::string& path);
  static Config Parse(const std::string& text, const std::string& origin = "<string>");

  // The job file's path, or "<defaults>" when there is none.
  const std::string& origin() const { return origin_; }
  // Where a value came from: the origin given to SetFromText ("--set", "--count"), else
  // origin().
  std::string OriginOf(const std::string& table, const std::string& key) const;
  // The distinct origins of a table's values, comma-separated ("job.toml, --count"); origin()
  // when the table holds no value.
  std::string OriginsOf(const std::string& table) const;
  // Whom to name for a failed Check() of `table`: the origin of the key that `why` starts
  // with ("identity_scale must be in [0, 3]") when the table holds that key, else
  // OriginsOf(table).
  std::string OriginOfCheck(const std::string& table, const std::string& why) const;
  // Tables are dotted paths: "synth.samples".
  bool HasTable(const std::string& table) const;
  bool Has(const std::string& table, const std::string& key) const;
  // Whether the value at table.key is an array (false when absent).
  bool IsArray(const std::string& table, const std::string& key) const;
  // The keys of a table that hold values (not sub-tables), in file order.
  std::vector<std::string> Keys(const std::string& table) const;
  // Sub-table names of a table ("" for the root).
  std::vector<std::string> Tables(const std::string& table) const;

  // Typed getters: InvalidInputError naming origin, table, key and type on mismatch.
  void Get(const std::string& table, const std::string& key, bool* value) const;
  void Get(const std::string& table, const std::string& key, int* value) const;
  void Get(const std::string& table, const std::string& key, int64_t* value) const;
  void Get(const std::string& table, const std::string& key, float* value) const;
  void Get(const std::string& table, const std::string& key, double* value) const;
  void Get(const std::string& table, const std::string& key, std::string* value) const;
  void Get(const std::string& table, const std::string& key, std::vector<int>* value) const;
  void Get(const std::string& table, const std::string& key, std::vector<float>* value) const;
  void Get(const std::string& table, const std::string& key,
           std::vector<std::string>* value) const;

  void Set(const std::string& table, const std::string& key, bool value);
  void Set(const std::string& table, const std::string& key, int value);
  void Set(const std::string& table, const std::string& key, int64_t value);
  void Set(const std::string& table, const std::string& key, float value);
  void Set(const std::string& table, const std::string& key, double value);
  void Set(const std::string& table, const std::string& key, const std::string& value);
  void Set(const std::string& table, const std::string& key, const std::vector<int>& value);
  void Set(const std::string& table, const std::string& key, const std::vector<float>& value);
  void Set(const std::string& table, const std::string& key,
           const std::vector<std::string>& value);
  // Sets a value from its command-line text: one TOML literal (42, 0.5, true, [1, 2],
  // "text") or, failing that, a bare string. `origin` labels errors about the value ("--set",
  // "--count"); empty: origin().
  void SetFromText(const std::string& table, const std::string& key, const std::string& text,
                   const std::string& origin = "");
  // Applies "table.key=value" (the --set flag); errors about the value name "--set".
  void SetAssignment(const std::string& assignment);

  // InvalidInputError, naming the origin and listing `valid`, when a table is not one of
  // `valid` (dotted paths: "rig.demo") nor a parent of one ([rig] of [rig.demo]), or when a
  // value sits outside the valid tables (at the top, or in a parent such as [rig]).
  void CheckTables(const std::vector<std::string>& valid) const;

  // Copies `table` (and its sub-tables) of `other` into this config, replacing it.
  void CopyTable(const Config& other, const std::string& table);
  // The TOML text of the whole config, or of one table.
  std::string ToToml(const std::string& table = "") const;

 private:
  struct Impl;
  void ForgetOrigin(const std::string& table, const std::string& key);

  std::unique_ptr<Impl> impl_;
  std::string origin_ = "<defaults>";
  // (table, key) -> origin, for values set with an origin of their own.
  std::map<std::pair<std::string, std::string>, std::string> value_origins_;
};

// Where an option's key lives: (table, name) for "name", (table.group, name) for
// "group.name".
std::pair<std::string, std::string> OptionPlace(const std::string& table, const std::string& key);

// InvalidInputError when `table` of `config` holds a key that is not one of `keys` (an
// options struct's keys, grouped ones as "group.name"), or a sub-table that is not one of
// their groups; the error lists the valid keys, and for a grouped option's name in the wrong
// table says which table it belongs in.
void CheckOptionKeys(const Config& config, const std::string& table,
                     const std::vector<std::string>& keys);

// Visits a nested options struct as the group `group`: each of its keys as "group.key".
template <class Options, class V>
void VisitGroup(const char* group, Options& options, V&& v) {
  options.Visit([&](const char* key, auto& field, const char* help) {
    const std::string grouped = std::string(group) + "." + key;
    v(grouped.c_str(), field, help);
  });
}

// `table` and the sub-tables of its option groups, in Visit order.
template <typename Options>
std::vector<std::string> OptionTables(const std::string& table) {
  std::vector<std::string> tables = {table};
  Options().Visit([&](const char* key, auto&, const char*) {
    const std::string where = OptionPlace(table, key).first;
    if (std::find(tables.begin(), tables.end(), where) == tables.end()) tables.push_back(where);
  });
  return tables;
}

// Fills `options` from `table` of `config` and its group sub-tables. Unknown keys or tables:
// InvalidInputError listing the valid ones. Absent keys keep the struct's defaults.
template <typename Options>
void LoadOptions(const Config& config, const std::string& table, Options* options) {
  std::vector<std::string> keys;
  options->Visit([&](const char* key, auto& field, const char* /*help*/) {
    keys.emplace_back(key);
    const auto [where, name] = OptionPlace(table, key);
    if (config.Has(where, name)) config.Get(where, name, &field);
  });
  CheckOptionKeys(config, table, keys);
}

// Writes every field of `options` into `table` of `config` (grouped ones into its sub-tables).
template <typename Options>
void StoreOptions(const Options& options, const std::string& table, Config* config) {
  const_cast<Options&>(options).Visit([&](const char* key, auto& field, const char*) {
    const auto [where, name] = OptionPlace(table, key);
    config->Set(where, name, field);
  });
}

// LoadOptions then Check(): InvalidInputError with the table and the reason.
template <typename Options>
Options ResolveOptions(const Config& config, const std::string& table) {
  Options options;
  LoadOptions(config, table, &options);
  std::string why;
  if (!options.Check(&why)) {
    throw InvalidInputError(config.OriginOfCheck(table, why) + ": [" + table + "] " + why);
  }
  return options;
}

}  // namespace facecap::io

#endif  // FACECAP_IO_CONFIG_H_
