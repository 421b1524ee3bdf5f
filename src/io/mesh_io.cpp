#include "io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdarg>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <unordered_map>

#include <assimp/Importer.hpp>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "io/atomic_file.h"
#include "io/image_io.h"
#include "rig/evaluate.h"
#include "util/errors.h"
#include "util/json.h"

namespace facecap::io {

namespace fs = std::filesystem;

namespace {

// Offsets with every |component| at or below this are dropped from sparse deltas (cm).
constexpr float kDeltaThreshold = 1e-6f;
// glTF stores metres; rigs are centimetres.
constexpr float kCentimetresPerMetre = 100.f;

// ---- files ------------------------------------------------------------------------------------

std::string ReadWholeFile(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileIOError(path + ": cannot open " + what + " (" + std::strerror(errno) + ")");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw FileIOError(path + ": read error");
  return buffer.str();
}

void AppendFormat(std::string* out, const char* format, ...) __attribute__((format(printf, 2, 3)));
void AppendFormat(std::string* out, const char* format, ...) {
  char buffer[256];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(buffer, sizeof(buffer), format, args);
  va_end(args);
  if (n > 0) out->append(buffer, std::min<size_t>(n, sizeof(buffer) - 1));
}

// ---- OBJ parsing ------------------------------------------------------------------------------

class ObjParser {
 public:
  ObjParser(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  Mesh Parse() {
    std::vector<Eigen::Vector3f> positions;
    std::vector<Eigen::Vector2f> texcoords;
    std::vector<Eigen::Vector3i> faces, face_uvs;
    std::vector<int> face_line;
    int faces_with_uv = 0, faces_without_uv = 0;
    size_t pos = 0;
    line_number_ = 0;
    while (pos < text_.size()) {
      size_t end = text_.find('\n', pos);
      if (end == std::string::npos) end = text_.size();
      ++line_number_;
      cursor_ = text_.data() + pos;
      line_end_ = text_.data() + end;
      pos = end + 1;
      SkipSpaces();
      if (cursor_ == line_end_ || *cursor_ == '#') continue;
      const std::string keyword = Word();
      if (keyword == "v") {
        Eigen::Vector3f p;
        for (int c = 0; c < 3; ++c) p[c] = Number("vertex coordinate");
        if (!p.allFinite()) {
          Fail("vertex " + std::to_string(positions.size()) + " is not finite");
        }
        positions.push_back(p);
      } else if (keyword == "vt") {
        Eigen::Vector2f t;
        for (int c = 0; c < 2; ++c) t[c] = Number("texture coordinate");
        if (!t.allFinite()) {
          Fail("texture coordinate " + std::to_string(texcoords.size()) + " is not finite");
        }
        texcoords.push_back(t);
      } else if (keyword == "f") {
        std::vector<int> corner_vertex, corner_uv;
        bool any_uv = false, all_uv = true;
        SkipSpaces();
        while (cursor_ < line_end_ && *cursor_ != '#') {
          int vertex = ResolveIndex(Integer("face vertex index"), positions.size(), "vertex");
          int uv = -1;
          if (cursor_ < line_end_ && *cursor_ == '/') {
            ++cursor_;
            if (cursor_ < line_end_ && *cursor_ != '/') {
              uv = ResolveIndex(Integer("face texture index"), texcoords.size(),
                                "texture coordinate");
            }
            if (cursor_ < line_end_ && *cursor_ == '/') {  // normal index: ignored
              ++cursor_;
              if (cursor_ < line_end_ && !IsSpace(*cursor_)) Integer("face normal index");
            }
          }
          if (cursor_ < line_end_ && !IsSpace(*cursor_)) Fail("malformed face corner");
          corner_vertex.push_back(vertex);
          corner_uv.push_back(uv);
          any_uv |= uv >= 0;
          all_uv &= uv >= 0;
          SkipSpaces();
        }
        if (corner_vertex.size() < 3) Fail("a face needs at least 3 corners");
        if (any_uv && !all_uv) Fail("face gives texture indices for some corners only");
        (any_uv ? faces_with_uv : faces_without_uv) += 1;
        // Fan triangulation (0, k, k + 1): the same for every file of one topology.
        for (size_t k = 1; k + 1 < corner_vertex.size(); ++k) {
          faces.emplace_back(corner_vertex[0], corner_vertex[k], corner_vertex[k + 1]);
          face_uvs.emplace_back(corner_uv[0], corner_uv[k], corner_uv[k + 1]);
          face_line.push_back(line_number_);
        }
      }
      // Other statements (vn, vp, o, g, s, usemtl, mtllib, l, ...) do not affect geometry.
    }
    if (faces_with_uv > 0 && faces_without_uv > 0) {
      throw FileIOError(path_ + ": " + std::to_string(faces_with_uv) +
                        " faces have texture indices and " + std::to_string(faces_without_uv) +
                        " do not; expected all or none");
    }
    if (positions.empty()) {
      throw FileIOError(path_ + ": no vertices (" +
                        (text_.empty() ? std::string("the file is empty")
                                       : "no 'v' line in " + std::to_string(line_number_) +
                                             " lines") +
                        ")");
    }
    Mesh mesh;
    mesh.vertices.resize(static_cast<int>(positions.size()), 3);
    for (size_t i = 0; i < positions.size(); ++i) mesh.vertices.row(i) = positions[i].transpose();
    mesh.triangles.resize(static_cast<int>(faces.size()), 3);
    for (size_t f = 0; f < faces.size(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const int v = faces[f][c];
        if (v < 0 || v >= static_cast<int>(positions.size())) {
          throw FileIOError(path_ + ":" + std::to_string(face_line[f]) + ": face refers to vertex " +
                            std::to_string(v + 1) + " but the file has " +
                            std::to_string(positions.size()) + " vertices");
        }
      }
      mesh.triangles.row(f) = faces[f].transpose();
    }
    if (faces_with_uv > 0) {
      mesh.uvs.resize(static_cast<int>(texcoords.size()), 2);
      for (size_t i = 0; i < texcoords.size(); ++i) mesh.uvs.row(i) = texcoords[i].transpose();
      mesh.uv_triangles.resize(static_cast<int>(faces.size()), 3);
      for (size_t f = 0; f < faces.size(); ++f) {
        for (int c = 0; c < 3; ++c) {
          const int t = face_uvs[f][c];
          if (t < 0 || t >= static_cast<int>(texcoords.size())) {
            throw FileIOError(path_ + ":" + std::to_string(face_line[f]) +
                              ": face refers to texture coordinate " + std::to_string(t + 1) +
                              " but the file has " + std::to_string(texcoords.size()));
          }
        }
        mesh.uv_triangles.row(f) = face_uvs[f].transpose();
      }
    }
    return mesh;
  }

 private:
  static bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r'; }
  void SkipSpaces() {
    while (cursor_ < line_end_ && IsSpace(*cursor_)) ++cursor_;
  }
  std::string Word() {
    const char* start = cursor_;
    while (cursor_ < line_end_ && !IsSpace(*cursor_)) ++cursor_;
    return std::string(start, cursor_);
  }
  [[noreturn]] void Fail(const std::string& what) const {
    throw FileIOError(path_ + ":" + std::to_string(line_number_) + ": " + what);
  }
  float Number(const char* what) {
    SkipSpaces();
    if (cursor_ >= line_end_) Fail(std::string("missing ") + what);
    std::string token = Word();
    char* end = nullptr;
    const float value = std::strtof(token.c_str(), &end);
    // The whole token: a NUL byte inside it ends strtof's number but not the token.
    if (end != token.c_str() + token.size() || token.empty()) {
      Fail(std::string("bad ") + what + " '" + token.c_str() + "'");
    }
    return value;
  }
  long Integer(const char* what) {
    const char* start = cursor_;
    if (cursor_ < line_end_ && (*cursor_ == '-' || *cursor_ == '+')) ++cursor_;
    while (cursor_ < line_end_ && *cursor_ >= '0' && *cursor_ <= '9') ++cursor_;
    if (cursor_ == start || (cursor_ == start + 1 && (*start == '-' || *start == '+'))) {
      Fail(std::string("bad ") + what);
    }
    const std::string text(start, cursor_);
    errno = 0;
    const long value = std::strtol(text.c_str(), nullptr, 10);
    if (errno == ERANGE) Fail(std::string(what) + " " + text + " is out of range");
    if (value == 0) Fail(std::string(what) + " 0 (OBJ indices start at 1)");
    return value;
  }
  // 1-based, or negative relative to the elements read so far; returns 0-based. A positive
  // index may refer to an element defined later (checked once the file is read); a negative
  // one must fall within the elements read so far, and neither may exceed the int range.
  int ResolveIndex(long index, size_t count, const char* what) const {
    if (index > std::numeric_limits<int>::max()) {
      Fail(std::string("face refers to ") + what + " " + std::to_string(index) +
           ", beyond any mesh this reader takes");
    }
    if (index < -static_cast<long>(count)) {
      Fail(std::string("face refers to ") + what + " " + std::to_string(index) + " but only " +
           std::to_string(count) + " precede it");
    }
    return static_cast<int>(index > 0 ? index - 1 : static_cast<long>(count) + index);
  }

  const std::string& path_;
  const std::string& text_;
  const char* cursor_ = nullptr;
  const char* line_end_ = nullptr;
  int line_number_ = 0;
};

// ---- rig helpers ------------------------------------------------------------------------------

rig::SparseDelta SparseDifference(const rig::Vertices& shape, const rig::Vertices& neutral) {
  rig::SparseDelta delta;
  for (int v = 0; v < neutral.rows(); ++v) {
    const Eigen::Vector3f d = (shape.row(v) - neutral.row(v)).transpose();
    if (d.cwiseAbs().maxCoeff() <= kDeltaThreshold) continue;
    delta.vertex.push_back(v);
    delta.offset.push_back(d);
  }
  return delta;
}

// The fields an OBJ or glTF cannot carry: no jaw skinning, one region, no landmarks.
void FillDefaultRigFields(rig::Rig* rig) {
  rig->jaw_weights = Eigen::VectorXf::Zero(rig->NumVertices());
  rig->jaw_pivot.setZero();
  rig->regions = {rig::Region{"skin", Eigen::Vector3f(0.8f, 0.6f, 0.5f)}};
  rig->triangle_region = Eigen::VectorXi::Zero(rig->triangles.rows());
  rig->landmarks.resize(0);
}

void CheckRigForExport(const rig::Rig& rig, const std::string& path) {
  std::string why;
  if (!rig.Check(&why)) throw InvalidInputError("cannot export " + path + ": invalid rig: " + why);
}

// S(e_i) for every shape i: the shape's full effect including jaw skinning.
std::vector<rig::Vertices> FullShapes(const rig::Rig& rig) {
  std::vector<rig::Vertices> shapes(rig.NumShapes());
  rig::RigEvaluator evaluator(rig);
  for (int s = 0; s < rig.NumShapes(); ++s) {
    Eigen::VectorXf weights = Eigen::VectorXf::Zero(rig.NumShapes());
    weights[s] = 1.f;
    evaluator.EvaluateShape(weights, &shapes[s]);
  }
  return shapes;
}

void CheckShapeFileName(const std::string& name) {
  const bool bad = name.empty() || name == "neutral" || name[0] == '.' ||
                   name.find_first_of("/\\:\n\r\t\"*?<>|") != std::string::npos;
  if (bad) {
    throw InvalidInputError("shape name '" + name +
                            "' cannot be an OBJ file name in a rig folder (empty, 'neutral', "
                            "leading '.', or a path or control character)");
  }
}

// ---- JSON and base64 --------------------------------------------------------------------------

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      AppendFormat(&out, "\\u%04x", c);
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

std::string JsonFloat(float x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", static_cast<double>(x));
  return buffer;
}

std::string Base64(const std::string& bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += kAlphabet[n & 63];
  }
  if (i < bytes.size()) {
    uint32_t n = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= uint8_t(bytes[i + 1]) << 8;
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Binary buffer plus the bufferViews and accessors that describe it.
class GltfBufferBuilder {
 public:
  // Appends float data as one bufferView and accessor; returns the accessor index.
  // components: 1 (SCALAR), 2 (VEC2) or 3 (VEC3). with_bounds adds min / max.
  int AddFloats(const std::vector<float>& data, int components, bool with_bounds, int target) {
    const size_t count = data.size() / components;
    const int view = AddView(data.data(), data.size() * sizeof(float), target);
    std::string accessor = "{\"bufferView\":" + std::to_string(view) +
                           ",\"componentType\":5126,\"count\":" + std::to_string(count) +
                           ",\"type\":\"" + TypeName(components) + "\"";
    if (with_bounds) {
      std::vector<float> low(components, 0.f), high(components, 0.f);
      for (size_t i = 0; i < count; ++i) {
        for (int c = 0; c < components; ++c) {
          const float x = data[i * components + c];
          low[c] = i == 0 ? x : std::min(low[c], x);
          high[c] = i == 0 ? x : std::max(high[c], x);
        }
      }
      accessor += ",\"min\":" + FloatArray(low) + ",\"max\":" + FloatArray(high);
    }
    accessors_.push_back(accessor + "}");
    return static_cast<int>(accessors_.size()) - 1;
  }

  int AddIndices(const std::vector<uint32_t>& indices) {
    const int view = AddView(indices.data(), indices.size() * sizeof(uint32_t), 34963);
    accessors_.push_back("{\"bufferView\":" + std::to_string(view) +
                         ",\"componentType\":5125,\"count\":" + std::to_string(indices.size()) +
                         ",\"type\":\"SCALAR\"}");
    return static_cast<int>(accessors_.size()) - 1;
  }

  // Appends raw bytes (an encoded image) as one bufferView; returns the view index.
  int AddBytes(const std::string& data) { return AddView(data.data(), data.size(), 0); }

  const std::string& bytes() const { return bytes_; }
  std::string AccessorsJson() const { return JoinArray(accessors_); }
  std::string ViewsJson() const { return JoinArray(views_); }

  static std::string FloatArray(const std::vector<float>& values) {
    std::string out = "[";
    for (size_t i = 0; i < values.size(); ++i) out += (i ? "," : "") + JsonFloat(values[i]);
    return out + "]";
  }

 private:
  static const char* TypeName(int components) {
    return components == 1 ? "SCALAR" : components == 2 ? "VEC2" : "VEC3";
  }
  static std::string JoinArray(const std::vector<std::string>& items) {
    std::string out = "[";
    for (size_t i = 0; i < items.size(); ++i) out += (i ? "," : "") + items[i];
    return out + "]";
  }
  int AddView(const void* data, size_t size, int target) {
    while (bytes_.size() % 4) bytes_ += '\0';
    const size_t offset = bytes_.size();
    bytes_.append(static_cast<const char*>(data), size);
    std::string view = "{\"buffer\":0,\"byteOffset\":" + std::to_string(offset) +
                       ",\"byteLength\":" + std::to_string(size);
    if (target) view += ",\"target\":" + std::to_string(target);
    views_.push_back(view + "}");
    return static_cast<int>(views_.size()) - 1;
  }

  std::string bytes_;
  std::vector<std::string> views_;
  std::vector<std::string> accessors_;
};

void AppendUint32(std::string* out, uint32_t x) {
  for (int b = 0; b < 4; ++b) *out += static_cast<char>((x >> (8 * b)) & 0xff);
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  std::string tail = s.substr(s.size() - suffix.size());
  std::transform(tail.begin(), tail.end(), tail.begin(), ::tolower);
  return tail == suffix;
}

// ---- assimp helpers ---------------------------------------------------------------------------

bool FindNodeTransform(const aiNode* node, unsigned mesh_index, const aiMatrix4x4& parent,
                       aiMatrix4x4* out) {
  const aiMatrix4x4 global = parent * node->mTransformation;
  for (unsigned i = 0; i < node->mNumMeshes; ++i) {
    if (node->mMeshes[i] == mesh_index) {
      *out = global;
      return true;
    }
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c) {
    if (FindNodeTransform(node->mChildren[c], mesh_index, global, out)) return true;
  }
  return false;
}

}  // namespace

// ---- OBJ --------------------------------------------------------------------------------------

Mesh ReadMeshObj(const std::string& path) {
  const std::string text = ReadWholeFile(path, "OBJ file");
  return ObjParser(path, text).Parse();
}

void ExportMeshObj(const rig::Vertices& vertices, const rig::Triangles& triangles,
                   const rig::UVs* uvs, const rig::Triangles* uv_triangles,
                   const std::string& path) {
  if ((uvs == nullptr) != (uv_triangles == nullptr)) {
    throw InvalidInputError("ExportMeshObj(" + path + "): give both uvs and uv_triangles or neither");
  }
  if (uv_triangles && uv_triangles->rows() != triangles.rows()) {
    throw InvalidInputError("ExportMeshObj(" + path + "): uv_triangles has " +
                            std::to_string(uv_triangles->rows()) + " rows for " +
                            std::to_string(triangles.rows()) + " triangles");
  }
  const int num_vertices = static_cast<int>(vertices.rows());
  const int num_uvs = uvs ? static_cast<int>(uvs->rows()) : 0;
  if (!vertices.allFinite() || (uvs && !uvs->allFinite())) {
    throw InvalidInputError("ExportMeshObj(" + path + "): non-finite vertex or texture coordinate");
  }
  for (int f = 0; f < triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      if (triangles(f, c) < 0 || triangles(f, c) >= num_vertices ||
          (uv_triangles && ((*uv_triangles)(f, c) < 0 || (*uv_triangles)(f, c) >= num_uvs))) {
        throw InvalidInputError("ExportMeshObj(" + path + "): triangle " + std::to_string(f) +
                                " has an index out of range");
      }
    }
  }
  std::string text;
  text.reserve(40 * (vertices.rows() + num_uvs + triangles.rows()) + 64);
  text += "# facecap mesh: " + std::to_string(num_vertices) + " vertices, " +
          std::to_string(triangles.rows()) + " triangles\n";
  for (int v = 0; v < num_vertices; ++v) {
    AppendFormat(&text, "v %.9g %.9g %.9g\n", vertices(v, 0), vertices(v, 1), vertices(v, 2));
  }
  for (int t = 0; t < num_uvs; ++t) {
    AppendFormat(&text, "vt %.9g %.9g\n", (*uvs)(t, 0), (*uvs)(t, 1));
  }
  for (int f = 0; f < triangles.rows(); ++f) {
    if (uv_triangles) {
      AppendFormat(&text, "f %d/%d %d/%d %d/%d\n", triangles(f, 0) + 1, (*uv_triangles)(f, 0) + 1,
                   triangles(f, 1) + 1, (*uv_triangles)(f, 1) + 1, triangles(f, 2) + 1,
                   (*uv_triangles)(f, 2) + 1);
    } else {
      AppendFormat(&text, "f %d %d %d\n", triangles(f, 0) + 1, triangles(f, 1) + 1,
                   triangles(f, 2) + 1);
    }
  }
  WriteFileAtomically(path, text);
}

rig::Rig ImportRigFromObjFolder(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw FileIOError(dir + ": rig folder does not exist or is not a directory");
  }
  const std::string neutral_path = (fs::path(dir) / "neutral.obj").string();
  if (!fs::exists(neutral_path, ec)) {
    throw FileIOError(neutral_path + ": missing (a rig folder holds neutral.obj plus one "
                      "<shape>.obj per shape)");
  }
  const Mesh neutral = ReadMeshObj(neutral_path);

  // Shape names: shapes.txt when present, else every other .obj sorted by name.
  std::vector<std::string> names;
  const std::string order_path = (fs::path(dir) / "shapes.txt").string();
  if (fs::exists(order_path, ec)) {
    std::istringstream lines(ReadWholeFile(order_path, "shape list"));
    std::string line;
    while (std::getline(lines, line)) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty()) names.push_back(line);
    }
  } else {
    for (const auto& entry : fs::directory_iterator(dir)) {
      if (!entry.is_regular_file() || entry.path().extension() != ".obj") continue;
      const std::string stem = entry.path().stem().string();
      if (stem != "neutral") names.push_back(stem);
    }
    std::sort(names.begin(), names.end());
  }

  rig::Rig rig;
  rig.neutral = neutral.vertices;
  rig.triangles = neutral.triangles;
  rig.uvs = neutral.uvs;
  rig.uv_triangles = neutral.uv_triangles;
  FillDefaultRigFields(&rig);
  for (const std::string& name : names) {
    const std::string path = (fs::path(dir) / (name + ".obj")).string();
    if (!fs::exists(path, ec)) {
      throw FileIOError(path + ": missing (listed in " + order_path + ")");
    }
    const Mesh shape = ReadMeshObj(path);
    if (shape.vertices.rows() != neutral.vertices.rows()) {
      throw FileIOError(path + ": topology differs from neutral.obj: expected " +
                        std::to_string(neutral.vertices.rows()) + " vertices, got " +
                        std::to_string(shape.vertices.rows()));
    }
    if (shape.triangles.rows() != neutral.triangles.rows()) {
      throw FileIOError(path + ": topology differs from neutral.obj: expected " +
                        std::to_string(neutral.triangles.rows()) + " triangles, got " +
                        std::to_string(shape.triangles.rows()));
    }
    for (int f = 0; f < shape.triangles.rows(); ++f) {
      if (shape.triangles.row(f) != neutral.triangles.row(f)) {
        std::ostringstream why;
        why << path << ": topology differs from neutral.obj: face " << f << " is ("
            << shape.triangles(f, 0) + 1 << ", " << shape.triangles(f, 1) + 1 << ", "
            << shape.triangles(f, 2) + 1 << "), expected (" << neutral.triangles(f, 0) + 1
            << ", " << neutral.triangles(f, 1) + 1 << ", " << neutral.triangles(f, 2) + 1
            << ") (1-based vertex indices)";
        throw FileIOError(why.str());
      }
    }
    rig::Shape rig_shape;
    rig_shape.name = name;
    rig_shape.delta = SparseDifference(shape.vertices, neutral.vertices);  // D_i = S_i - N
    rig.shapes.push_back(std::move(rig_shape));
  }
  std::string why;
  if (!rig.Check(&why)) throw FileIOError(neutral_path + ": rig is invalid: " + why);
  return rig;
}

void ExportRigToObjFolder(const rig::Rig& rig, const std::string& dir) {
  CheckRigForExport(rig, dir);
  std::set<std::string> expected = {"neutral"};
  for (const rig::Shape& shape : rig.shapes) {
    CheckShapeFileName(shape.name);
    expected.insert(shape.name);
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(dir + ": cannot create directory: " + ec.message());
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() == ".obj" && !expected.count(entry.path().stem().string())) {
      throw OutputError(dir + ": holds " + entry.path().filename().string() +
                        ", which is not a shape of this rig; export into an empty folder");
    }
  }
  const rig::UVs* uvs = rig.uvs.rows() > 0 ? &rig.uvs : nullptr;
  const rig::Triangles* uv_triangles = uvs ? &rig.uv_triangles : nullptr;
  ExportMeshObj(rig.neutral, rig.triangles, uvs, uv_triangles,
                (fs::path(dir) / "neutral.obj").string());
  const std::vector<rig::Vertices> shapes = FullShapes(rig);
  std::string order;
  for (int s = 0; s < rig.NumShapes(); ++s) {
    ExportMeshObj(shapes[s], rig.triangles, uvs, uv_triangles,
                  (fs::path(dir) / (rig.shapes[s].name + ".obj")).string());
    order += rig.shapes[s].name + "\n";
  }
  WriteFileAtomically((fs::path(dir) / "shapes.txt").string(), order);
}

// ---- glTF -------------------------------------------------------------------------------------

rig::Rig ImportRigFromGltf(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw FileIOError(path + ": glTF file does not exist");
  Assimp::Importer importer;
  // Triangulate only: no vertex joining or cache optimisation, so base and morph-target
  // vertices keep the file's order and stay in one-to-one correspondence.
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (!scene) throw FileIOError(path + ": cannot read glTF: " + importer.GetErrorString());
  if (scene->mNumMeshes == 0) throw FileIOError(path + ": the file holds no mesh");

  unsigned best = 0;
  for (unsigned m = 1; m < scene->mNumMeshes; ++m) {
    const aiMesh* a = scene->mMeshes[m];
    const aiMesh* b = scene->mMeshes[best];
    if (a->mNumAnimMeshes > b->mNumAnimMeshes ||
        (a->mNumAnimMeshes == b->mNumAnimMeshes && a->mNumVertices > b->mNumVertices)) {
      best = m;
    }
  }
  const aiMesh* mesh = scene->mMeshes[best];
  const int num_file_vertices = static_cast<int>(mesh->mNumVertices);
  const int num_targets = static_cast<int>(mesh->mNumAnimMeshes);
  aiMatrix4x4 transform;  // identity
  if (scene->mRootNode) FindNodeTransform(scene->mRootNode, best, aiMatrix4x4(), &transform);

  auto to_rig = [&](const aiVector3D& p) -> Eigen::Vector3f {
    const aiVector3D q = transform * p;
    return Eigen::Vector3f(q.x, q.y, q.z) * kCentimetresPerMetre;
  };
  // Positions of every file vertex: base, then each target.
  std::vector<rig::Vertices> positions(1 + num_targets,
                                       rig::Vertices(num_file_vertices, 3));
  for (int v = 0; v < num_file_vertices; ++v) {
    positions[0].row(v) = to_rig(mesh->mVertices[v]).transpose();
  }
  for (int t = 0; t < num_targets; ++t) {
    const aiAnimMesh* target = mesh->mAnimMeshes[t];
    if (!target->mVertices || target->mNumVertices != mesh->mNumVertices) {
      throw FileIOError(path + ": morph target " + std::to_string(t) +
                        " has no positions or a different vertex count than its mesh");
    }
    for (int v = 0; v < num_file_vertices; ++v) {
      positions[1 + t].row(v) = to_rig(target->mVertices[v]).transpose();
    }
  }
  for (int k = 0; k <= num_targets; ++k) {
    for (int v = 0; v < num_file_vertices; ++v) {
      if (!positions[k].row(v).allFinite()) {
        throw FileIOError(path + ": " +
                          (k == 0 ? std::string("base mesh")
                                  : "morph target " + std::to_string(k - 1)) +
                          " vertex " + std::to_string(v) + " is not finite");
      }
    }
  }

  // Weld vertices that glTF split along texture seams: same position in the base mesh and in
  // every target. The first occurrence becomes the rig vertex; order is otherwise kept.
  std::vector<int> rig_vertex_of(num_file_vertices);
  std::vector<int> file_vertex_of_rig;
  {
    auto hash_of = [&](int v) {
      size_t h = 0;
      for (int k = 0; k <= num_targets; ++k) {
        for (int c = 0; c < 3; ++c) {
          uint32_t bits;
          const float x = positions[k](v, c);
          std::memcpy(&bits, &x, sizeof(bits));
          h = h * 1000003u ^ std::hash<uint32_t>()(bits);
        }
      }
      return h;
    };
    auto same = [&](int a, int b) {
      for (int k = 0; k <= num_targets; ++k) {
        if (positions[k].row(a) != positions[k].row(b)) return false;
      }
      return true;
    };
    std::unordered_multimap<size_t, int> seen;
    for (int v = 0; v < num_file_vertices; ++v) {
      const size_t h = hash_of(v);
      int match = -1;
      auto range = seen.equal_range(h);
      for (auto it = range.first; it != range.second && match < 0; ++it) {
        if (same(file_vertex_of_rig[it->second], v)) match = it->second;
      }
      if (match < 0) {
        match = static_cast<int>(file_vertex_of_rig.size());
        file_vertex_of_rig.push_back(v);
        seen.emplace(h, match);
      }
      rig_vertex_of[v] = match;
    }
  }

  rig::Rig rig;
  const int num_vertices = static_cast<int>(file_vertex_of_rig.size());
  rig.neutral.resize(num_vertices, 3);
  for (int v = 0; v < num_vertices; ++v) rig.neutral.row(v) = positions[0].row(file_vertex_of_rig[v]);
  std::vector<Eigen::Vector3i> triangles, uv_triangles;
  for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
    const aiFace& face = mesh->mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines of a mixed primitive
    Eigen::Vector3i file_corners, rig_corners;
    for (int c = 0; c < 3; ++c) {
      const int v = static_cast<int>(face.mIndices[c]);
      if (v < 0 || v >= num_file_vertices) {
        throw FileIOError(path + ": face " + std::to_string(f) + " has vertex index " +
                          std::to_string(v) + " outside [0, " +
                          std::to_string(num_file_vertices) + ")");
      }
      file_corners[c] = v;
      rig_corners[c] = rig_vertex_of[v];
    }
    triangles.push_back(rig_corners);
    uv_triangles.push_back(file_corners);
  }
  if (triangles.empty()) throw FileIOError(path + ": the mesh has no triangles");
  rig.triangles.resize(static_cast<int>(triangles.size()), 3);
  for (size_t f = 0; f < triangles.size(); ++f) rig.triangles.row(f) = triangles[f].transpose();
  if (mesh->HasTextureCoords(0)) {
    // One texture coordinate per file vertex; assimp already flipped v to the bottom-left origin.
    rig.uvs.resize(num_file_vertices, 2);
    for (int v = 0; v < num_file_vertices; ++v) {
      rig.uvs.row(v) << mesh->mTextureCoords[0][v].x, mesh->mTextureCoords[0][v].y;
    }
    rig.uv_triangles.resize(static_cast<int>(uv_triangles.size()), 3);
    for (size_t f = 0; f < uv_triangles.size(); ++f) {
      rig.uv_triangles.row(f) = uv_triangles[f].transpose();
    }
  }
  FillDefaultRigFields(&rig);

  std::set<std::string> used_names;
  for (int t = 0; t < num_targets; ++t) {
    rig::Shape shape;
    shape.name = mesh->mAnimMeshes[t]->mName.C_Str();
    if (shape.name.empty() || used_names.count(shape.name)) shape.name = "shape_" + std::to_string(t);
    used_names.insert(shape.name);
    rig::Vertices target(num_vertices, 3);
    for (int v = 0; v < num_vertices; ++v) target.row(v) = positions[1 + t].row(file_vertex_of_rig[v]);
    shape.delta = SparseDifference(target, rig.neutral);  // D_i = S_i - N
    rig.shapes.push_back(std::move(shape));
  }
  std::string why;
  if (!rig.Check(&why)) throw FileIOError(path + ": rig is invalid: " + why);
  return rig;
}

namespace {

// glTF of the rig's triangles and texture coordinates at vertex `positions` (cm, #V x 3), with
// one morph target per shape when `morph_targets`, and the animation when given.
// Checks an animation's frame rate and weight counts against the shapes exported.
void CheckGltfAnimation(const std::vector<std::vector<float>>* animation_weights, float fps,
                        int num_shapes, const std::string& path) {
  if (!animation_weights) return;
  if (!(fps > 0.f) || !std::isfinite(fps)) {
    throw InvalidInputError("ExportRigToGltf(" + path + "): fps must be positive, got " +
                            std::to_string(fps));
  }
  if (num_shapes == 0) {
    throw InvalidInputError("ExportRigToGltf(" + path + "): an animation needs shapes");
  }
  for (size_t f = 0; f < animation_weights->size(); ++f) {
    if (static_cast<int>((*animation_weights)[f].size()) != num_shapes) {
      throw InvalidInputError("ExportRigToGltf(" + path + "): animation frame " +
                              std::to_string(f) + " has " +
                              std::to_string((*animation_weights)[f].size()) +
                              " weights for " + std::to_string(num_shapes) + " shapes");
    }
  }
}

// glTF has one index per corner: vertices split along texture seams. File vertex v < #V is
// rig vertex v (with the uv of its first corner), seam copies follow, so that welding on
// import gives the rig's vertex order back.
struct GltfVertices {
  std::vector<int> source_vertex, source_uv;  // per file vertex: rig vertex and uv (-1: none)
  std::vector<uint32_t> indices;              // per corner
};

GltfVertices SplitAtSeams(const rig::Rig& rig) {
  const int num_vertices = rig.NumVertices();
  const bool has_uvs = rig.uvs.rows() > 0;
  GltfVertices out;
  out.source_vertex.resize(num_vertices);
  out.source_uv.assign(num_vertices, -1);
  for (int v = 0; v < num_vertices; ++v) out.source_vertex[v] = v;
  out.indices.reserve(3 * rig.triangles.rows());
  std::unordered_map<uint64_t, int> seam_copy;
  for (int f = 0; f < rig.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = rig.triangles(f, c);
      if (!has_uvs) {
        out.indices.push_back(v);
        continue;
      }
      const int t = rig.uv_triangles(f, c);
      if (out.source_uv[v] < 0) out.source_uv[v] = t;
      if (out.source_uv[v] == t) {
        out.indices.push_back(v);
        continue;
      }
      const uint64_t key = (static_cast<uint64_t>(v) << 32) | static_cast<uint32_t>(t);
      auto [it, inserted] = seam_copy.emplace(key, static_cast<int>(out.source_vertex.size()));
      if (inserted) {
        out.source_vertex.push_back(v);
        out.source_uv.push_back(t);
      }
      out.indices.push_back(it->second);
    }
  }
  return out;
}

// The accessors of the mesh: positions, uvs (-1: none), indices, one morph target per shape.
struct GltfMeshAccessors {
  int position = -1, uv = -1, index = -1;
  int image_view = -1;  // bufferView of the embedded base colour PNG (-1: none)
  std::vector<int> targets;
};

GltfMeshAccessors AddMeshData(const rig::Rig& rig, const rig::Vertices& positions, int num_shapes,
                              const GltfVertices& vertices, GltfBufferBuilder* buffer) {
  const int num_file_vertices = static_cast<int>(vertices.source_vertex.size());
  GltfMeshAccessors a;
  std::vector<float> data(3 * num_file_vertices);
  for (int i = 0; i < num_file_vertices; ++i) {
    for (int c = 0; c < 3; ++c) {
      data[3 * i + c] = positions(vertices.source_vertex[i], c) / kCentimetresPerMetre;
    }
  }
  a.position = buffer->AddFloats(data, 3, true, 34962);
  if (rig.uvs.rows() > 0) {
    std::vector<float> uv(2 * num_file_vertices);
    for (int i = 0; i < num_file_vertices; ++i) {
      const int t = vertices.source_uv[i];
      uv[2 * i] = t >= 0 ? rig.uvs(t, 0) : 0.f;
      uv[2 * i + 1] = t >= 0 ? 1.f - rig.uvs(t, 1) : 1.f;  // glTF's v runs downwards
    }
    a.uv = buffer->AddFloats(uv, 2, false, 34962);
  }
  a.index = buffer->AddIndices(vertices.indices);
  // Morph targets: the full effect S(e_i) - N of each shape, jaw skinning baked in.
  const std::vector<rig::Vertices> shapes = num_shapes > 0 ? FullShapes(rig) : std::vector<rig::Vertices>();
  for (int s = 0; s < num_shapes; ++s) {
    for (int i = 0; i < num_file_vertices; ++i) {
      const int v = vertices.source_vertex[i];
      for (int c = 0; c < 3; ++c) {
        data[3 * i + c] = (shapes[s](v, c) - rig.neutral(v, c)) / kCentimetresPerMetre;
      }
    }
    a.targets.push_back(buffer->AddFloats(data, 3, true, 34962));
  }
  return a;
}

// One entry of "meshes": its primitive (with `material`, -1: none) and its morph targets,
// named in extras.targetNames.
std::string GltfMeshObject(const std::string& name, const GltfMeshAccessors& a, int material,
                           const std::vector<std::string>& target_names) {
  const int num_shapes = static_cast<int>(a.targets.size());
  std::string json = "{\"name\":" + JsonString(name) + ",\"primitives\":[{\"attributes\":{\"POSITION\":" +
                     std::to_string(a.position);
  if (a.uv >= 0) json += ",\"TEXCOORD_0\":" + std::to_string(a.uv);
  json += "},\"indices\":" + std::to_string(a.index) + ",\"mode\":4";
  if (material >= 0) json += ",\"material\":" + std::to_string(material);
  if (num_shapes > 0) {
    json += ",\"targets\":[";
    for (int s = 0; s < num_shapes; ++s) {
      json += (s ? "," : "") + std::string("{\"POSITION\":") + std::to_string(a.targets[s]) + "}";
    }
    json += "]";
  }
  json += "}]";
  if (num_shapes > 0) {
    json += ",\"weights\":" + GltfBufferBuilder::FloatArray(std::vector<float>(num_shapes, 0.f));
    json += ",\"extras\":{\"targetNames\":[";
    for (int s = 0; s < num_shapes; ++s) json += (s ? "," : "") + JsonString(target_names[s]);
    json += "]}";
  }
  return json + "}";
}

// The JSON from "asset" through "meshes": one node per mesh (the face first).
std::string GltfMeshesJson(const std::vector<std::string>& names, const std::vector<std::string>& meshes) {
  std::string json = "{\"asset\":{\"version\":\"2.0\",\"generator\":\"facecap\"},\"scene\":0,\"scenes\":[{\"nodes\":[";
  for (size_t k = 0; k < names.size(); ++k) json += (k ? "," : "") + std::to_string(k);
  json += "]}],\"nodes\":[";
  for (size_t k = 0; k < names.size(); ++k) {
    json += (k ? "," : "") + std::string("{\"name\":") + JsonString(names[k]) + ",\"mesh\":" + std::to_string(k) + "}";
  }
  json += "],\"meshes\":[";
  for (size_t k = 0; k < meshes.size(); ++k) json += (k ? "," : "") + meshes[k];
  return json + "]";
}

// One material: a base colour factor (linear RGBA) and texture (an index into "textures",
// -1: none), not metallic.
struct GltfMaterial {
  std::string name;
  Eigen::Vector4f factor = Eigen::Vector4f::Ones();
  int texture = -1;
  float roughness = 0.6f;
  bool blend = false;
};

// ",materials" ... ",images": the materials, and one texture per embedded PNG (bufferViews
// `image_views`), sampled with mipmaps and clamped at the UV square's edges.
std::string GltfMaterialsJson(const std::vector<GltfMaterial>& materials, const std::vector<int>& image_views,
                              const std::vector<std::string>& image_names) {
  std::string json = ",\"materials\":[";
  for (size_t k = 0; k < materials.size(); ++k) {
    const GltfMaterial& m = materials[k];
    json += (k ? "," : "") + std::string("{\"name\":") + JsonString(m.name) + ",\"pbrMetallicRoughness\":{";
    if (m.factor != Eigen::Vector4f::Ones()) {
      json += "\"baseColorFactor\":" +
              GltfBufferBuilder::FloatArray({m.factor[0], m.factor[1], m.factor[2], m.factor[3]}) + ",";
    }
    if (m.texture >= 0) json += "\"baseColorTexture\":{\"index\":" + std::to_string(m.texture) + "},";
    json += "\"metallicFactor\":0,\"roughnessFactor\":" + JsonNumber(m.roughness) + "}";
    if (m.blend) json += ",\"alphaMode\":\"BLEND\"";
    json += "}";
  }
  json += "]";
  if (image_views.empty()) return json;
  json += ",\"textures\":[";
  for (size_t k = 0; k < image_views.size(); ++k) {
    json += (k ? "," : "") + std::string("{\"sampler\":0,\"source\":") + std::to_string(k) + "}";
  }
  json += "],\"samplers\":[{\"magFilter\":9729,\"minFilter\":9987,\"wrapS\":33071,\"wrapT\":33071}],\"images\":[";
  for (size_t k = 0; k < image_views.size(); ++k) {
    json += (k ? "," : "") + std::string("{\"name\":") + JsonString(image_names[k]) +
            ",\"mimeType\":\"image/png\",\"bufferView\":" + std::to_string(image_views[k]) + "}";
  }
  return json + "]";
}

// ",animations": the morph-target weights per frame at `fps`, linearly interpolated, driving
// the weights of nodes 0 .. num_nodes - 1 (every mesh has one target per shape).
std::string GltfAnimationJson(const std::vector<std::vector<float>>& animation_weights, float fps,
                              int num_shapes, int num_nodes, GltfBufferBuilder* buffer) {
  const size_t num_frames = animation_weights.size();
  std::vector<float> times(num_frames), weights;
  weights.reserve(num_frames * num_shapes);
  for (size_t f = 0; f < num_frames; ++f) {
    times[f] = static_cast<float>(f) / fps;
    weights.insert(weights.end(), animation_weights[f].begin(), animation_weights[f].end());
  }
  const int time_accessor = buffer->AddFloats(times, 1, true, 0);
  const int weight_accessor = buffer->AddFloats(weights, 1, false, 0);
  std::string json = ",\"animations\":[{\"name\":\"performance\",\"samplers\":[{\"input\":" +
                     std::to_string(time_accessor) + ",\"output\":" + std::to_string(weight_accessor) +
                     ",\"interpolation\":\"LINEAR\"}],\"channels\":[";
  for (int n = 0; n < num_nodes; ++n) {
    json += (n ? "," : "") + std::string("{\"sampler\":0,\"target\":{\"node\":") + std::to_string(n) +
            ",\"path\":\"weights\"}}";
  }
  return json + "]}]";
}

// The accessors of an extra mesh: positions, uvs, indices and its morph targets (deltas).
GltfMeshAccessors AddExtraMeshData(const GltfExtraMesh& m, int num_shapes, GltfBufferBuilder* buffer) {
  GltfMeshAccessors a;
  const int n = static_cast<int>(m.neutral.rows());
  std::vector<float> data(3 * n);
  for (int i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) data[3 * i + c] = m.neutral(i, c) / kCentimetresPerMetre;
  }
  a.position = buffer->AddFloats(data, 3, true, 34962);
  if (m.uvs.rows() == n) {
    std::vector<float> uv(2 * n);
    for (int i = 0; i < n; ++i) {
      uv[2 * i] = m.uvs(i, 0);
      uv[2 * i + 1] = 1.f - m.uvs(i, 1);
    }
    a.uv = buffer->AddFloats(uv, 2, false, 34962);
  }
  std::vector<uint32_t> indices;
  for (int f = 0; f < m.triangles.rows(); ++f) {
    for (int c = 0; c < 3; ++c) indices.push_back(static_cast<uint32_t>(m.triangles(f, c)));
  }
  a.index = buffer->AddIndices(indices);
  for (int s = 0; s < num_shapes; ++s) {
    for (int i = 0; i < 3 * n; ++i) data[i] = m.deltas(i, s) / kCentimetresPerMetre;
    a.targets.push_back(buffer->AddFloats(data, 3, true, 34962));
  }
  return a;
}

void CheckExtraMeshes(const std::vector<GltfExtraMesh>* extra, int num_shapes, const std::string& path) {
  if (!extra) return;
  for (const GltfExtraMesh& m : *extra) {
    const int n = static_cast<int>(m.neutral.rows());
    const bool ok = n > 0 && m.neutral.allFinite() && (m.uvs.rows() == 0 || m.uvs.rows() == n) &&
                    m.deltas.rows() == 3 * n && m.deltas.cols() >= num_shapes && m.deltas.allFinite() &&
                    (m.triangles.rows() == 0 || (m.triangles.minCoeff() >= 0 && m.triangles.maxCoeff() < n)) &&
                    (!m.texture || (!m.texture->empty() && m.texture->channels == 3 && m.uvs.rows() == n));
    if (!ok) throw InvalidInputError("cannot export " + path + ": extra mesh " + m.name + " is malformed");
  }
}

// Writes the JSON (without its "buffers") and the buffer as a .glb container, or as .gltf
// text with the buffer in a base64 data URI.
void CheckGltfTexture(const rig::Rig& rig, const Image8* base_color, const std::string& path) {
  if (!base_color) return;
  if (rig.uvs.rows() == 0) {
    throw InvalidInputError("cannot export " + path + ": a texture for a rig without UVs");
  }
  if (base_color->empty() || base_color->channels != 3) {
    throw InvalidInputError("cannot export " + path + ": the texture must be a non-empty RGB image");
  }
}

void WriteGltfFile(std::string json, std::string bytes, const std::string& path) {
  while (bytes.size() % 4) bytes += '\0';
  if (!EndsWith(path, ".glb")) {
    json += ",\"buffers\":[{\"byteLength\":" + std::to_string(bytes.size()) +
            ",\"uri\":\"data:application/octet-stream;base64," + Base64(bytes) + "\"}]}";
    WriteFileAtomically(path, json);
    return;
  }
  json += ",\"buffers\":[{\"byteLength\":" + std::to_string(bytes.size()) + "}]}";
  while (json.size() % 4) json += ' ';
  std::string glb;
  glb.reserve(12 + 8 + json.size() + 8 + bytes.size());
  glb += "glTF";
  AppendUint32(&glb, 2);
  AppendUint32(&glb, static_cast<uint32_t>(12 + 8 + json.size() + 8 + bytes.size()));
  AppendUint32(&glb, static_cast<uint32_t>(json.size()));
  glb += "JSON";
  glb += json;
  AppendUint32(&glb, static_cast<uint32_t>(bytes.size()));
  glb += std::string("BIN\0", 4);
  glb += bytes;
  WriteFileAtomically(path, glb);
}

void WriteGltf(const rig::Rig& rig, const rig::Vertices& positions, bool morph_targets,
               const std::vector<std::vector<float>>* animation_weights, float fps,
               const Image8* base_color, const std::vector<GltfExtraMesh>* extra, const std::string& path) {
  const int num_shapes = morph_targets ? rig.NumShapes() : 0;
  CheckGltfAnimation(animation_weights, fps, num_shapes, path);
  CheckGltfTexture(rig, base_color, path);
  CheckExtraMeshes(extra, num_shapes, path);
  const GltfVertices vertices = SplitAtSeams(rig);
  GltfBufferBuilder buffer;
  const GltfMeshAccessors accessors = AddMeshData(rig, positions, num_shapes, vertices, &buffer);
  std::vector<std::string> target_names;
  for (int s = 0; s < num_shapes; ++s) target_names.push_back(rig.shapes[s].name);
  std::vector<GltfMaterial> materials;
  std::vector<int> image_views;
  std::vector<std::string> image_names;
  if (base_color) {
    image_views.push_back(buffer.AddBytes(EncodePng(*base_color)));
    image_names.push_back("albedo");
    GltfMaterial skin;
    skin.name = "skin";
    skin.texture = 0;
    materials.push_back(skin);
  }
  std::vector<const Image8*> textures;  // the extra meshes' distinct textures, in image order
  std::vector<std::string> names = {"face"};
  std::vector<std::string> meshes = {GltfMeshObject("face", accessors, base_color ? 0 : -1, target_names)};
  if (extra) {
    for (const GltfExtraMesh& m : *extra) {
      const GltfMeshAccessors a = AddExtraMeshData(m, num_shapes, &buffer);
      GltfMaterial material;
      material.name = m.material.empty() ? m.name : m.material;
      material.factor = m.base_color;
      material.roughness = m.roughness;
      material.blend = m.blend;
      if (m.texture) {
        // One embedded image per distinct texture (both eyeballs share the iris).
        auto known = std::find(textures.begin(), textures.end(), m.texture);
        if (known == textures.end()) {
          textures.push_back(m.texture);
          image_views.push_back(buffer.AddBytes(EncodePng(*m.texture)));
          image_names.push_back(m.name);
          known = textures.end() - 1;
        }
        material.texture = static_cast<int>(known - textures.begin()) + (base_color ? 1 : 0);
      }
      materials.push_back(material);
      names.push_back(m.name);
      meshes.push_back(GltfMeshObject(m.name, a, static_cast<int>(materials.size()) - 1, target_names));
    }
  }
  std::string json = GltfMeshesJson(names, meshes);
  if (!materials.empty()) json += GltfMaterialsJson(materials, image_views, image_names);
  if (animation_weights && !animation_weights->empty()) {
    json += GltfAnimationJson(*animation_weights, fps, num_shapes, static_cast<int>(names.size()), &buffer);
  }
  json += ",\"accessors\":" + buffer.AccessorsJson();
  json += ",\"bufferViews\":" + buffer.ViewsJson();
  WriteGltfFile(std::move(json), buffer.bytes(), path);
}

}  // namespace

void ExportRigToGltf(const rig::Rig& rig, const std::string& path,
                     const std::vector<std::vector<float>>* animation_weights, float fps,
                     const Image8* base_color, const std::vector<GltfExtraMesh>* extra_meshes) {
  CheckRigForExport(rig, path);
  WriteGltf(rig, rig.neutral, true, animation_weights, fps, base_color, extra_meshes, path);
}

void ExportPosedMesh(const rig::Rig& rig, const rig::Vertices& posed, const std::string& path) {
  CheckRigForExport(rig, path);
  if (posed.rows() != rig.NumVertices()) {
    throw InvalidInputError("ExportPosedMesh(" + path + "): " + std::to_string(posed.rows()) +
                            " posed vertices for a rig of " + std::to_string(rig.NumVertices()));
  }
  if (!posed.allFinite()) {
    throw InvalidInputError("ExportPosedMesh(" + path + "): non-finite posed vertex");
  }
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") {
    const bool has_uvs = rig.uvs.rows() > 0;
    ExportMeshObj(posed, rig.triangles, has_uvs ? &rig.uvs : nullptr,
                  has_uvs ? &rig.uv_triangles : nullptr, path);
  } else if (extension == ".glb" || extension == ".gltf") {
    WriteGltf(rig, posed, false, nullptr, 30.f, nullptr, nullptr, path);
  } else {
    throw InvalidInputError("ExportPosedMesh(" + path +
                            "): the extension must be .obj, .glb or .gltf");
  }
}

}  // namespace facecap::io
