#include "io/image_io.h"

#include <filesystem>
#include <type_traits>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include "util/errors.h"

namespace facecap::io {
namespace {

template <typename T>
void WriteAny(const std::string& path, const Image<T>& image, OIIO::TypeDesc type) {
  if (image.empty()) throw OutputError(path + ": empty image");
  const std::filesystem::path final_path(path);
  const std::string ext = final_path.extension().string();
  // Keep the extension on the temporary name: OIIO picks the format from it.
  const std::string tmp = (final_path.parent_path() / ("." + final_path.stem().string() +
                                                        ".partial" + ext)).string();
  std::error_code ec;
  if (!final_path.parent_path().empty()) std::filesystem::create_directories(final_path.parent_path(), ec);
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw OutputError(path + ": no image writer for extension '" + ext + "'");
  OIIO::ImageSpec spec(image.width, image.height, image.channels, type);
  if (!out->open(tmp, spec) || !out->write_image(type, image.data.data()) || !out->close()) {
    throw OutputError(path + ": cannot write image: " + out->geterror());
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw OutputError(path + ": cannot rename from " + tmp + ": " + ec.message());
}

}  // namespace

void WriteImage(const std::string& path, const Image8& image) {
  WriteAny(path, image, OIIO::TypeDesc::UINT8);
}

void WriteImage(const std::string& path, const ImageF& image) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".exr" || ext == ".EXR" || ext == ".tif" || ext == ".tiff") {
    WriteAny(path, image, OIIO::TypeDesc::FLOAT);
    return;
  }
  Image8 q(image.width, image.height, image.channels);
  for (size_t i = 0; i < image.data.size(); ++i) {
    const float v = std::min(1.f, std::max(0.f, image.data[i]));
    q.data[i] = static_cast<uint8_t>(v * 255.f + 0.5f);
  }
  WriteAny(path, q, OIIO::TypeDesc::UINT8);
}

std::string EncodePng(const Image8& image) {
  if (image.empty()) throw OutputError("EncodePng: empty image");
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("image.png", &proxy);
  if (!out) throw OutputError("EncodePng: no PNG writer: " + OIIO::geterror());
  const OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
  if (!out->open("image.png", spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, image.data.data()) || !out->close()) {
    throw OutputError("EncodePng: cannot encode: " + out->geterror());
  }
  return std::string(bytes.begin(), bytes.end());
}

namespace {

// Reads every channel of the image at `path` as `type` into raw (width x height x the file's
// channels), then keeps `channels` of them: grayscale is replicated to 3, RGB reduces to 1 by
// luma, alpha is dropped.
template <typename T>
Image<T> ReadImageAs(const std::string& path, int channels, OIIO::TypeDesc type, bool* is_float) {
  if (channels != 1 && channels != 3) throw InvalidInputError("image read: channels must be 1 or 3");
  if (!std::filesystem::is_regular_file(path)) throw FileIOError(path + ": no such image file");
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw FileIOError(path + ": cannot read as an image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    throw FileIOError(path + ": image has no pixels");
  }
  if (static_cast<int64_t>(spec.width) * spec.height > (int64_t{1} << 28)) {
    throw FileIOError(path + ": image of " + std::to_string(spec.width) + "x" +
                      std::to_string(spec.height) + " pixels is too large");
  }
  if (is_float) *is_float = spec.format.is_floating_point();
  Image<T> raw(spec.width, spec.height, spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, type, raw.data.data())) {
    throw FileIOError(path + ": cannot decode image: " + in->geterror());
  }
  in->close();
  Image<T> out(spec.width, spec.height, channels);
  for (int y = 0; y < spec.height; ++y) {
    for (int x = 0; x < spec.width; ++x) {
      const T* p = raw.pixel(x, y);
      T* q = out.pixel(x, y);
      if (channels == 1) {
        if (spec.nchannels < 3) {
          q[0] = p[0];
        } else if constexpr (std::is_same_v<T, uint8_t>) {
          q[0] = static_cast<uint8_t>((77 * p[0] + 150 * p[1] + 29 * p[2]) >> 8);
        } else {
          q[0] = 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2];
        }
      } else {
        for (int c = 0; c < 3; ++c) q[c] = p[spec.nchannels >= 3 ? c : 0];
      }
    }
  }
  return out;
}

}  // namespace

Image8 ReadImage8(const std::string& path, int channels) {
  return ReadImageAs<uint8_t>(path, channels, OIIO::TypeDesc::UINT8, nullptr);
}

ImageF ReadImageF(const std::string& path, int channels, bool* is_float) {
  return ReadImageAs<float>(path, channels, OIIO::TypeDesc::FLOAT, is_float);
}

}  // namespace facecap::io
