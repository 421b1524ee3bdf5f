// Shared by the fuzz targets: a scratch directory per process, and the structure-aware HDF5
// description the HDF5 targets decode their input into.
//
// An HDF5 target starts from a well-formed description of the file its reader expects (built
// from a few leading parameters: frame count, shape count, ...), then applies the edits that
// the rest of the input encodes, one after another: remove a dataset, change its element type
// (uint8, int32, int64, float32, float64 or strings, the types io::H5File writes), change its
// rank or dimensions (small), move one dimension by one, overwrite one value or all of them
// (special values such as NaN, infinity, -1, INT32_MAX, or values from the input), replace a
// string, turn a dataset into a group, add, remove or retype an attribute. The result is
// written with io::H5File to a scratch file that the reader then opens. An empty input is the
// well-formed file.
#ifndef FACECAP_TESTS_FUZZ_FUZZ_SUPPORT_H_
#define FACECAP_TESTS_FUZZ_FUZZ_SUPPORT_H_

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "io/hdf5.h"
#include "rig/rig.h"
#include "util/errors.h"

namespace facecap::fuzz {

// The scratch directory of this process: $FACECAP_FUZZ_SCRATCH when set, else /dev/shm when
// it is writable, else $TMPDIR or /tmp; a subdirectory named after the process id.
inline const std::string& ScratchDir() {
  static const std::string dir = [] {
    std::string base = "/tmp";
    if (const char* t = std::getenv("TMPDIR"); t && *t) base = t;
    if (access("/dev/shm", W_OK) == 0) base = "/dev/shm";
    if (const char* s = std::getenv("FACECAP_FUZZ_SCRATCH"); s && *s) base = s;
    const std::string d = base + "/facecap_fuzz_" + std::to_string(getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline void RemoveScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(ScratchDir(), ec);
}

// A file name in the scratch directory, which is removed at a normal exit.
inline std::string ScratchPath(const std::string& name) {
  static const bool registered = [] {
    ScratchDir();
    return std::atexit(RemoveScratchDir) == 0;
  }();
  (void)registered;
  return ScratchDir() + "/" + name;
}

// Aborts with a message: a finding the sanitizers would not report by themselves.
[[noreturn]] inline void Fail(const std::string& what) {
  std::fprintf(stderr, "FUZZ FAILURE: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

// A reader's error must name the file it could not read.
inline void ExpectNamesFile(const Error& e, const std::string& path) {
  if (std::string(e.what()).find(path) == std::string::npos) {
    Fail(std::string("error does not name the file ") + path + ": " + e.what());
  }
}

// ---- the file description -------------------------------------------------------------------

enum class Kind { kUInt8, kInt32, kInt64, kFloat32, kFloat64, kStrings };
constexpr int kNumKinds = 6;

inline const char* KindName(Kind k) {
  switch (k) {
    case Kind::kUInt8: return "u8";
    case Kind::kInt32: return "i32";
    case Kind::kInt64: return "i64";
    case Kind::kFloat32: return "f32";
    case Kind::kFloat64: return "f64";
    case Kind::kStrings: return "str";
  }
  return "?";
}

struct Dataset {
  Kind kind = Kind::kFloat32;
  io::Shape shape;                   // rank 1 for strings
  std::vector<double> values;        // numeric kinds: NumElements(shape), row-major
  std::vector<std::string> strings;  // kStrings: shape[0] strings
};

struct Attribute {
  enum Type { kString, kDouble, kInt, kDoubles } type = kDouble;
  std::string text;
  double number = 0.;
  int64_t integer = 0;
  std::vector<double> numbers;
};

struct FileSpec {
  std::map<std::string, Dataset> datasets;                            // by absolute name
  std::vector<std::string> groups;                                    // groups to create
  std::map<std::pair<std::string, std::string>, Attribute> attributes;  // (object, name)
};

inline int64_t Elements(const io::Shape& shape) {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

inline Dataset Numeric(Kind kind, io::Shape shape, std::vector<double> values) {
  Dataset d;
  d.kind = kind;
  d.shape = std::move(shape);
  d.values = std::move(values);
  d.values.resize(Elements(d.shape), 0.);
  return d;
}

inline Dataset Filled(Kind kind, io::Shape shape, double value) {
  return Numeric(kind, shape, std::vector<double>(Elements(shape), value));
}

inline Dataset Strings(std::vector<std::string> strings) {
  Dataset d;
  d.kind = Kind::kStrings;
  d.shape = {static_cast<int64_t>(strings.size())};
  d.strings = std::move(strings);
  return d;
}

inline Attribute StringAttribute(std::string text) {
  Attribute a;
  a.type = Attribute::kString;
  a.text = std::move(text);
  return a;
}

inline Attribute DoubleAttribute(double value) {
  Attribute a;
  a.type = Attribute::kDouble;
  a.number = value;
  return a;
}

// Saturating conversion of a description value to the stored element type (the harness
// itself must not convert NaN or out-of-range values with undefined behaviour).
template <typename T>
T Saturate(double x) {
  if constexpr (std::is_integral_v<T>) {
    if (std::isnan(x)) return 0;
    if (x <= static_cast<double>(std::numeric_limits<T>::lowest())) {
      return std::numeric_limits<T>::lowest();
    }
    if (x >= static_cast<double>(std::numeric_limits<T>::max())) {
      return std::numeric_limits<T>::max();
    }
    return static_cast<T>(x);
  } else {
    if (std::isnan(x) || std::isinf(x)) return static_cast<T>(x);
    const double limit = static_cast<double>(std::numeric_limits<T>::max());
    return static_cast<T>(std::clamp(x, -limit, limit));
  }
}

template <typename T>
void WriteNumeric(io::H5File* file, const std::string& name, const Dataset& d) {
  std::vector<T> data(d.values.size());
  for (size_t i = 0; i < data.size(); ++i) data[i] = Saturate<T>(d.values[i]);
  file->Write<T>(name, d.shape, data.data());
}

// Writes the description with io::H5File; false when the writer refuses it (OutputError),
// e.g. a dataset below another dataset.
inline bool WriteSpec(const FileSpec& spec, const std::string& path) {
  std::error_code ec;
  std::filesystem::remove(path, ec);
  try {
    io::H5File file = io::H5File::CreateAtomic(path);
    for (const std::string& g : spec.groups) file.CreateGroups(g + "/x");
    for (const auto& [name, d] : spec.datasets) {
      switch (d.kind) {
        case Kind::kUInt8: WriteNumeric<uint8_t>(&file, name, d); break;
        case Kind::kInt32: WriteNumeric<int32_t>(&file, name, d); break;
        case Kind::kInt64: WriteNumeric<int64_t>(&file, name, d); break;
        case Kind::kFloat32: WriteNumeric<float>(&file, name, d); break;
        case Kind::kFloat64: WriteNumeric<double>(&file, name, d); break;
        case Kind::kStrings: file.WriteStrings(name, d.strings); break;
      }
    }
    for (const auto& [where, a] : spec.attributes) {
      const auto& [object, name] = where;
      if (!file.Exists(object)) continue;  // nothing to attach it to
      switch (a.type) {
        case Attribute::kString: file.SetAttribute(object, name, a.text); break;
        case Attribute::kDouble: file.SetAttribute(object, name, a.number); break;
        case Attribute::kInt: file.SetAttribute(object, name, a.integer); break;
        case Attribute::kDoubles: file.SetAttribute(object, name, a.numbers); break;
      }
    }
    file.Commit();
  } catch (const OutputError&) {
    return false;
  }
  return true;
}

// The description in words, for FACECAP_FUZZ_DESCRIBE=1 (reproducing and writing seeds).
inline std::string Describe(const FileSpec& spec) {
  std::string out;
  for (const auto& g : spec.groups) out += "group " + g + "\n";
  for (const auto& [name, d] : spec.datasets) {
    out += name + " " + KindName(d.kind) + " " + io::ShapeToString(d.shape);
    const size_t shown = d.kind == Kind::kStrings ? d.strings.size() : d.values.size();
    out += " {";
    for (size_t i = 0; i < std::min<size_t>(shown, 8); ++i) {
      out += i ? ", " : "";
      if (d.kind == Kind::kStrings) {
        out += "\"" + d.strings[i] + "\"";
      } else {
        char buf[32];
        std::snprintf(buf, sizeof(buf), "%g", d.values[i]);
        out += buf;
      }
    }
    out += shown > 8 ? ", ...}\n" : "}\n";
  }
  for (const auto& [where, a] : spec.attributes) {
    out += where.first + "@" + where.second + " = ";
    switch (a.type) {
      case Attribute::kString: out += "\"" + a.text + "\""; break;
      case Attribute::kDouble: out += std::to_string(a.number); break;
      case Attribute::kInt: out += std::to_string(a.integer) + " (int)"; break;
      case Attribute::kDoubles: out += "[" + std::to_string(a.numbers.size()) + " doubles]"; break;
    }
    out += "\n";
  }
  return out;
}

inline bool DescribeRequested() {
  static const bool on = std::getenv("FACECAP_FUZZ_DESCRIBE") != nullptr;
  return on;
}

// ---- decoding the edits ------------------------------------------------------------------------

// A value for a dataset element or attribute: one of the values that break readers most often,
// or one taken from the input.
inline double ConsumeValue(FuzzedDataProvider& in) {
  static const double kSpecial[] = {
      0.,  1.,   -1.,  2.,   3.,   68.,  0.5,  std::nan(""),
      std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
      1e30, -1e30, 2147483647., -2147483648., 4294967296., 255., 256., 1e-30, 40., 640.,
      -0.,  9.3e18, -9.3e18, 1e300};
  constexpr int kNumSpecial = sizeof(kSpecial) / sizeof(kSpecial[0]);
  const int pick = in.ConsumeIntegralInRange<int>(0, kNumSpecial + 1);
  if (pick < kNumSpecial) return kSpecial[pick];
  if (pick == kNumSpecial) return static_cast<double>(in.ConsumeIntegralInRange<int>(-100, 1000));
  return in.ConsumeFloatingPoint<double>();
}

inline std::string ConsumeName(FuzzedDataProvider& in, const std::vector<std::string>& pool) {
  const size_t pick = in.ConsumeIntegralInRange<size_t>(0, pool.size());
  if (pick < pool.size()) return pool[pick];
  return in.ConsumeRandomLengthString(24);
}

// Resizes a dataset's data to its shape (new elements 0 or the empty string).
inline void Conform(Dataset* d) {
  if (d->kind == Kind::kStrings) {
    if (d->shape.size() != 1) d->shape = {static_cast<int64_t>(d->strings.size())};
    d->strings.resize(d->shape[0]);
    d->values.clear();
  } else {
    d->values.resize(Elements(d->shape), 0.);
    d->strings.clear();
  }
}

// The datasets and attributes a reader looks at: what the edits pick from.
struct Slots {
  std::vector<std::string> datasets;
  std::vector<std::pair<std::string, std::string>> attributes;
  std::vector<std::string> names;  // strings that a string dataset may hold
};

inline constexpr int kMaxEdits = 48;
inline constexpr int64_t kMaxDim = 8;

inline void ApplyEdits(FuzzedDataProvider& in, const Slots& slots, FileSpec* spec) {
  for (int edit = 0; edit < kMaxEdits && in.remaining_bytes() > 0; ++edit) {
    const int op = in.ConsumeIntegralInRange<int>(0, 9);
    if (op == 9) {  // attribute
      if (slots.attributes.empty()) continue;
      const auto& where =
          slots.attributes[in.ConsumeIntegralInRange<size_t>(0, slots.attributes.size() - 1)];
      Attribute a;
      switch (in.ConsumeIntegralInRange<int>(0, 4)) {
        case 0: spec->attributes.erase(where); continue;
        case 1: a.type = Attribute::kString; a.text = in.ConsumeRandomLengthString(16); break;
        case 2: a.type = Attribute::kDouble; a.number = ConsumeValue(in); break;
        case 3: a.type = Attribute::kInt; a.integer = in.ConsumeIntegral<int64_t>(); break;
        default: {
          a.type = Attribute::kDoubles;
          const int n = in.ConsumeIntegralInRange<int>(0, 5);
          for (int i = 0; i < n; ++i) a.numbers.push_back(ConsumeValue(in));
        }
      }
      spec->attributes[where] = a;
      continue;
    }
    const std::string& name =
        slots.datasets[in.ConsumeIntegralInRange<size_t>(0, slots.datasets.size() - 1)];
    auto it = spec->datasets.find(name);
    if (op == 0) {  // remove, or restore an empty one of the kind asked for
      if (it != spec->datasets.end()) {
        spec->datasets.erase(it);
      } else {
        Dataset d;
        d.kind = static_cast<Kind>(in.ConsumeIntegralInRange<int>(0, kNumKinds - 1));
        d.shape = {0};
        Conform(&d);
        spec->datasets[name] = d;
      }
      continue;
    }
    if (op == 8) {  // a group where the dataset was
      if (it != spec->datasets.end()) spec->datasets.erase(it);
      spec->datasets[name + "/x"] = Filled(Kind::kUInt8, {1}, 0.);
      continue;
    }
    if (it == spec->datasets.end()) continue;
    Dataset& d = it->second;
    switch (op) {
      case 1: {  // element type
        const Kind kind = static_cast<Kind>(in.ConsumeIntegralInRange<int>(0, kNumKinds - 1));
        if ((kind == Kind::kStrings) != (d.kind == Kind::kStrings)) {
          if (kind == Kind::kStrings) {
            d.strings.clear();
            for (double v : d.values) d.strings.push_back(std::to_string(v));
            d.shape = {static_cast<int64_t>(d.strings.size())};
          } else {
            d.values.assign(d.strings.size(), 0.);
          }
        }
        d.kind = kind;
        Conform(&d);
        break;
      }
      case 2: {  // rank and dimensions; each dimension kept or new
        const int rank = in.ConsumeIntegralInRange<int>(0, 4);
        io::Shape shape(rank);
        for (int i = 0; i < rank; ++i) {
          const bool keep = i < static_cast<int>(d.shape.size()) && in.ConsumeBool();
          shape[i] = keep ? d.shape[i] : in.ConsumeIntegralInRange<int64_t>(0, kMaxDim);
        }
        d.shape = shape;
        Conform(&d);
        break;
      }
      case 3: {  // one dimension one off
        if (d.shape.empty()) break;
        int64_t& dim = d.shape[in.ConsumeIntegralInRange<size_t>(0, d.shape.size() - 1)];
        dim = in.ConsumeBool() ? dim + 1 : std::max<int64_t>(0, dim - 1);
        Conform(&d);
        break;
      }
      case 4: {  // one value
        const size_t n = d.kind == Kind::kStrings ? d.strings.size() : d.values.size();
        if (n == 0) break;
        const size_t i = in.ConsumeIntegral<uint16_t>() % n;
        if (d.kind == Kind::kStrings) {
          d.strings[i] = ConsumeName(in, slots.names);
        } else {
          d.values[i] = ConsumeValue(in);
        }
        break;
      }
      case 5: {  // every value
        if (d.kind == Kind::kStrings) {
          const std::string s = ConsumeName(in, slots.names);
          std::fill(d.strings.begin(), d.strings.end(), s);
        } else {
          std::fill(d.values.begin(), d.values.end(), ConsumeValue(in));
        }
        break;
      }
      case 6: {  // a run of values from the input
        if (d.values.empty()) break;
        size_t i = in.ConsumeIntegral<uint16_t>() % d.values.size();
        const int n = in.ConsumeIntegralInRange<int>(1, 16);
        for (int k = 0; k < n && i < d.values.size(); ++k, ++i) d.values[i] = ConsumeValue(in);
        break;
      }
      case 7: {  // strings: one more or one fewer
        if (d.kind != Kind::kStrings) break;
        if (in.ConsumeBool()) {
          d.strings.push_back(ConsumeName(in, slots.names));
        } else if (!d.strings.empty()) {
          d.strings.pop_back();
        }
        d.shape = {static_cast<int64_t>(d.strings.size())};
        break;
      }
      default: break;
    }
  }
}

// ---- a small valid rig -----------------------------------------------------------------------

// A tetrahedron rig: 4 vertices, 4 triangles with texture coordinates, two regions, jaw
// skinning, three shapes (jawOpen drives the jaw; mouthSmileLeft has no delta), 68 landmarks
// (when `landmarks`) and `modes` identity modes. It passes Rig::Check.
inline rig::Rig SmallRig(bool uvs = true, bool landmarks = true, int modes = 2) {
  rig::Rig r;
  r.neutral.resize(4, 3);
  r.neutral << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  r.triangles.resize(4, 3);
  r.triangles << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  if (uvs) {
    r.uvs.resize(4, 2);
    r.uvs << 0, 0, 1, 0, 0, 1, 1, 1;
    r.uv_triangles = r.triangles;
  }
  r.regions = {{"skin", Eigen::Vector3f(0.8f, 0.6f, 0.5f)}, {"lips", Eigen::Vector3f(1, 0, 0)}};
  r.triangle_region.resize(4);
  r.triangle_region << 0, 0, 1, 1;
  r.jaw_weights.resize(4);
  r.jaw_weights << 0.f, 0.f, 0.5f, 1.f;
  r.jaw_pivot = Eigen::Vector3f(0.f, -1.f, 0.f);
  rig::Shape jaw;
  jaw.name = "jawOpen";
  jaw.delta.vertex = {2, 3};
  jaw.delta.offset = {Eigen::Vector3f(0.f, -0.1f, 0.f), Eigen::Vector3f(0.f, -0.2f, 0.1f)};
  jaw.jaw_euler = Eigen::Vector3f(0.2f, 0.f, 0.f);
  jaw.jaw_translation = Eigen::Vector3f(0.f, 0.f, 0.1f);
  rig::Shape blink;
  blink.name = "eyeBlinkLeft";
  blink.delta.vertex = {0};
  blink.delta.offset = {Eigen::Vector3f(0.05f, 0.f, 0.f)};
  rig::Shape smile;
  smile.name = "mouthSmileLeft";
  r.shapes = {jaw, blink, smile};
  if (landmarks) {
    r.landmarks.resize(68);
    for (int l = 0; l < 68; ++l) r.landmarks[l] = l % 4;
  }
  for (int k = 0; k < modes; ++k) {
    rig::Vertices m = rig::Vertices::Constant(4, 3, 0.01f * static_cast<float>(k + 1));
    r.identity_modes.push_back(m);
  }
  return r;
}

// The datasets io::WriteRig writes for `r` under `group` (rig_io.h lists the layout).
inline void AddRig(const rig::Rig& r, const std::string& group, FileSpec* spec) {
  const std::string g = group + "/";
  auto matrix = [](Kind kind, const auto& m) {
    std::vector<double> v;
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      for (Eigen::Index j = 0; j < m.cols(); ++j) v.push_back(static_cast<double>(m(i, j)));
    }
    return Numeric(kind, {static_cast<int64_t>(m.rows()), static_cast<int64_t>(m.cols())}, v);
  };
  auto vector = [](Kind kind, const auto& m) {
    std::vector<double> v;
    for (Eigen::Index i = 0; i < m.size(); ++i) v.push_back(static_cast<double>(m[i]));
    return Numeric(kind, {static_cast<int64_t>(m.size())}, v);
  };
  const int64_t V = r.NumVertices(), S = r.NumShapes();
  auto& d = spec->datasets;
  d[g + "neutral"] = matrix(Kind::kFloat32, r.neutral);
  d[g + "triangles"] = matrix(Kind::kInt32, r.triangles);
  d[g + "uvs"] = r.uvs.rows() ? matrix(Kind::kFloat32, r.uvs) : Numeric(Kind::kFloat32, {0, 2}, {});
  d[g + "uv_triangles"] = r.uv_triangles.rows() ? matrix(Kind::kInt32, r.uv_triangles)
                                                : Numeric(Kind::kInt32, {0, 3}, {});
  d[g + "triangle_region"] = vector(Kind::kInt32, r.triangle_region);
  std::vector<std::string> region_names;
  std::vector<double> colors;
  for (const auto& region : r.regions) {
    region_names.push_back(region.name);
    for (int c = 0; c < 3; ++c) colors.push_back(region.color[c]);
  }
  d[g + "regions/names"] = Strings(region_names);
  d[g + "regions/colors"] =
      Numeric(Kind::kFloat32, {static_cast<int64_t>(r.regions.size()), 3}, colors);
  d[g + "jaw/weights"] = vector(Kind::kFloat32, r.jaw_weights);
  d[g + "jaw/pivot"] = vector(Kind::kFloat32, r.jaw_pivot);
  std::vector<std::string> names;
  std::vector<double> euler, translation, offset, vertex, row_offsets{0.};
  for (const auto& shape : r.shapes) {
    names.push_back(shape.name);
    for (int c = 0; c < 3; ++c) {
      euler.push_back(shape.jaw_euler[c]);
      translation.push_back(shape.jaw_translation[c]);
    }
    for (size_t k = 0; k < shape.delta.vertex.size(); ++k) {
      vertex.push_back(shape.delta.vertex[k]);
      for (int c = 0; c < 3; ++c) offset.push_back(shape.delta.offset[k][c]);
    }
    row_offsets.push_back(static_cast<double>(vertex.size()));
  }
  d[g + "shapes/names"] = Strings(names);
  d[g + "shapes/jaw_euler"] = Numeric(Kind::kFloat32, {S, 3}, euler);
  d[g + "shapes/jaw_translation"] = Numeric(Kind::kFloat32, {S, 3}, translation);
  d[g + "shapes/deltas/row_offsets"] = Numeric(Kind::kInt64, {S + 1}, row_offsets);
  d[g + "shapes/deltas/vertex"] =
      Numeric(Kind::kInt32, {static_cast<int64_t>(vertex.size())}, vertex);
  d[g + "shapes/deltas/offset"] =
      Numeric(Kind::kFloat32, {static_cast<int64_t>(vertex.size()), 3}, offset);
  d[g + "landmarks"] = vector(Kind::kInt32, r.landmarks);
  std::vector<double> modes;
  for (const auto& m : r.identity_modes) {
    for (Eigen::Index i = 0; i < m.size(); ++i) modes.push_back(m.data()[i]);
  }
  d[g + "identity_modes"] =
      Numeric(Kind::kFloat32, {static_cast<int64_t>(r.identity_modes.size()), V, 3}, modes);
}

// One input of a structure-aware HDF5 target: the file `base` describes, with the edits the
// rest of the input makes to `slots`, written as the scratch file `name` and given to `read`
// (the reader, then the accessors a stage calls). A FileIOError must name the file.
template <typename Base, typename Read>
int RunHdf5Input(const uint8_t* data, size_t size, Base base, const Slots& slots,
                 const std::string& name, Read read) {
  FuzzedDataProvider in(data, size);
  FileSpec spec = base(in);
  ApplyEdits(in, slots, &spec);
  if (DescribeRequested()) std::fprintf(stderr, "%s", Describe(spec).c_str());
  const std::string path = ScratchPath(name);
  if (!WriteSpec(spec, path)) return 0;
  try {
    read(path);
  } catch (const FileIOError& e) {
    if (DescribeRequested()) std::fprintf(stderr, "FileIOError: %s\n", e.what());
    ExpectNamesFile(e, path);
  }
  return 0;
}

}  // namespace facecap::fuzz

#endif  // FACECAP_TESTS_FUZZ_FUZZ_SUPPORT_H_
