// Command-line plumbing shared by the subcommands (CLI11 stays in stages/ and app/).
//
// Every stage option struct (see io/config.h) becomes flags automatically: a field `count`
// of table [synth.samples] is `--count`, with its help text and default shown by --help.
// Precedence: struct defaults < job file (--job) < --set table.key=value < the flags.
// A job file holds every stage's table, so a stage accepts the other stages' tables; a table
// that no stage reads ([rig.demoo], --set rigdemo.identity_seed=3) is an error.
#ifndef FACECAP_APP_CLI_H_
#define FACECAP_APP_CLI_H_

#include <map>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <CLI/CLI.hpp>

#include "io/config.h"
#include "stages/stage.h"
#include "util/errors.h"

namespace facecap::app {

// Flags common to all stages plus the per-option overrides collected from the command line.
struct StageFlags {
  std::string job;                         // --job FILE
  std::vector<std::string> sets;           // --set table.key=value
  std::map<std::string, std::string> overrides;  // table key -> text given on the command line
  std::string table;
  // The tables a job file may have (every stage's, and [run]); null: tables are not checked.
  const std::vector<std::string>* job_tables = nullptr;
};

template <typename T>
std::string DefaultText(const T& value) {
  std::ostringstream os;
  if constexpr (std::is_same_v<T, bool>) {
    os << (value ? "true" : "false");
  } else if constexpr (std::is_same_v<T, std::string>) {
    os << '"' << value << '"';
  } else if constexpr (std::is_arithmetic_v<T>) {
    os << value;
  } else {
    os << "[";
    for (size_t i = 0; i < value.size(); ++i) os << (i ? ", " : "") << DefaultText(value[i]);
    os << "]";
  }
  return os.str();
}

// The flag of an option key: --name for "name" and for a grouped "group.name".
inline std::string FlagName(const std::string& key) {
  std::string f = "--" + key.substr(key.find('.') + 1);
  for (char& c : f) if (c == '_') c = '-';
  return f;
}

inline std::string TomlQuote(const std::string& text) {
  std::string q = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') q += '\\';
    q += c;
  }
  return q + "\"";
}

// The TOML literal of a numeric flag's text, or "" when the text is not exactly one finite
// decimal number (an integer when `integral`): "1 2", "3\n", "0x10", "nan", "1e999" are not.
std::string NumberFlagToToml(const std::string& text, bool integral);

// The TOML literal for a flag's text: strings are quoted, lists may be given as "1,2,3", a
// number must be exactly one number (InvalidInputError otherwise).
template <typename Field>
std::string FlagTextToToml(const std::string& text) {
  if constexpr (std::is_same_v<Field, std::string>) {
    return TomlQuote(text);
  } else if constexpr (std::is_arithmetic_v<Field>) {
    constexpr bool kIntegral = std::is_integral_v<Field>;
    std::string literal = NumberFlagToToml(text, kIntegral);
    if (literal.empty()) {
      throw InvalidInputError("expected " + std::string(kIntegral ? "an integer" : "a number") +
                              ", got '" + text + "'");
    }
    return literal;
  } else {
    if (!text.empty() && text.front() == '[') return text;
    std::string out = "[";
    std::stringstream ss(text);
    std::string item;
    bool first = true;
    while (std::getline(ss, item, ',')) {
      if constexpr (std::is_same_v<typename Field::value_type, std::string>) item = TomlQuote(item);
      out += (first ? "" : ", ") + item;
      first = false;
    }
    return out + "]";
  }
}

// An options struct may group its flags in --help: `static HelpSections()` returns pairs
// (first key of a section, the section's title), in Visit order.
template <typename Options, typename = void>
struct HasHelpSections : std::false_type {};
template <typename Options>
struct HasHelpSections<Options, std::void_t<decltype(Options::HelpSections())>> : std::true_type {};

// Adds --job, --set and one flag per field of Options to `sub`.
template <typename Options>
void AddStageFlags(CLI::App* sub, const std::string& table, StageFlags* flags) {
  flags->table = table;
  sub->add_option("--job", flags->job,
                  "TOML job file; its [" + table + "] table sets these options")
      ->check(CLI::ExistingFile);
  sub->add_option("--set", flags->sets,
                  "override any job-file value: --set " + table + ".key=value (repeatable)");
  Options defaults;
  std::vector<std::pair<std::string, std::string>> sections;
  if constexpr (HasHelpSections<Options>::value) sections = Options::HelpSections();
  std::string section = "Options";
  defaults.Visit([&](const char* key, auto& field, const char* help) {
    const std::string k = key;
    for (const auto& [first, title] : sections) {
      // A section of grouped options names the job-file table they live in.
      const std::string where = io::OptionPlace(table, first).first;
      if (first == k) section = where == table ? title : title + " ([" + where + "])";
    }
    using Field = std::decay_t<decltype(field)>;
    const std::string description = std::string(help) + " (default: " + DefaultText(field) + ")";
    if constexpr (std::is_same_v<Field, bool>) {
      // --name sets true, --no-name sets false.
      sub->add_flag_function(
             FlagName(k) + ",!--no-" + FlagName(k).substr(2),
             [flags, k](std::int64_t count) { flags->overrides[k] = count > 0 ? "true" : "false"; },
             description)
          ->group(section);
      return;
    } else {
      auto* option = sub->add_option_function<std::string>(
          FlagName(k),
          [flags, k](const std::string& text) { flags->overrides[k] = FlagTextToToml<Field>(text); },
          description);
      option->group(section);
      if constexpr (std::is_arithmetic_v<Field>) {
        constexpr bool kIntegral = std::is_integral_v<Field>;
        option->type_name(kIntegral ? "INT" : "FLOAT");
        option->check(CLI::Validator(
            [](std::string& text) -> std::string {
              if (!NumberFlagToToml(text, kIntegral).empty()) return "";
              return std::string("expected ") + (kIntegral ? "an integer" : "a number") +
                     ", got '" + text + "'";
            },
            ""));
      } else if constexpr (std::is_same_v<Field, std::string>) {
        option->type_name("TEXT");
      } else {
        option->type_name("LIST");
      }
    }
  });
}

// For an instance table [STAGE-NAME] of the stage table `stage`: the instance's tables, its
// own and its option groups' ([STAGE-NAME.group]), appended to *out for each of the stage's
// among `tables`.
void AddInstanceTables(const std::vector<std::string>& tables, const std::string& stage,
                       const std::string& instance, std::vector<std::string>* out);

// The job configuration with --set and flags applied (flags win); with flags.job_tables, a
// table that is not one of them is an error that names it, its source and the valid tables.
io::Config BuildConfig(const StageFlags& flags);

// Resolves Options for the stage: defaults, job file, --set, flags; then Check().
// `resolved` receives the options as stored in the output's provenance.
template <typename Options>
Options ResolveStageOptions(const StageFlags& flags, io::Config* resolved) {
  Options options = io::ResolveOptions<Options>(BuildConfig(flags), flags.table);
  *resolved = stages::StoredOptions(options, flags.table);
  return options;
}

// Quotes argv into one command line (for provenance).
std::string JoinCommandLine(int argc, char** argv);

}  // namespace facecap::app

#endif  // FACECAP_APP_CLI_H_
