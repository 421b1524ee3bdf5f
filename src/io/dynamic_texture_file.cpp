#include "io/dynamic_texture_file.h"

#include <cmath>
#include <utility>

#include "io/texture_file.h"
#include "util/errors.h"

namespace facecap::io {

namespace {
constexpr const char* kGroup = "/dynamic_texture";
constexpr int kC = kSkinMapChannels;
}  // namespace

ImageF SkinMapLayer(const std::vector<float>& maps, int size, int first, int count) {
  ImageF image(size, size, count);
  const size_t n = static_cast<size_t>(size) * size;
  for (size_t t = 0; t < n; ++t) {
    for (int c = 0; c < count; ++c) image.data[t * count + c] = maps[t * kC + first + c];
  }
  return image;
}

void WriteDynamicTextureLibrary(H5File* file, const DynamicTextureLibrary& library) {
  const int64_t S = library.size;
  const size_t maps = static_cast<size_t>(S) * S * kC;
  if (S < 1 || library.neutral.size() != maps || library.compress.size() != maps || library.stretch.size() != maps ||
      library.influence.size() != static_cast<size_t>(library.num_shapes) * library.num_vertices * 2 ||
      library.reference.size() != static_cast<size_t>(S) * S * 2) {
    throw InvalidInputError("dynamic texture library: maps or influences of the wrong size");
  }
  for (const auto& [name, data] : {std::pair<const char*, const std::vector<float>*>{"neutral", &library.neutral},
                                   {"compress", &library.compress}, {"stretch", &library.stretch}}) {
    const std::string path = std::string(kGroup) + "/" + name;
    file->Write<float>(path, {S, S, kC}, data->data());
    file->SetAttribute(path, "channels", std::string(kSkinMapChannelNames));
  }
  file->Write<float>(std::string(kGroup) + "/influence", {library.num_shapes, library.num_vertices, 2},
                     library.influence.data());
  file->SetAttribute(std::string(kGroup) + "/influence", "channels", std::string("compress_cm stretch_cm"));
  file->Write<float>(std::string(kGroup) + "/reference", {S, S, 2}, library.reference.data());
  file->SetAttribute(std::string(kGroup) + "/reference", "channels", std::string("compress_cm stretch_cm"));
  file->SetAttribute(std::string(kGroup) + "/compress", "sharpness_per_cm", static_cast<double>(library.sharpness));
  WriteColorTexture(file, kTextureAlbedoPath, SkinMapLayer(library.neutral, library.size, 0, 3));
}

bool HasDynamicTexture(const std::string& path) {
  return H5File::OpenRead(path).Exists(std::string(kGroup) + "/compress");
}

DynamicTextureLibrary ReadDynamicTextureLibrary(const std::string& path, int num_shapes, int num_vertices) {
  const H5File f = H5File::OpenRead(path);
  DynamicTextureLibrary lib;
  const std::string group(kGroup);
  for (const char* name : {"neutral", "compress", "stretch", "influence", "reference"}) {
    if (!f.Exists(group + "/" + name)) {
      throw FileIOError(path + ": no " + group + "/" + name +
                        " (a library made before the strain texture? make it again with textures library or "
                        "textures infer)");
    }
  }
  const Shape shape = f.DatasetShape(group + "/neutral");
  if (shape.size() != 3 || shape[0] != shape[1] || shape[0] < 1 || shape[2] != kC) {
    throw FileIOError(path + ": " + group + "/neutral must be [S, S, 5]");
  }
  lib.size = static_cast<int>(shape[0]);
  const int64_t S = lib.size;
  lib.neutral = f.Read<float>(group + "/neutral", {S, S, kC});
  lib.compress = f.Read<float>(group + "/compress", {S, S, kC});
  lib.stretch = f.Read<float>(group + "/stretch", {S, S, kC});
  lib.influence = f.Read<float>(group + "/influence", {num_shapes, num_vertices, 2});
  lib.reference = f.Read<float>(group + "/reference", {S, S, 2});
  lib.num_shapes = num_shapes;
  lib.num_vertices = num_vertices;
  lib.sharpness = static_cast<float>(f.GetDoubleAttribute(group + "/compress", "sharpness_per_cm"));
  for (const auto* v : {&lib.neutral, &lib.compress, &lib.stretch, &lib.influence, &lib.reference}) {
    for (float x : *v) {
      if (!std::isfinite(x)) throw FileIOError(path + ": " + group + " holds a value that is not finite");
    }
  }
  for (const auto* v : {&lib.influence, &lib.reference}) {
    for (float x : *v) {
      if (x < 0.f) throw FileIOError(path + ": " + group + " holds a negative influence");
    }
  }
  if (!(lib.sharpness > 0.f)) throw FileIOError(path + ": " + group + "/compress@sharpness_per_cm must be > 0");
  return lib;
}

}  // namespace facecap::io
