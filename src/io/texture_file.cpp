#include "io/texture_file.h"

#include <cmath>

#include "util/errors.h"

namespace facecap::io {

void WriteColorTexture(H5File* file, const std::string& name, const ImageF& texture) {
  if (texture.channels != 3 || texture.width != texture.height || texture.width < 1) {
    throw InvalidInputError("texture " + name + ": need a square 3-channel texture");
  }
  file->Write<float>(name, {texture.height, texture.width, 3}, texture.data.data());
  file->SetAttribute(name, "layout",
                     std::string("y (row 0 at v = 1), x (u), RGB; linear RGB in [0, 1]"));
}

ImageF ReadColorTexture(const std::string& path, const std::string& name) {
  H5File f = H5File::OpenRead(path);
  if (!f.Exists(name)) throw FileIOError(path + ": no texture " + name);
  Shape shape;
  std::vector<float> data = f.Read<float>(name, {-1, -1, 3}, &shape);
  if (shape[0] != shape[1] || shape[0] < 1) {
    throw FileIOError(path + ": texture " + name + " is " + std::to_string(shape[0]) + " x " +
                      std::to_string(shape[1]) + ", not square");
  }
  for (float v : data) {
    if (!std::isfinite(v)) throw FileIOError(path + ": texture " + name + " has a value that is not finite");
  }
  ImageF texture(static_cast<int>(shape[1]), static_cast<int>(shape[0]), 3);
  texture.data = std::move(data);
  return texture;
}

ImageF ReadRigTexture(const std::string& path) {
  if (!H5File::OpenRead(path).Exists(kTextureAlbedoPath)) return ImageF();
  return ReadColorTexture(path, kTextureAlbedoPath);
}

}  // namespace facecap::io
