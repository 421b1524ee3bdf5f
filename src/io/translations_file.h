// The translations of deepfake infer: /frames/translated (frames_file.h), [N, S, S, 3] uint8
// RGB, each frame's square translation D_A(E(I)) (or D_B(E(I))) at the network's size S,
// row-major from the top-left pixel. The file's codes and camera are read elsewhere.
#ifndef FACECAP_IO_TRANSLATIONS_FILE_H_
#define FACECAP_IO_TRANSLATIONS_FILE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "io/hdf5.h"
#include "util/image.h"

namespace facecap::io {

class TranslationsFile {
 public:
  // Opens `path` read-only. FileIOError naming the file when it has no /frames/translated or
  // its shape is not [N, S, S, 3].
  explicit TranslationsFile(const std::string& path);

  const std::string& path() const { return file_.path(); }
  int64_t count() const { return count_; }  // N
  int size() const { return size_; }        // S: the width and height in pixels

  // Translation `frame` as an S x S RGB image; FileIOError naming the file when the file has
  // no such frame.
  Image8 ReadFrame(int64_t frame) const;
  // Every translation, [N, S, S, 3] row-major.
  std::vector<uint8_t> ReadAll() const;

 private:
  H5File file_;
  int64_t count_ = 0;
  int size_ = 0;
};

}  // namespace facecap::io

#endif  // FACECAP_IO_TRANSLATIONS_FILE_H_
