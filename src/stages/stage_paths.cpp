#include "stages/stage_paths.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "util/errors.h"

namespace facecap::stages {
namespace fs = std::filesystem;

std::string WithSuffix(const std::string& path, const std::string& suffix) {
  std::string stem = path;
  if (stem.size() > 3 && stem.compare(stem.size() - 3, 3, ".h5") == 0) stem.resize(stem.size() - 3);
  return stem + suffix;
}

std::string CanonicalPath(const std::string& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec) return path;
  fs::path canonical = fs::weakly_canonical(absolute, ec);
  return ec ? absolute.lexically_normal().string() : canonical.string();
}

namespace {

// True when a and b name the same file: the same canonical path, or (both existing) the same
// inode, as hard links are.
bool SameFile(const std::string& a, const std::string& b) {
  if (CanonicalPath(a) == CanonicalPath(b)) return true;
  std::error_code ec;
  return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec) && !ec;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The extensions a kind accepts; empty: any.
std::vector<std::string> Extensions(OutputKind kind) {
  switch (kind) {
    case OutputKind::kHdf5: return {".h5", ".hdf5"};
    case OutputKind::kImage: return {".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff"};
    case OutputKind::kVideo: return {".mp4"};
    case OutputKind::kGltf: return {".glb", ".gltf"};
    case OutputKind::kMesh: return {".obj", ".glb", ".gltf"};
    case OutputKind::kCsv: return {".csv"};
    case OutputKind::kAudio: return {".wav"};
    case OutputKind::kText:
    case OutputKind::kFolder: return {};
  }
  return {};
}

std::string Label(const std::string& table, const NamedPath& p) {
  return "[" + table + "] " + p.key + " '" + p.path + "'";
}

}  // namespace

void CheckStagePaths(const StagePaths& paths) {
  for (size_t i = 0; i < paths.outputs.size(); ++i) {
    const NamedPath& out = paths.outputs[i];
    if (out.path.empty()) continue;
    for (const NamedPath& in : paths.inputs) {
      if (!in.path.empty() && SameFile(out.path, in.path)) {
        throw InvalidInputError(Label(paths.table, out) + " is the input " + in.key + " '" +
                                in.path + "'; an output never replaces an input: choose "
                                "another output name");
      }
    }
    for (size_t j = 0; j < i; ++j) {
      const NamedPath& other = paths.outputs[j];
      if (!other.path.empty() && SameFile(out.path, other.path)) {
        throw InvalidInputError(Label(paths.table, out) + " is also its output " + other.key +
                                " '" + other.path + "'; give each output its own name");
      }
    }
    std::error_code ec;
    if (out.kind != OutputKind::kFolder && fs::is_directory(out.path, ec)) {
      throw InvalidInputError(Label(paths.table, out) + " is a folder; it must name a file");
    }
    if (out.kind == OutputKind::kFolder && fs::exists(out.path, ec) &&
        !fs::is_directory(out.path, ec)) {
      throw InvalidInputError(Label(paths.table, out) + " is a file; it must name a folder");
    }
    const std::vector<std::string> extensions = Extensions(out.kind);
    const std::string extension = Lower(fs::path(out.path).extension().string());
    if (!extensions.empty() &&
        std::find(extensions.begin(), extensions.end(), extension) == extensions.end()) {
      std::string list;
      for (const std::string& e : extensions) list += (list.empty() ? "" : ", ") + e;
      throw InvalidInputError(Label(paths.table, out) + " must end in " + list);
    }
  }
}

void CheckJobPaths(const std::vector<StagePaths>& stages, const std::string& job) {
  for (size_t i = 0; i < stages.size(); ++i) {
    for (const NamedPath& out : stages[i].outputs) {
      if (out.path.empty()) continue;
      for (size_t j = 0; j <= i; ++j) {
        for (const NamedPath& in : stages[j].inputs) {
          if (in.path.empty() || !SameFile(out.path, in.path)) continue;
          throw InvalidInputError(
              job + ": " + Label(stages[i].table, out) + " is the input " + in.key + " '" +
              in.path + "' of [" + stages[j].table + "], which runs " +
              (j == i ? "as the same stage" : "before it") +
              "; a stage's output must be read only by later stages");
        }
        if (j == i) continue;
        for (const NamedPath& other : stages[j].outputs) {
          if (other.path.empty() || !SameFile(out.path, other.path)) continue;
          throw InvalidInputError(job + ": " + Label(stages[i].table, out) + " is also " +
                                  Label(stages[j].table, other) +
                                  "; two stages never write the same file");
        }
      }
    }
  }
}

}  // namespace facecap::stages
