// A plain interleaved image buffer, row-major, (x, y) with y down. No file formats here:
// reading and writing images lives in io/image_io.h.
#ifndef FACECAP_UTIL_IMAGE_H_
#define FACECAP_UTIL_IMAGE_H_

#include <cstdint>
#include <vector>

namespace facecap {

template <typename T>
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<T> data;  // height * width * channels, interleaved

  Image() = default;
  Image(int w, int h, int c, T fill = T(0))
      : width(w), height(h), channels(c), data(static_cast<size_t>(w) * h * c, fill) {}

  T& at(int x, int y, int c = 0) {
    return data[(static_cast<size_t>(y) * width + x) * channels + c];
  }
  const T& at(int x, int y, int c = 0) const {
    return data[(static_cast<size_t>(y) * width + x) * channels + c];
  }
  T* pixel(int x, int y) { return &data[(static_cast<size_t>(y) * width + x) * channels]; }
  const T* pixel(int x, int y) const {
    return &data[(static_cast<size_t>(y) * width + x) * channels];
  }
  bool empty() const { return data.empty(); }
  size_t size() const { return data.size(); }
};

using Image8 = Image<uint8_t>;
using ImageF = Image<float>;

}  // namespace facecap

#endif  // FACECAP_UTIL_IMAGE_H_
