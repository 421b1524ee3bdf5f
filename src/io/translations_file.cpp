#include "io/translations_file.h"

#include "io/frames_file.h"
#include "util/errors.h"

namespace facecap::io {

TranslationsFile::TranslationsFile(const std::string& path) : file_(H5File::OpenRead(path)) {
  if (!file_.Exists(frames::kTranslated)) {
    throw FileIOError(path + ": no " + std::string(frames::kTranslated) +
                      " (an output of deepfake infer is expected)");
  }
  const Shape shape = file_.CheckShape(frames::kTranslated, {-1, -1, -1, 3});
  if (shape[1] != shape[2]) {
    throw FileIOError(path + ": " + frames::kTranslated + " has shape " + ShapeToString(shape) +
                      ", expected [N, S, S, 3] (square translations of deepfake infer)");
  }
  count_ = shape[0];
  size_ = static_cast<int>(shape[1]);
}

Image8 TranslationsFile::ReadFrame(int64_t frame) const {
  if (frame < 0 || frame >= count_) {
    throw FileIOError(path() + ": no translation of frame " + std::to_string(frame) + " (" +
                      std::to_string(count_) + " frames)");
  }
  Image8 image(size_, size_, 3);
  file_.ReadFrames<uint8_t>(frames::kTranslated, frame, 1, image.data.data());
  return image;
}

std::vector<uint8_t> TranslationsFile::ReadAll() const {
  return file_.Read<uint8_t>(frames::kTranslated, {count_, size_, size_, 3});
}

}  // namespace facecap::io
