#include "io/config.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <limits>
#include <sstream>

#include <toml++/toml.h>

namespace facecap::io {

struct Config::Impl {
  toml::table root;
};

namespace {

std::vector<std::string> SplitDots(const std::string& path) {
  std::vector<std::string> parts;
  std::stringstream ss(path);
  std::string part;
  while (std::getline(ss, part, '.')) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

const toml::table* FindTable(const toml::table& root, const std::string& table) {
  const toml::table* t = &root;
  for (const auto& part : SplitDots(table)) {
    t = t->get_as<toml::table>(part);
    if (!t) return nullptr;
  }
  return t;
}

toml::table* EnsureTable(toml::table& root, const std::string& table) {
  toml::table* t = &root;
  for (const auto& part : SplitDots(table)) {
    toml::table* next = t->get_as<toml::table>(part);
    if (!next) {
      t->insert_or_assign(part, toml::table{});
      next = t->get_as<toml::table>(part);
    }
    t = next;
  }
  return t;
}

std::string Where(const std::string& origin, const std::string& table, const std::string& key) {
  return origin + ": [" + table + "] " + key;
}

}  // namespace

Config::Config() : impl_(std::make_unique<Impl>()) {}
Config::~Config() = default;
Config::Config(const Config& other)
    : impl_(std::make_unique<Impl>(*other.impl_)),
      origin_(other.origin_),
      value_origins_(other.value_origins_) {}
Config& Config::operator=(const Config& other) {
  if (this != &other) {
    impl_ = std::make_unique<Impl>(*other.impl_);
    origin_ = other.origin_;
    value_origins_ = other.value_origins_;
  }
  return *this;
}

Config Config::Load(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw FileIOError(path + ": no such job file");
  Config config;
  config.origin_ = path;
  try {
    config.impl_->root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    std::ostringstream os;
    os << path << ":" << e.source().begin.line << ":" << e.source().begin.column
       << ": not valid TOML: " << e.description();
    throw InvalidInputError(os.str());
  }
  return config;
}

namespace {

// How deeply tables and arrays nest below `node` (0 for a plain value).
int NestingDepth(const toml::node& node) {
  int deepest = 0;
  if (const toml::table* t = node.as_table()) {
    for (const auto& [key, value] : *t) deepest = std::max(deepest, 1 + NestingDepth(value));
  } else if (const toml::array* a = node.as_array()) {
    for (const toml::node& value : *a) deepest = std::max(deepest, 1 + NestingDepth(value));
  }
  return deepest;
}

// Deeper than any job file needs; toml++ reads back at most 256 levels of what ToToml writes
// (dotted keys nest tables without counting towards its limit when parsed).
constexpr int kMaxNestingDepth = 64;

}  // namespace

Config Config::Parse(const std::string& text, const std::string& origin) {
  Config config;
  config.origin_ = origin;
  try {
    config.impl_->root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    std::ostringstream os;
    os << origin << ":" << e.source().begin.line << ":" << e.source().begin.column
       << ": not valid TOML: " << e.description();
    throw InvalidInputError(os.str());
  }
  const int depth = NestingDepth(config.impl_->root);
  if (depth > kMaxNestingDepth) {
    throw InvalidInputError(origin + ": tables and arrays nest " + std::to_string(depth) +
                            " levels deep; a job file needs a few, at most " +
                            std::to_string(kMaxNestingDepth));
  }
  return config;
}

bool Config::HasTable(const std::string& table) const {
  return FindTable(impl_->root, table) != nullptr;
}

bool Config::Has(const std::string& table, const std::string& key) const {
  const toml::table* t = FindTable(impl_->root, table);
  return t && t->contains(key) && !(*t)[key].is_table();
}

bool Config::IsArray(const std::string& table, const std::string& key) const {
  const toml::table* t = FindTable(impl_->root, table);
  return t && t->contains(key) && (*t)[key].is_array();
}

std::vector<std::string> Config::Keys(const std::string& table) const {
  std::vector<std::string> keys;
  const toml::table* t = FindTable(impl_->root, table);
  if (!t) return keys;
  for (auto&& [k, v] : *t) {
    if (!v.is_table()) keys.emplace_back(k.str());
  }
  return keys;
}

std::string Config::OriginOf(const std::string& table, const std::string& key) const {
  const auto it = value_origins_.find({table, key});
  return it == value_origins_.end() ? origin_ : it->second;
}

std::string Config::OriginsOf(const std::string& table) const {
  std::vector<std::string> origins;
  for (const std::string& key : Keys(table)) {
    const std::string origin = OriginOf(table, key);
    if (std::find(origins.begin(), origins.end(), origin) == origins.end()) {
      origins.push_back(origin);
    }
  }
  if (origins.empty()) return origin_;
  std::string joined;
  for (const auto& o : origins) joined += (joined.empty() ? "" : ", ") + o;
  return joined;
}

std::string Config::OriginOfCheck(const std::string& table, const std::string& why) const {
  const auto in_key = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  };
  size_t end = 0;
  while (end < why.size() && in_key(why[end])) ++end;
  const std::string key = why.substr(0, end);
  if (!key.empty() && Has(table, key)) return OriginOf(table, key);
  for (const std::string& group : Tables(table)) {
    if (!key.empty() && Has(table + "." + group, key)) return OriginOf(table + "." + group, key);
  }
  return OriginsOf(table);
}

std::pair<std::string, std::string> OptionPlace(const std::string& table, const std::string& key) {
  const size_t dot = key.find('.');
  if (dot == std::string::npos) return {table, key};
  return {table + "." + key.substr(0, dot), key.substr(dot + 1)};
}

void CheckOptionKeys(const Config& config, const std::string& table,
                     const std::vector<std::string>& keys) {
  // Valid names per table (the stage's own first), in Visit order.
  std::vector<std::pair<std::string, std::vector<std::string>>> valid = {{table, {}}};
  for (const std::string& key : keys) {
    const std::pair<std::string, std::string> place = OptionPlace(table, key);
    auto it = std::find_if(valid.begin(), valid.end(),
                           [&](const auto& v) { return v.first == place.first; });
    if (it == valid.end()) it = valid.insert(valid.end(), {place.first, {}});
    it->second.push_back(place.second);
  }
  const auto join = [](const std::vector<std::string>& names) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return list;
  };
  std::vector<std::string> groups;
  for (size_t i = 1; i < valid.size(); ++i) groups.push_back("[" + valid[i].first + "]");
  for (const auto& [where, names] : valid) {
    for (const std::string& key : config.Keys(where)) {
      if (std::find(names.begin(), names.end(), key) != names.end()) continue;
      std::string hint;
      for (const auto& [other, other_names] : valid) {
        if (other != where && std::find(other_names.begin(), other_names.end(), key) != other_names.end()) {
          hint = "; '" + key + "' belongs in [" + other + "]";
        }
      }
      throw InvalidInputError(config.OriginOf(where, key) + ": unknown key '" + key + "' in [" +
                              where + "]" + hint + "; valid keys: " + join(names) +
                              (where == table && !groups.empty() ? "; and the tables " + join(groups) : ""));
    }
    for (const std::string& sub_table : config.Tables(where)) {
      const std::string path = where + "." + sub_table;
      const bool is_group = where == table && std::any_of(valid.begin(), valid.end(),
                                                          [&](const auto& v) { return v.first == path; });
      if (is_group) continue;
      throw InvalidInputError(config.OriginsOf(path) + ": unknown table [" + path + "]" +
                              (where == table && !groups.empty()
                                   ? "; the option groups of [" + table + "] are " + join(groups)
                                   : "; [" + where + "] has no sub-tables"));
    }
  }
}

void Config::ForgetOrigin(const std::string& table, const std::string& key) {
  value_origins_.erase({table, key});
}

std::vector<std::string> Config::Tables(const std::string& table) const {
  std::vector<std::string> names;
  const toml::table* t = FindTable(impl_->root, table);
  if (!t) return names;
  for (auto&& [k, v] : *t) {
    if (v.is_table()) names.emplace_back(k.str());
  }
  return names;
}

namespace {

const toml::node& Node(const toml::table& root, const std::string& origin,
                       const std::string& table, const std::string& key) {
  const toml::table* t = FindTable(root, table);
  if (!t || !t->contains(key)) throw InvalidInputError(Where(origin, table, key) + " is missing");
  return *t->get(key);
}

[[noreturn]] void TypeError(const std::string& origin, const std::string& table,
                            const std::string& key, const char* expected, const toml::node& n) {
  std::ostringstream os;
  os << Where(origin, table, key) << " must be " << expected << ", got " << n.type();
  throw InvalidInputError(os.str());
}

// Every number option is finite: NaN and infinity pass no range check, so they are refused
// here for job files and --set alike, as the flags refuse them.
double NumberOf(const toml::node& n, const std::string& origin, const std::string& table,
                const std::string& key) {
  if (auto v = n.value_exact<double>()) {
    if (!std::isfinite(*v)) {
      throw InvalidInputError(Where(origin, table, key) + " must be a finite number, got " +
                              (std::isnan(*v) ? "nan" : "infinity"));
    }
    return *v;
  }
  if (auto v = n.value_exact<int64_t>()) return static_cast<double>(*v);
  TypeError(origin, table, key, "a number", n);
}

float FloatOf(const toml::node& n, const std::string& origin, const std::string& table,
              const std::string& key) {
  const double v = NumberOf(n, origin, table, key);
  if (std::abs(v) > std::numeric_limits<float>::max()) {
    throw InvalidInputError(Where(origin, table, key) + " is out of the 32-bit float range");
  }
  return static_cast<float>(v);
}


int64_t IntegerOf(const toml::node& n, const std::string& origin, const std::string& table,
                  const std::string& key) {
  if (auto v = n.value_exact<int64_t>()) return *v;
  TypeError(origin, table, key, "an integer", n);
}

}  // namespace

void Config::Get(const std::string& table, const std::string& key, bool* value) const {
  const std::string origin = OriginOf(table, key);
  const toml::node& n = Node(impl_->root, origin, table, key);
  if (auto v = n.value_exact<bool>()) *value = *v;
  else TypeError(origin, table, key, "true or false", n);
}

void Config::Get(const std::string& table, const std::string& key, int64_t* value) const {
  const std::string origin = OriginOf(table, key);
  *value = IntegerOf(Node(impl_->root, origin, table, key), origin, table, key);
}

namespace {

int Int32Of(const toml::node& n, const std::string& origin, const std::string& table,
            const std::string& key) {
  const int64_t v = IntegerOf(n, origin, table, key);
  if (v < INT32_MIN || v > INT32_MAX) {
    throw InvalidInputError(Where(origin, table, key) + " is out of the 32-bit integer range");
  }
  return static_cast<int>(v);
}

}  // namespace

void Config::Get(const std::string& table, const std::string& key, int* value) const {
  const std::string origin = OriginOf(table, key);
  *value = Int32Of(Node(impl_->root, origin, table, key), origin, table, key);
}

void Config::Get(const std::string& table, const std::string& key, double* value) const {
  const std::string origin = OriginOf(table, key);
  *value = NumberOf(Node(impl_->root, origin, table, key), origin, table, key);
}

void Config::Get(const std::string& table, const std::string& key, float* value) const {
  const std::string origin = OriginOf(table, key);
  *value = FloatOf(Node(impl_->root, origin, table, key), origin, table, key);
}

void Config::Get(const std::string& table, const std::string& key, std::string* value) const {
  const std::string origin = OriginOf(table, key);
  const toml::node& n = Node(impl_->root, origin, table, key);
  if (auto v = n.value_exact<std::string>()) *value = *v;
  else TypeError(origin, table, key, "a string", n);
}

namespace {

template <typename T, typename Convert>
void GetArray(const toml::node& n, const std::string& origin, const std::string& table,
              const std::string& key, std::vector<T>* out, Convert convert) {
  const toml::array* a = n.as_array();
  if (!a) TypeError(origin, table, key, "an array", n);
  out->clear();
  for (const toml::node& e : *a) out->push_back(convert(e));
}

}  // namespace

void Config::Get(const std::string& table, const std::string& key, std::vector<int>* value) const {
  const std::string origin = OriginOf(table, key);
  GetArray(Node(impl_->root, origin, table, key), origin, table, key, value,
           [&](const toml::node& e) { return Int32Of(e, origin, table, key); });
}

void Config::Get(const std::string& table, const std::string& key,
                 std::vector<float>* value) const {
  const std::string origin = OriginOf(table, key);
  GetArray(Node(impl_->root, origin, table, key), origin, table, key, value,
           [&](const toml::node& e) {
             return FloatOf(e, origin, table, key);
           });
}

void Config::Get(const std::string& table, const std::string& key,
                 std::vector<std::string>* value) const {
  const std::string origin = OriginOf(table, key);
  const toml::node& n = Node(impl_->root, origin, table, key);
  if (auto v = n.value_exact<std::string>()) {  // one string: a list of one
    *value = {*v};
    return;
  }
  GetArray(n, origin, table, key, value,
           [&](const toml::node& e) {
             if (auto v = e.value_exact<std::string>()) return *v;
             TypeError(origin, table, key, "an array of strings", e);
           });
}

void Config::Set(const std::string& table, const std::string& key, bool value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, value);
}
void Config::Set(const std::string& table, const std::string& key, int value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, static_cast<int64_t>(value));
}
void Config::Set(const std::string& table, const std::string& key, int64_t value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, value);
}
void Config::Set(const std::string& table, const std::string& key, float value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, static_cast<double>(value));
}
void Config::Set(const std::string& table, const std::string& key, double value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, value);
}
void Config::Set(const std::string& table, const std::string& key, const std::string& value) {
  ForgetOrigin(table, key);
  EnsureTable(impl_->root, table)->insert_or_assign(key, value);
}
void Config::Set(const std::string& table, const std::string& key, const std::vector<int>& value) {
  ForgetOrigin(table, key);
  toml::array a;
  for (int v : value) a.push_back(static_cast<int64_t>(v));
  EnsureTable(impl_->root, table)->insert_or_assign(key, std::move(a));
}
void Config::Set(const std::string& table, const std::string& key,
                 const std::vector<float>& value) {
  ForgetOrigin(table, key);
  toml::array a;
  for (float v : value) a.push_back(static_cast<double>(v));
  EnsureTable(impl_->root, table)->insert_or_assign(key, std::move(a));
}
void Config::Set(const std::string& table, const std::string& key,
                 const std::vector<std::string>& value) {
  ForgetOrigin(table, key);
  toml::array a;
  for (const auto& v : value) a.push_back(v);
  EnsureTable(impl_->root, table)->insert_or_assign(key, std::move(a));
}

void Config::SetFromText(const std::string& table, const std::string& key,
                         const std::string& text, const std::string& origin) {
  toml::table* t = EnsureTable(impl_->root, table);
  bool literal = false;
  try {
    // Exactly one literal: "3\nother = 4" parses, but is not one value.
    toml::table parsed = toml::parse("value = " + text);
    if (parsed.size() == 1) {
      t->insert_or_assign(key, *parsed.get("value"));
      literal = true;
    }
  } catch (const toml::parse_error&) {
  }
  if (!literal) t->insert_or_assign(key, text);
  if (origin.empty()) {
    ForgetOrigin(table, key);
  } else {
    value_origins_[{table, key}] = origin;
  }
}

void Config::SetAssignment(const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw InvalidInputError("--set " + assignment + ": expected table.key=value");
  }
  const std::string path = assignment.substr(0, eq);
  const size_t dot = path.rfind('.');
  if (dot == std::string::npos) {
    throw InvalidInputError("--set " + assignment + ": expected table.key=value");
  }
  SetFromText(path.substr(0, dot), path.substr(dot + 1), assignment.substr(eq + 1), "--set");
}

namespace {

// Whether `table` is the root or holds a valid table: [rig] of [rig.demo].
bool IsParentOfValid(const std::string& table, const std::vector<std::string>& valid) {
  if (table.empty()) return true;
  for (const auto& v : valid) {
    if (v.compare(0, table.size() + 1, table + ".") == 0) return true;
  }
  return false;
}

// The first value under `t` (depth first), as (table, key); empty when there is none.
std::pair<std::string, std::string> FirstValue(const toml::table& t, const std::string& path) {
  for (auto&& [k, v] : t) {
    if (!v.is_table()) return {path, std::string(k.str())};
  }
  for (auto&& [k, v] : t) {
    const std::string sub = path.empty() ? std::string(k.str()) : path + "." + std::string(k.str());
    auto found = FirstValue(*v.as_table(), sub);
    if (!found.second.empty()) return found;
  }
  return {};
}

}  // namespace

void Config::CheckTables(const std::vector<std::string>& valid) const {
  std::string list;
  for (const auto& v : valid) list += (list.empty() ? "" : ", ") + v;
  const auto check = [&](const auto& self, const toml::table& t, const std::string& path) -> void {
    const bool is_valid = std::find(valid.begin(), valid.end(), path) != valid.end();
    if (!is_valid && !IsParentOfValid(path, valid)) {
      const auto [table, key] = FirstValue(t, path);
      throw InvalidInputError((key.empty() ? origin_ : OriginOf(table, key)) +
                              ": unknown table [" + path + "]; valid tables: " + list);
    }
    for (auto&& [k, v] : t) {
      const std::string key(k.str());
      if (v.is_table()) {
        self(self, *v.as_table(), path.empty() ? key : path + "." + key);
      } else if (!is_valid) {
        throw InvalidInputError(OriginOf(path, key) + ": key '" + key + "' " +
                                (path.empty() ? std::string("outside any table")
                                              : "in [" + path + "], which is not a stage table") +
                                "; valid tables: " + list);
      }
    }
  };
  check(check, impl_->root, "");
}

void Config::CopyTable(const Config& other, const std::string& table) {
  const toml::table* src = FindTable(other.impl_->root, table);
  if (!src) return;
  const auto under = [&](const std::string& t) {
    return table.empty() || t == table || t.compare(0, table.size() + 1, table + ".") == 0;
  };
  for (auto it = value_origins_.begin(); it != value_origins_.end();) {
    it = under(it->first.first) ? value_origins_.erase(it) : std::next(it);
  }
  for (const auto& [where, origin] : other.value_origins_) {
    if (under(where.first)) value_origins_[where] = origin;
  }
  std::vector<std::string> parts = SplitDots(table);
  if (parts.empty()) {
    impl_->root = *src;
    return;
  }
  const std::string leaf = parts.back();
  parts.pop_back();
  std::string parent;
  for (const auto& p : parts) parent += (parent.empty() ? "" : ".") + p;
  EnsureTable(impl_->root, parent)->insert_or_assign(leaf, *src);
}

std::string Config::ToToml(const std::string& table) const {
  const toml::table* t = FindTable(impl_->root, table);
  if (!t) return "";
  std::ostringstream os;
  os << toml::toml_formatter{*t};
  return os.str();
}

}  // namespace facecap::io
