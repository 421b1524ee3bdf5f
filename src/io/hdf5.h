// HDF5 behind RAII handles: typed reads and writes of Eigen matrices, strings, images and
// frame-major datasets (chunked, deflate, extendible), attributes, provenance, atomic files.
// No HDF5 header leaks out of io/: handles are plain int64 ids here.
//
// Every failure throws FileIOError (reading) or OutputError (writing) with the file, the
// dataset and what was expected, e.g.
//   samples.h5: dataset /frames/segmentation has shape [4000, 128, 128, 3], expected [*, 64, 64, 3]
#ifndef FACECAP_IO_HDF5_H_
#define FACECAP_IO_HDF5_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "util/image.h"

namespace facecap::io {

// Element types that the typed calls accept.
enum class H5Type { kUInt8, kInt32, kInt64, kFloat32, kFloat64 };
template <typename T> constexpr H5Type H5TypeOf();
template <> constexpr H5Type H5TypeOf<uint8_t>() { return H5Type::kUInt8; }
template <> constexpr H5Type H5TypeOf<int32_t>() { return H5Type::kInt32; }
template <> constexpr H5Type H5TypeOf<int64_t>() { return H5Type::kInt64; }
template <> constexpr H5Type H5TypeOf<float>() { return H5Type::kFloat32; }
template <> constexpr H5Type H5TypeOf<double>() { return H5Type::kFloat64; }

using Shape = std::vector<int64_t>;
std::string ShapeToString(const Shape& shape);  // "[4000, 128, 128, 3]"

// What a stage tells H5File::WriteProvenance for the root attributes every facecap file
// carries (WriteProvenance adds the version, commit, time and configuration hash).
struct Provenance {
  std::string stage;         // "synth samples"
  std::string command_line;  // the full command line
  std::string config;        // the resolved TOML configuration
  int mpi_ranks = 1;
};

class H5File {
 public:
  // Opens an existing file read-only.
  static H5File OpenRead(const std::string& path);
  // Opens an existing file for reading and writing.
  static H5File OpenReadWrite(const std::string& path);
  // Creates `path + ".partial"` (truncating it); Commit() renames it to `path`. A file that
  // is never committed stays as ".partial" and is never mistaken for a finished output.
  static H5File CreateAtomic(const std::string& path);
  // Opens `path + ".partial"` to continue a resumable stage when it exists and is a valid
  // HDF5 file, otherwise creates it. *resumed tells which.
  static H5File OpenOrCreatePartial(const std::string& path, bool* resumed);
  static std::string PartialPath(const std::string& path) { return path + ".partial"; }
  static bool IsHdf5(const std::string& path);

  H5File() = default;
  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&& other) noexcept;
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;
  ~H5File();

  // Flushes, closes and renames the ".partial" file to its final name.
  void Commit();
  void Flush();
  void Close();
  const std::string& path() const { return path_; }        // the final name
  const std::string& disk_path() const { return disk_path_; }  // where the bytes are now
  bool is_open() const { return id_ >= 0; }

  // --- structure ---
  bool Exists(const std::string& name) const;  // a dataset or group at /a/b/c
  void CreateGroups(const std::string& name);  // creates /a and /a/b for name /a/b/c
  Shape DatasetShape(const std::string& name) const;
  void Remove(const std::string& name);
  // Copies dataset or group `name` (recursively, with attributes) from `source` to the same
  // name here, creating missing parent groups; FileIOError when the copy fails.
  void CopyFrom(const H5File& source, const std::string& name);

  // --- whole datasets ---
  // Writes (replacing) a dataset of `shape` from `data` (row-major). Datasets above 1 MiB are
  // chunked and deflate-compressed.
  template <typename T>
  void Write(const std::string& name, const Shape& shape, const T* data) {
    WriteRaw(name, H5TypeOf<T>(), shape, data);
  }
  // Reads a whole dataset; `expected` may hold -1 for "any" in each dimension and must have
  // the dataset's rank (empty: any shape).
  template <typename T>
  std::vector<T> Read(const std::string& name, const Shape& expected, Shape* shape = nullptr) const {
    Shape s = CheckShape(name, expected);
    std::vector<T> out(NumElements(s));
    ReadRaw(name, H5TypeOf<T>(), out.data());
    if (shape) *shape = s;
    return out;
  }

  // Eigen matrices (any storage order; stored row-major as [rows, cols]).
  template <typename Derived>
  void WriteMatrix(const std::string& name, const Eigen::DenseBase<Derived>& m) {
    using T = typename Derived::Scalar;
    Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rm = m;
    Write<T>(name, {static_cast<int64_t>(rm.rows()), static_cast<int64_t>(rm.cols())}, rm.data());
  }
  template <typename T>
  Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> ReadMatrix(
      const std::string& name, int64_t rows = -1, int64_t cols = -1) const {
    Shape s;
    std::vector<T> v = Read<T>(name, {rows, cols}, &s);
    Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(s[0], s[1]);
    std::copy(v.begin(), v.end(), m.data());
    return m;
  }
  template <typename T>
  void WriteVector(const std::string& name, const std::vector<T>& v) {
    Write<T>(name, {static_cast<int64_t>(v.size())}, v.data());
  }
  template <typename T>
  std::vector<T> ReadVector(const std::string& name, int64_t size = -1) const {
    return Read<T>(name, {size});
  }
  void WriteStrings(const std::string& name, const std::vector<std::string>& strings);
  std::vector<std::string> ReadStrings(const std::string& name, int64_t size = -1) const;
  void WriteImage(const std::string& name, const Image8& image);
  Image8 ReadImage(const std::string& name) const;

  // --- frame-major datasets: [frames, ...frame_shape], extendible along frames ---
  // Creates the dataset unless it exists with the same frame shape and type (then it is kept,
  // for resumed runs). Chunks hold `chunk_frames` frames; deflate level 0 disables compression.
  template <typename T>
  void CreateFrames(const std::string& name, const Shape& frame_shape, int64_t num_frames,
                    int64_t chunk_frames = 1, int deflate = 4) {
    CreateFramesRaw(name, H5TypeOf<T>(), frame_shape, num_frames, chunk_frames, deflate);
  }
  // Writes frames [first, first + count); grows the dataset when needed.
  template <typename T>
  void WriteFrames(const std::string& name, int64_t first, int64_t count, const T* data) {
    WriteFramesRaw(name, H5TypeOf<T>(), first, count, data);
  }
  template <typename T>
  void ReadFrames(const std::string& name, int64_t first, int64_t count, T* data) const {
    ReadFramesRaw(name, H5TypeOf<T>(), first, count, data);
  }
  int64_t NumFrames(const std::string& name) const;

  // --- attributes on "/" or any object ---
  void SetAttribute(const std::string& object, const std::string& name, const std::string& value);
  void SetAttribute(const std::string& object, const std::string& name, double value);
  void SetAttribute(const std::string& object, const std::string& name, int64_t value);
  void SetAttribute(const std::string& object, const std::string& name,
                    const std::vector<double>& value);
  bool HasAttribute(const std::string& object, const std::string& name) const;
  std::string GetStringAttribute(const std::string& object, const std::string& name) const;
  double GetDoubleAttribute(const std::string& object, const std::string& name) const;
  int64_t GetIntAttribute(const std::string& object, const std::string& name) const;
  std::vector<double> GetDoubleVectorAttribute(const std::string& object,
                                               const std::string& name) const;

  // Writes the root provenance attributes: facecap_version, git_commit, command_line, config,
  // created_utc, mpi_ranks, stage, and config_hash (ConfigHash of config, which `facecap run`
  // compares to decide whether an output is up to date).
  void WriteProvenance(const Provenance& provenance);

  // Shape check with the file's error message; returns the actual shape.
  Shape CheckShape(const std::string& name, const Shape& expected) const;
  static int64_t NumElements(const Shape& shape);

 private:
  H5File(int64_t id, std::string path, std::string disk_path, bool atomic);
  void WriteRaw(const std::string& name, H5Type type, const Shape& shape, const void* data);
  void ReadRaw(const std::string& name, H5Type type, void* data) const;
  void CreateFramesRaw(const std::string& name, H5Type type, const Shape& frame_shape,
                       int64_t num_frames, int64_t chunk_frames, int deflate);
  void WriteFramesRaw(const std::string& name, H5Type type, int64_t first, int64_t count,
                      const void* data);
  void ReadFramesRaw(const std::string& name, H5Type type, int64_t first, int64_t count,
                     void* data) const;
  [[noreturn]] void FailRead(const std::string& what) const;
  [[noreturn]] void FailWrite(const std::string& what) const;

  int64_t id_ = -1;
  std::string path_;
  std::string disk_path_;
  bool atomic_ = false;
};

// A per-frame `done` mask (uint8 [frames]) stored at /progress/done, for resumable stages.
// The stage writes results, then marks frames done, then flushes: a frame marked done is
// always complete on disk.
class DoneMask {
 public:
  DoneMask(H5File* file, int64_t num_frames, const std::string& name = "/progress/done");
  bool IsDone(int64_t frame) const { return done_[frame] != 0; }
  int64_t NumDone() const;
  std::vector<int64_t> Pending() const;  // frames not done, ascending
  void MarkDone(const std::vector<int64_t>& frames);  // writes and flushes
  const std::vector<uint8_t>& mask() const { return done_; }

 private:
  H5File* file_;
  std::string name_;
  std::vector<uint8_t> done_;
};

// The resolved configuration of a resumable output is kept in /progress attribute
// `config_hash`; a partial file made with another configuration is not continued.
std::string ConfigHash(const std::string& config_text);

}  // namespace facecap::io

#endif  // FACECAP_IO_HDF5_H_
