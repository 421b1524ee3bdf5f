#include "io/hdf5.h"

#include <hdf5.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <sstream>

#include "util/errors.h"
#include "util/hash.h"
#include "util/version.h"

namespace facecap::io {
namespace {

// Silences HDF5's own error stack printing once per process: facecap reports errors itself.
void SilenceHdf5() {
  static bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

hid_t NativeType(H5Type type) {
  switch (type) {
    case H5Type::kUInt8: return H5T_NATIVE_UINT8;
    case H5Type::kInt32: return H5T_NATIVE_INT32;
    case H5Type::kInt64: return H5T_NATIVE_INT64;
    case H5Type::kFloat32: return H5T_NATIVE_FLOAT;
    case H5Type::kFloat64: return H5T_NATIVE_DOUBLE;
  }
  return H5T_NATIVE_FLOAT;
}

size_t TypeSize(H5Type type) {
  switch (type) {
    case H5Type::kUInt8: return 1;
    case H5Type::kInt32: return 4;
    case H5Type::kInt64: return 8;
    case H5Type::kFloat32: return 4;
    case H5Type::kFloat64: return 8;
  }
  return 4;
}

// Closes an HDF5 id of any kind when it goes out of scope.
class Handle {
 public:
  explicit Handle(hid_t id = -1) : id_(id) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0) {
      switch (H5Iget_type(id_)) {
        case H5I_DATASET: H5Dclose(id_); break;
        case H5I_DATASPACE: H5Sclose(id_); break;
        case H5I_GROUP: H5Gclose(id_); break;
        case H5I_ATTR: H5Aclose(id_); break;
        case H5I_DATATYPE: H5Tclose(id_); break;
        case H5I_GENPROP_LST: H5Pclose(id_); break;
        default: break;
      }
    }
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
};

std::vector<hsize_t> ToHsize(const Shape& s) { return std::vector<hsize_t>(s.begin(), s.end()); }

Shape SpaceShape(hid_t space) {
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return Shape(dims.begin(), dims.end());
}

std::string Normalize(const std::string& name) {
  return name.empty() || name[0] != '/' ? "/" + name : name;
}

std::string UtcNow() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

std::string ShapeToString(const Shape& shape) {
  std::ostringstream os;
  os << "[";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i) os << ", ";
    if (shape[i] < 0) os << "*"; else os << shape[i];
  }
  os << "]";
  return os.str();
}

int64_t H5File::NumElements(const Shape& shape) {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

H5File::H5File(int64_t id, std::string path, std::string disk_path, bool atomic)
    : id_(id), path_(std::move(path)), disk_path_(std::move(disk_path)), atomic_(atomic) {}

H5File::H5File(H5File&& other) noexcept { *this = std::move(other); }

H5File& H5File::operator=(H5File&& other) noexcept {
  if (this != &other) {
    Close();
    id_ = other.id_;
    path_ = std::move(other.path_);
    disk_path_ = std::move(other.disk_path_);
    atomic_ = other.atomic_;
    other.id_ = -1;
  }
  return *this;
}

H5File::~H5File() { Close(); }

void H5File::Close() {
  if (id_ >= 0) {
    H5Fclose(id_);
    id_ = -1;
  }
}

bool H5File::IsHdf5(const std::string& path) {
  SilenceHdf5();
  if (!std::filesystem::is_regular_file(path)) return false;
  return H5Fis_hdf5(path.c_str()) > 0;
}

H5File H5File::OpenRead(const std::string& path) {
  SilenceHdf5();
  if (!std::filesystem::exists(path)) throw FileIOError(path + ": no such file");
  if (!std::filesystem::is_regular_file(path)) throw FileIOError(path + ": not a regular file");
  hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) {
    throw FileIOError(path + ": cannot open as HDF5 (not an HDF5 file, truncated or corrupt; " +
                      std::to_string(std::filesystem::file_size(path)) + " bytes)");
  }
  return H5File(id, path, path, false);
}

H5File H5File::OpenReadWrite(const std::string& path) {
  SilenceHdf5();
  hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (id < 0) throw FileIOError(path + ": cannot open as HDF5 for writing");
  return H5File(id, path, path, false);
}

H5File H5File::CreateAtomic(const std::string& path) {
  SilenceHdf5();
  const std::string partial = PartialPath(path);
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (!parent.empty() && !std::filesystem::is_directory(parent)) {
    throw OutputError(path + ": cannot create the output directory " + parent.string());
  }
  hid_t id = H5Fcreate(partial.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (id < 0) throw OutputError(partial + ": cannot create HDF5 file");
  return H5File(id, path, partial, true);
}

H5File H5File::OpenOrCreatePartial(const std::string& path, bool* resumed) {
  SilenceHdf5();
  const std::string partial = PartialPath(path);
  if (IsHdf5(partial)) {
    hid_t id = H5Fopen(partial.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (id >= 0) {
      *resumed = true;
      return H5File(id, path, partial, true);
    }
  }
  *resumed = false;
  return CreateAtomic(path);
}

void H5File::Flush() {
  if (id_ >= 0) H5Fflush(id_, H5F_SCOPE_GLOBAL);
}

void H5File::Commit() {
  if (id_ < 0) throw OutputError(path_ + ": commit of a closed file");
  Flush();
  Close();
  if (atomic_) {
    std::error_code ec;
    std::filesystem::rename(disk_path_, path_, ec);
    if (ec) throw OutputError(path_ + ": cannot rename " + disk_path_ + ": " + ec.message());
    disk_path_ = path_;
    atomic_ = false;
  }
}

void H5File::FailRead(const std::string& what) const {
  throw FileIOError(path_ + ": " + what);
}
void H5File::FailWrite(const std::string& what) const {
  throw OutputError(disk_path_ + ": " + what);
}

bool H5File::Exists(const std::string& raw) const {
  const std::string name = Normalize(raw);
  if (name == "/") return true;
  // Check every prefix: H5Lexists fails on a missing intermediate group.
  size_t pos = 1;
  while (true) {
    pos = name.find('/', pos);
    const std::string prefix = name.substr(0, pos);
    if (H5Lexists(id_, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (pos == std::string::npos) return true;
    ++pos;
  }
}

void H5File::CreateGroups(const std::string& raw) {
  const std::string name = Normalize(raw);
  size_t pos = 1;
  while ((pos = name.find('/', pos)) != std::string::npos) {
    const std::string prefix = name.substr(0, pos);
    if (H5Lexists(id_, prefix.c_str(), H5P_DEFAULT) <= 0) {
      Handle g(H5Gcreate2(id_, prefix.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
      if (!g.ok()) FailWrite("cannot create group " + prefix);
    }
    ++pos;
  }
}

Shape H5File::DatasetShape(const std::string& raw) const {
  const std::string name = Normalize(raw);
  if (!Exists(name)) FailRead("missing dataset " + name);
  Handle ds(H5Dopen2(id_, name.c_str(), H5P_DEFAULT));
  if (!ds.ok()) FailRead(name + " is not a readable dataset");
  Handle space(H5Dget_space(ds.get()));
  return SpaceShape(space.get());
}

void H5File::Remove(const std::string& raw) {
  const std::string name = Normalize(raw);
  if (Exists(name)) H5Ldelete(id_, name.c_str(), H5P_DEFAULT);
}

void H5File::CopyFrom(const H5File& source, const std::string& raw) {
  const std::string name = Normalize(raw);
  if (!source.Exists(name)) throw FileIOError(source.path() + ": has no " + name + " to copy");
  CreateGroups(name);
  if (H5Ocopy(source.id_, name.c_str(), id_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0) {
    throw FileIOError(path_ + ": cannot copy " + name + " from " + source.path());
  }
}

Shape H5File::CheckShape(const std::string& raw, const Shape& expected) const {
  const std::string name = Normalize(raw);
  Shape actual = DatasetShape(name);
  bool ok = expected.empty() || expected.size() == actual.size();
  for (size_t i = 0; ok && i < expected.size(); ++i) {
    if (expected[i] >= 0 && expected[i] != actual[i]) ok = false;
  }
  if (!ok) {
    FailRead("dataset " + name + " has shape " + ShapeToString(actual) + ", expected " +
             ShapeToString(expected));
  }
  return actual;
}

void H5File::WriteRaw(const std::string& raw, H5Type type, const Shape& shape, const void* data) {
  const std::string name = Normalize(raw);
  Remove(name);
  CreateGroups(name);
  std::vector<hsize_t> dims = ToHsize(shape);
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Handle plist(H5Pcreate(H5P_DATASET_CREATE));
  const int64_t bytes = NumElements(shape) * static_cast<int64_t>(TypeSize(type));
  if (bytes > (1 << 20) && !dims.empty() && NumElements(shape) > 0) {
    // Chunk along the first dimension, about 1 MiB per chunk.
    std::vector<hsize_t> chunk = dims;
    const int64_t row_bytes = bytes / static_cast<int64_t>(dims[0]);
    chunk[0] = std::max<hsize_t>(1, std::min<hsize_t>(dims[0], (1 << 20) / std::max<int64_t>(1, row_bytes)));
    H5Pset_chunk(plist.get(), static_cast<int>(chunk.size()), chunk.data());
    H5Pset_deflate(plist.get(), 4);
  }
  Handle ds(H5Dcreate2(id_, name.c_str(), NativeType(type), space.get(), H5P_DEFAULT, plist.get(),
                       H5P_DEFAULT));
  if (!ds.ok()) FailWrite("cannot create dataset " + name + " of shape " + ShapeToString(shape));
  if (NumElements(shape) > 0 &&
      H5Dwrite(ds.get(), NativeType(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    FailWrite("cannot write dataset " + name);
  }
}

void H5File::ReadRaw(const std::string& raw, H5Type type, void* data) const {
  const std::string name = Normalize(raw);
  Handle ds(H5Dopen2(id_, name.c_str(), H5P_DEFAULT));
  if (!ds.ok()) FailRead("missing dataset " + name);
  Handle space(H5Dget_space(ds.get()));
  if (NumElements(SpaceShape(space.get())) == 0) return;
  Handle ftype(H5Dget_type(ds.get()));
  const H5T_class_t cls = H5Tget_class(ftype.get());
  if (cls != H5T_INTEGER && cls != H5T_FLOAT) FailRead("dataset " + name + " is not numeric");
  if (H5Dread(ds.get(), NativeType(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    FailRead("cannot read dataset " + name + " (truncated or corrupt file?)");
  }
}

void H5File::WriteStrings(const std::string& raw, const std::vector<std::string>& strings) {
  const std::string name = Normalize(raw);
  Remove(name);
  CreateGroups(name);
  hsize_t n = strings.size();
  Handle space(H5Screate_simple(1, &n, nullptr));
  Handle type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle ds(H5Dcreate2(id_, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT,
                       H5P_DEFAULT));
  if (!ds.ok()) FailWrite("cannot create string dataset " + name);
  std::vector<const char*> ptrs;
  for (const auto& s : strings) ptrs.push_back(s.c_str());
  if (n > 0 && H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) {
    FailWrite("cannot write string dataset " + name);
  }
}

std::vector<std::string> H5File::ReadStrings(const std::string& raw, int64_t size) const {
  const std::string name = Normalize(raw);
  Shape shape = CheckShape(name, {size});
  Handle ds(H5Dopen2(id_, name.c_str(), H5P_DEFAULT));
  Handle ftype(H5Dget_type(ds.get()));
  if (H5Tget_class(ftype.get()) != H5T_STRING) FailRead("dataset " + name + " is not strings");
  std::vector<std::string> out;
  if (shape[0] == 0) return out;
  if (H5Tis_variable_str(ftype.get()) > 0) {
    Handle type(H5Tcopy(H5T_C_S1));
    H5Tset_size(type.get(), H5T_VARIABLE);
    H5Tset_cset(type.get(), H5Tget_cset(ftype.get()));
    std::vector<char*> ptrs(shape[0], nullptr);
    if (H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) {
      FailRead("cannot read strings " + name);
    }
    for (char* p : ptrs) out.emplace_back(p ? p : "");
    Handle space(H5Dget_space(ds.get()));
    H5Dvlen_reclaim(type.get(), space.get(), H5P_DEFAULT, ptrs.data());
  } else {
    const size_t len = H5Tget_size(ftype.get());
    std::vector<char> buf(len * shape[0] + 1, '\0');
    Handle type(H5Tcopy(H5T_C_S1));
    H5Tset_size(type.get(), len);
    H5Tset_cset(type.get(), H5Tget_cset(ftype.get()));
    if (H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) {
      FailRead("cannot read strings " + name);
    }
    for (int64_t i = 0; i < shape[0]; ++i) {
      out.emplace_back(std::string(buf.data() + i * len, strnlen(buf.data() + i * len, len)));
    }
  }
  return out;
}

void H5File::WriteImage(const std::string& name, const Image8& image) {
  Write<uint8_t>(name, {image.height, image.width, image.channels}, image.data.data());
}

Image8 H5File::ReadImage(const std::string& name) const {
  Shape s;
  std::vector<uint8_t> data = Read<uint8_t>(name, {-1, -1, -1}, &s);
  Image8 image(static_cast<int>(s[1]), static_cast<int>(s[0]), static_cast<int>(s[2]));
  image.data = std::move(data);
  return image;
}

void H5File::CreateFramesRaw(const std::string& raw, H5Type type, const Shape& frame_shape,
                             int64_t num_frames, int64_t chunk_frames, int deflate) {
  const std::string name = Normalize(raw);
  Shape full = frame_shape;
  full.insert(full.begin(), num_frames);
  if (Exists(name)) {
    Shape actual = DatasetShape(name);
    Shape expected = full;
    expected[0] = -1;
    bool same = actual.size() == expected.size();
    for (size_t i = 1; same && i < actual.size(); ++i) same = actual[i] == expected[i];
    if (same) return;
    FailWrite("existing dataset " + name + " has shape " + ShapeToString(actual) +
              ", expected " + ShapeToString(expected));
  }
  CreateGroups(name);
  std::vector<hsize_t> dims = ToHsize(full);
  std::vector<hsize_t> maxdims = dims;
  maxdims[0] = H5S_UNLIMITED;
  std::vector<hsize_t> chunk = dims;
  chunk[0] = static_cast<hsize_t>(std::max<int64_t>(1, chunk_frames));
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data()));
  Handle plist(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_chunk(plist.get(), static_cast<int>(chunk.size()), chunk.data());
  if (deflate > 0) {
    H5Pset_shuffle(plist.get());
    H5Pset_deflate(plist.get(), static_cast<unsigned>(deflate));
  }
  Handle ds(H5Dcreate2(id_, name.c_str(), NativeType(type), space.get(), H5P_DEFAULT, plist.get(),
                       H5P_DEFAULT));
  if (!ds.ok()) FailWrite("cannot create frame dataset " + name);
}

void H5File::WriteFramesRaw(const std::string& raw, H5Type type, int64_t first, int64_t count,
                            const void* data) {
  const std::string name = Normalize(raw);
  Handle ds(H5Dopen2(id_, name.c_str(), H5P_DEFAULT));
  if (!ds.ok()) FailWrite("missing frame dataset " + name + " (create it first)");
  Handle fspace0(H5Dget_space(ds.get()));
  std::vector<hsize_t> dims = ToHsize(SpaceShape(fspace0.get()));
  if (static_cast<hsize_t>(first + count) > dims[0]) {
    dims[0] = first + count;
    if (H5Dset_extent(ds.get(), dims.data()) < 0) FailWrite("cannot extend " + name);
  }
  Handle fspace(H5Dget_space(ds.get()));
  std::vector<hsize_t> start(dims.size(), 0), extent = dims;
  start[0] = first;
  extent[0] = count;
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, extent.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr));
  if (count > 0 &&
      H5Dwrite(ds.get(), NativeType(type), mspace.get(), fspace.get(), H5P_DEFAULT, data) < 0) {
    FailWrite("cannot write frames [" + std::to_string(first) + ", " +
              std::to_string(first + count) + ") of " + name);
  }
}

void H5File::ReadFramesRaw(const std::string& raw, H5Type type, int64_t first, int64_t count,
                           void* data) const {
  const std::string name = Normalize(raw);
  Shape shape = DatasetShape(name);
  if (shape.empty() || first < 0 || first + count > shape[0]) {
    FailRead("frames [" + std::to_string(first) + ", " + std::to_string(first + count) +
             ") requested from " + name + " of shape " + ShapeToString(shape));
  }
  Handle ds(H5Dopen2(id_, name.c_str(), H5P_DEFAULT));
  Handle fspace(H5Dget_space(ds.get()));
  std::vector<hsize_t> start(shape.size(), 0), extent = ToHsize(shape);
  start[0] = first;
  extent[0] = count;
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, extent.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr));
  if (count > 0 &&
      H5Dread(ds.get(), NativeType(type), mspace.get(), fspace.get(), H5P_DEFAULT, data) < 0) {
    FailRead("cannot read frames of " + name + " (truncated or corrupt file?)");
  }
}

int64_t H5File::NumFrames(const std::string& name) const {
  Shape s = DatasetShape(name);
  return s.empty() ? 0 : s[0];
}

namespace {

hid_t OpenObject(hid_t file, const std::string& object) {
  return H5Oopen(file, object.c_str(), H5P_DEFAULT);
}

void CloseObject(hid_t obj) {
  if (obj >= 0) H5Oclose(obj);
}

// The number of values an attribute holds (1 for a scalar), or -1 when unknown.
hssize_t AttributePoints(hid_t attr) {
  Handle space(H5Aget_space(attr));
  return space.ok() ? H5Sget_simple_extent_npoints(space.get()) : -1;
}

}  // namespace

void H5File::SetAttribute(const std::string& object, const std::string& name,
                          const std::string& value) {
  hid_t obj = OpenObject(id_, Normalize(object));
  if (obj < 0) FailWrite("no object " + object + " for attribute " + name);
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  Handle type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), std::max<size_t>(1, value.size()));
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR));
  Handle attr(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
  const std::string padded = value.empty() ? std::string(1, '\0') : value;
  const bool ok = attr.ok() && H5Awrite(attr.get(), type.get(), padded.data()) >= 0;
  CloseObject(obj);
  if (!ok) FailWrite("cannot write attribute " + object + "@" + name);
}

namespace {

template <typename T>
bool WriteNumericAttribute(hid_t file, const std::string& object, const std::string& name,
                           hid_t type, const std::vector<T>& values, bool scalar) {
  hid_t obj = OpenObject(file, object);
  if (obj < 0) return false;
  if (H5Aexists(obj, name.c_str()) > 0) H5Adelete(obj, name.c_str());
  hsize_t n = values.size();
  Handle space(scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr));
  Handle attr(H5Acreate2(obj, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  const bool ok = attr.ok() && H5Awrite(attr.get(), type, values.data()) >= 0;
  CloseObject(obj);
  return ok;
}

}  // namespace

void H5File::SetAttribute(const std::string& object, const std::string& name, double value) {
  if (!WriteNumericAttribute<double>(id_, Normalize(object), name, H5T_NATIVE_DOUBLE, {value}, true))
    FailWrite("cannot write attribute " + object + "@" + name);
}

void H5File::SetAttribute(const std::string& object, const std::string& name, int64_t value) {
  if (!WriteNumericAttribute<int64_t>(id_, Normalize(object), name, H5T_NATIVE_INT64, {value}, true))
    FailWrite("cannot write attribute " + object + "@" + name);
}

void H5File::SetAttribute(const std::string& object, const std::string& name,
                          const std::vector<double>& value) {
  if (!WriteNumericAttribute<double>(id_, Normalize(object), name, H5T_NATIVE_DOUBLE, value, false))
    FailWrite("cannot write attribute " + object + "@" + name);
}

bool H5File::HasAttribute(const std::string& object, const std::string& name) const {
  if (!Exists(Normalize(object))) return false;
  hid_t obj = OpenObject(id_, Normalize(object));
  if (obj < 0) return false;
  const bool has = H5Aexists(obj, name.c_str()) > 0;
  CloseObject(obj);
  return has;
}

std::string H5File::GetStringAttribute(const std::string& object, const std::string& name) const {
  if (!HasAttribute(object, name)) FailRead("missing attribute " + object + "@" + name);
  hid_t obj = OpenObject(id_, Normalize(object));
  Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  Handle ftype(H5Aget_type(attr.get()));
  std::string out;
  // One string: an array of them would be read past the single value below.
  bool ok = H5Tget_class(ftype.get()) == H5T_STRING && AttributePoints(attr.get()) == 1;
  if (ok && H5Tis_variable_str(ftype.get()) > 0) {
    char* p = nullptr;
    Handle mtype(H5Tcopy(H5T_C_S1));
    H5Tset_size(mtype.get(), H5T_VARIABLE);
    H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get()));
    ok = H5Aread(attr.get(), mtype.get(), &p) >= 0;
    if (ok && p) out = p;
    if (p) H5free_memory(p);
  } else if (ok) {
    const size_t len = H5Tget_size(ftype.get());
    std::vector<char> buf(len + 1, '\0');
    ok = H5Aread(attr.get(), ftype.get(), buf.data()) >= 0;
    out.assign(buf.data(), strnlen(buf.data(), len));
  }
  CloseObject(obj);
  if (!ok) FailRead("attribute " + object + "@" + name + " is not a single string");
  return out;
}

std::vector<double> H5File::GetDoubleVectorAttribute(const std::string& object,
                                                     const std::string& name) const {
  if (!HasAttribute(object, name)) FailRead("missing attribute " + object + "@" + name);
  hid_t obj = OpenObject(id_, Normalize(object));
  Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  Handle space(H5Aget_space(attr.get()));
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  std::vector<double> out(std::max<hssize_t>(0, n));
  const bool ok = H5Aread(attr.get(), H5T_NATIVE_DOUBLE, out.data()) >= 0;
  CloseObject(obj);
  if (!ok) FailRead("attribute " + object + "@" + name + " is not numeric");
  return out;
}

double H5File::GetDoubleAttribute(const std::string& object, const std::string& name) const {
  std::vector<double> v = GetDoubleVectorAttribute(object, name);
  if (v.size() != 1) FailRead("attribute " + object + "@" + name + " is not a scalar");
  return v[0];
}

int64_t H5File::GetIntAttribute(const std::string& object, const std::string& name) const {
  if (!HasAttribute(object, name)) FailRead("missing attribute " + object + "@" + name);
  hid_t obj = OpenObject(id_, Normalize(object));
  Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  const hssize_t points = AttributePoints(attr.get());
  int64_t value = 0;
  // One value: an array of them would be read past `value`.
  const bool ok = points == 1 && H5Aread(attr.get(), H5T_NATIVE_INT64, &value) >= 0;
  CloseObject(obj);
  if (points != 1 && points >= 0) FailRead("attribute " + object + "@" + name + " is not a scalar");
  if (!ok) FailRead("attribute " + object + "@" + name + " is not an integer");
  return value;
}

void H5File::WriteProvenance(const Provenance& p) {
  SetAttribute("/", "facecap_version", Version());
  SetAttribute("/", "git_commit", GitCommit());
  SetAttribute("/", "command_line", p.command_line);
  SetAttribute("/", "config", p.config);
  SetAttribute("/", "created_utc", UtcNow());
  SetAttribute("/", "mpi_ranks", static_cast<int64_t>(p.mpi_ranks));
  SetAttribute("/", "stage", p.stage);
  SetAttribute("/", "config_hash", ConfigHash(p.config));
}

DoneMask::DoneMask(H5File* file, int64_t num_frames, const std::string& name)
    : file_(file), name_(name), done_(num_frames, 0) {
  if (file_->Exists(name_)) {
    done_ = file_->ReadVector<uint8_t>(name_, num_frames);
  } else {
    file_->CreateFrames<uint8_t>(name_, {}, num_frames, 4096, 0);
    file_->WriteFrames<uint8_t>(name_, 0, num_frames, done_.data());
  }
}

int64_t DoneMask::NumDone() const {
  int64_t n = 0;
  for (uint8_t d : done_) n += d != 0;
  return n;
}

std::vector<int64_t> DoneMask::Pending() const {
  std::vector<int64_t> out;
  for (int64_t i = 0; i < static_cast<int64_t>(done_.size()); ++i)
    if (!done_[i]) out.push_back(i);
  return out;
}

void DoneMask::MarkDone(const std::vector<int64_t>& frames) {
  for (int64_t f : frames) done_.at(f) = 1;
  file_->Flush();  // results first
  file_->WriteFrames<uint8_t>(name_, 0, static_cast<int64_t>(done_.size()), done_.data());
  file_->Flush();
}

std::string ConfigHash(const std::string& text) {
  const uint64_t h = Fnv1a(text.data(), text.size());
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace facecap::io
