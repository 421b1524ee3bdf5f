// Frames from a video file (OpenCV VideoCapture, ffmpeg backend) or a folder of images, as
// 8-bit RGB, with random access by frame index so that ranks can read disjoint blocks.
// Grayscale, 16-bit, float and alpha images are converted (and flagged); images above a
// pixel budget are scaled down for processing (and flagged); frames that cannot be decoded
// come back with ok = false and the reason, never as an exception.
#ifndef FACECAP_FACE_FRAME_SOURCE_H_
#define FACECAP_FACE_FRAME_SOURCE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "util/image.h"

namespace facecap::face {

// Bits of a frame's input flags (/frames/input_flags): what was converted on the way in.
enum InputFlag : int32_t {
  kInputFromGrayscale = 1,  // a 1-channel image, replicated to RGB
  kInputFrom16Bit = 2,      // 16-bit samples, scaled to 8 bits
  kInputFromFloat = 4,      // floating-point samples, clamped to [0, 1] and scaled
  kInputDroppedAlpha = 8,   // an alpha channel was dropped
  kInputDownscaled = 16,    // larger than the pixel budget: processed at a smaller size
};

struct DecodedFrame {
  bool ok = false;           // false: unreadable, see error
  std::string error;         // why the frame could not be read
  Image8 image;              // RGB, 8-bit; possibly scaled down (see source_scale)
  double source_scale = 1.0; // source pixels per processing pixel (> 1 after a downscale)
  int source_width = 0;      // size of the frame in the file
  int source_height = 0;
  int32_t input_flags = 0;   // InputFlag bits
};

class FrameSource {
 public:
  // Opens a video file. FileIOError when it cannot be opened, or holds no decodable frame.
  static std::unique_ptr<FrameSource> OpenVideo(const std::string& path, int64_t max_pixels);
  // Opens a folder of images (png, jpg, jpeg, bmp, tif, tiff, webp, pgm, ppm, exr; sorted by
  // name). FileIOError when the folder is missing or holds no image file.
  static std::unique_ptr<FrameSource> OpenImages(const std::string& folder, int64_t max_pixels);

  virtual ~FrameSource() = default;
  // Frames in the source (video: as the container reports, or counted when it does not).
  virtual int64_t NumFrames() const = 0;
  // Frames per second (0 for image folders).
  virtual double Fps() const = 0;
  // The files frames come from (one for a video, one per frame for a folder).
  virtual const std::vector<std::string>& Files() const = 0;
  // Which of Files() frame `index` comes from.
  virtual int32_t FileIdOf(int64_t index) const = 0;
  // Seconds from the start of the video (-1 for still images).
  virtual double TimecodeOf(int64_t index) const = 0;
  // Decodes frame `index` in [0, NumFrames()). Sequential indices are cheapest.
  virtual DecodedFrame Read(int64_t index) = 0;
};

// Converts a decoded OpenCV-style buffer to 8-bit RGB: `depth_bits` 8 or 16 (unsigned) or
// 32 (float), `channels` 1-4 in BGR(A) order, rows of `width * channels` samples. Used by
// the readers; exposed for tests. Sets flags of the conversions made.
Image8 ToRgb8(const void* data, int width, int height, int channels, int depth_bits,
              int32_t* input_flags);

// Writes `frames` (RGB, equal sizes) as a Motion-JPEG AVI at `fps`: every frame is a key
// frame, so seeking is exact. For tests and benchmarks. OutputError on failure.
void WriteVideo(const std::string& path, const std::vector<Image8>& frames, double fps);

// Reads one image file as 8-bit RGB with the same conversions as a folder source.
DecodedFrame ReadImageFile(const std::string& path, int64_t max_pixels);

// Frames of a camera moving over a (real) photo: a slow zoom and pan, `width` x `height`
// each, for tests and benchmarks of the ingest path on real faces.
std::vector<Image8> CameraMoveClip(const Image8& photo, int width, int height, int num_frames);

}  // namespace facecap::face

#endif  // FACECAP_FACE_FRAME_SOURCE_H_
