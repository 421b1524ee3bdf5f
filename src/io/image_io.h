// Image files through OpenImageIO: PNG, JPEG, EXR, TIFF, ... chosen by extension. Writes are
// atomic (a temporary name, then rename). Only io/ includes OIIO headers.
#ifndef FACECAP_IO_IMAGE_IO_H_
#define FACECAP_IO_IMAGE_IO_H_

#include <string>

#include "util/image.h"

namespace facecap::io {

// Writes 8-bit images (1, 3 or 4 channels).
void WriteImage(const std::string& path, const Image8& image);
// Writes float images; EXR keeps the floats, 8-bit formats clamp [0, 1] and quantize.
void WriteImage(const std::string& path, const ImageF& image);
// Reads any supported image as 8-bit with `channels` channels (1 or 3): grayscale is
// replicated, alpha dropped, 16-bit and float data converted. FileIOError names the file.
Image8 ReadImage8(const std::string& path, int channels = 3);
// Reads any supported image as floats with `channels` channels (1 or 3), converted as
// ReadImage8 converts; integer formats come as [0, 1], float formats (EXR, float TIFF) as
// stored. *is_float (when given) tells which the file held. FileIOError names the file.
ImageF ReadImageF(const std::string& path, int channels, bool* is_float = nullptr);
// The bytes of a PNG file of an 8-bit image (1, 3 or 4 channels), encoded in memory.
std::string EncodePng(const Image8& image);

}  // namespace facecap::io

#endif  // FACECAP_IO_IMAGE_IO_H_
