// The files a stage reads and writes, named by its options, and the checks made on them
// before any work: an output never resolves to one of the stage's inputs (nor, under
// `facecap run`, to another stage's input or output), a file output is not a folder, and an
// output's extension is one its format has.
#ifndef FACECAP_STAGES_STAGE_PATHS_H_
#define FACECAP_STAGES_STAGE_PATHS_H_

#include <string>
#include <vector>

namespace facecap::stages {

// What an output option names, for its extension check.
enum class OutputKind {
  kHdf5,    // .h5 or .hdf5
  kImage,   // .png, .jpg, .jpeg, .exr, .tif, .tiff
  kVideo,   // .mp4
  kGltf,    // .glb or .gltf
  kMesh,    // .obj, .glb or .gltf
  kCsv,     // .csv
  kAudio,   // .wav
  kText,    // any name (JSON, Markdown)
  kFolder,  // a folder (made when absent)
};

struct OutputKey {
  std::string key;  // option key, e.g. "out"
  OutputKind kind = OutputKind::kHdf5;
};

// Which options of a stage name files: the keys of its inputs (a list option names several
// files) and of its outputs. Empty values are options not used.
struct PathKeys {
  std::vector<std::string> inputs;
  std::vector<OutputKey> outputs;
};

struct NamedPath {
  std::string key;   // option key, or a description of a derived file ("out + .checkpoint")
  std::string path;  // as given
  OutputKind kind = OutputKind::kText;  // outputs only
};

// The resolved files of one stage run.
struct StagePaths {
  std::string table;
  std::vector<NamedPath> inputs;
  std::vector<NamedPath> outputs;
};

// `path` without its .h5, followed by suffix: the name of a file written beside an output.
std::string WithSuffix(const std::string& path, const std::string& suffix);

// The path with `.`, `..` and symbolic links resolved (as far as it exists), absolute.
std::string CanonicalPath(const std::string& path);

// InvalidInputError (exit 2) naming both options and files when an output resolves to an
// input or to another output of the stage, when a file output is an existing folder, or when
// its extension is not one of its kind's.
void CheckStagePaths(const StagePaths& paths);

// The same across the stages of a job, in run order: InvalidInputError when a stage's output
// is an input of itself or of an earlier stage (a cycle: reruns would overwrite each other's
// inputs forever), or when two stages write the same file.
void CheckJobPaths(const std::vector<StagePaths>& stages, const std::string& job);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_STAGE_PATHS_H_
