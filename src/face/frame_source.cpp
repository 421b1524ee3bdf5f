#include "face/frame_source.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "util/errors.h"
#include "util/log.h"

namespace facecap::face {
namespace {

namespace fs = std::filesystem;

// Scales `image` down to at most `max_pixels` pixels (INTER_AREA); returns the factor applied
// to the source size (<= 1).
double FitPixelBudget(cv::Mat* image, int64_t max_pixels) {
  const double pixels = static_cast<double>(image->cols) * image->rows;
  if (max_pixels <= 0 || pixels <= static_cast<double>(max_pixels)) return 1.0;
  const double factor = std::sqrt(static_cast<double>(max_pixels) / pixels);
  cv::Mat small;
  cv::resize(*image, small, cv::Size(), factor, factor, cv::INTER_AREA);
  const double actual = static_cast<double>(small.cols) / image->cols;
  *image = small;
  return actual;
}

// Any decoded cv::Mat to the DecodedFrame of an RGB 8-bit image within the pixel budget.
DecodedFrame FromMat(const cv::Mat& mat, int64_t max_pixels) {
  DecodedFrame f;
  f.source_width = mat.cols;
  f.source_height = mat.rows;
  int depth_bits = 0;
  switch (mat.depth()) {
    case CV_8U: depth_bits = 8; break;
    case CV_16U: depth_bits = 16; break;
    case CV_32F: depth_bits = 32; break;
    default:
      f.error = "unsupported sample type (OpenCV depth " + std::to_string(mat.depth()) +
                "); expected 8-bit, 16-bit or float";
      return f;
  }
  if (mat.channels() < 1 || mat.channels() > 4) {
    f.error = "unsupported channel count " + std::to_string(mat.channels());
    return f;
  }
  cv::Mat work = mat.isContinuous() ? mat : mat.clone();
  // Downscale before converting: a huge 16-bit image is never held twice at full size in 8 bits.
  const double factor = FitPixelBudget(&work, max_pixels);
  if (factor < 1.0) f.input_flags |= kInputDownscaled;
  f.source_scale = 1.0 / factor;
  f.image = ToRgb8(work.data, work.cols, work.rows, work.channels(), depth_bits, &f.input_flags);
  f.ok = true;
  return f;
}

class VideoSource : public FrameSource {
 public:
  VideoSource(const std::string& path, int64_t max_pixels) : max_pixels_(max_pixels) {
    files_.push_back(path);
    if (!fs::is_regular_file(path)) throw FileIOError(path + ": video file not found");
    if (!capture_.open(path, cv::CAP_FFMPEG)) {
      throw FileIOError(path + ": cannot open as a video (OpenCV's ffmpeg backend could not "
                               "read it; is it a video file?)");
    }
    fps_ = capture_.get(cv::CAP_PROP_FPS);
    if (!(fps_ > 0.0 && fps_ < 10000.0)) fps_ = 0.0;
    num_frames_ = static_cast<int64_t>(capture_.get(cv::CAP_PROP_FRAME_COUNT));
    if (num_frames_ <= 0) {
      // Some streams do not store a count: count by decoding once.
      num_frames_ = 0;
      while (capture_.grab()) ++num_frames_;
      capture_.release();
      capture_.open(path, cv::CAP_FFMPEG);
    }
    if (num_frames_ <= 0) throw FileIOError(path + ": the video holds no decodable frame");
  }

  int64_t NumFrames() const override { return num_frames_; }
  double Fps() const override { return fps_; }
  const std::vector<std::string>& Files() const override { return files_; }
  int32_t FileIdOf(int64_t) const override { return 0; }
  double TimecodeOf(int64_t index) const override { return fps_ > 0 ? index / fps_ : -1.0; }

  DecodedFrame Read(int64_t index) override {
    DecodedFrame f;
    if (index < 0 || index >= num_frames_) {
      f.error = "frame " + std::to_string(index) + " is outside the video";
      return f;
    }
    try {
      if (index != next_) {
        if (index > next_ && index - next_ <= kMaxGrabAhead) {
          while (next_ < index && capture_.grab()) ++next_;
        } else {
          capture_.set(cv::CAP_PROP_POS_FRAMES, static_cast<double>(index));
          next_ = index;
        }
      }
      cv::Mat bgr;
      const bool read = next_ == index && capture_.read(bgr);
      next_ = index + 1;
      if (!read || bgr.empty()) {
        next_ = -1;  // position unknown: seek next time
        f.error = "frame " + std::to_string(index) + " could not be decoded";
        return f;
      }
      return FromMat(bgr, max_pixels_);
    } catch (const cv::Exception& e) {
      next_ = -1;
      f.error = "frame " + std::to_string(index) + ": " + e.what();
      return f;
    }
  }

 private:
  static constexpr int64_t kMaxGrabAhead = 48;  // decode forward rather than seek
  cv::VideoCapture capture_;
  std::vector<std::string> files_;
  int64_t max_pixels_;
  int64_t num_frames_ = 0;
  int64_t next_ = 0;
  double fps_ = 0.0;
};

bool IsImageFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  static const char* kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff",
                                      ".webp", ".pgm", ".ppm", ".exr"};
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&](const char* e) { return ext == e; });
}

class ImageFolderSource : public FrameSource {
 public:
  ImageFolderSource(const std::string& folder, int64_t max_pixels) : max_pixels_(max_pixels) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) throw FileIOError(folder + ": image folder not found");
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
      if (entry.is_regular_file() && IsImageFile(entry.path())) files_.push_back(entry.path().string());
    }
    if (ec) throw FileIOError(folder + ": cannot list the folder: " + ec.message());
    std::sort(files_.begin(), files_.end());
    if (files_.empty()) {
      throw FileIOError(folder + ": no image files (png, jpg, jpeg, bmp, tif, tiff, webp, pgm, "
                                 "ppm, exr) in the folder");
    }
  }
  int64_t NumFrames() const override { return static_cast<int64_t>(files_.size()); }
  double Fps() const override { return 0.0; }
  const std::vector<std::string>& Files() const override { return files_; }
  int32_t FileIdOf(int64_t index) const override { return static_cast<int32_t>(index); }
  double TimecodeOf(int64_t) const override { return -1.0; }
  DecodedFrame Read(int64_t index) override {
    if (index < 0 || index >= NumFrames()) {
      DecodedFrame f;
      f.error = "image " + std::to_string(index) + " is outside the folder";
      return f;
    }
    return ReadImageFile(files_[index], max_pixels_);
  }

 private:
  std::vector<std::string> files_;
  int64_t max_pixels_;
};

}  // namespace

std::unique_ptr<FrameSource> FrameSource::OpenVideo(const std::string& path, int64_t max_pixels) {
  return std::make_unique<VideoSource>(path, max_pixels);
}

std::unique_ptr<FrameSource> FrameSource::OpenImages(const std::string& folder, int64_t max_pixels) {
  return std::make_unique<ImageFolderSource>(folder, max_pixels);
}

Image8 ToRgb8(const void* data, int width, int height, int channels, int depth_bits,
              int32_t* input_flags) {
  int type = 0;
  switch (depth_bits) {
    case 8: type = CV_8UC(channels); break;
    case 16: type = CV_16UC(channels); *input_flags |= kInputFrom16Bit; break;
    case 32: type = CV_32FC(channels); *input_flags |= kInputFromFloat; break;
    default: throw InvalidInputError("ToRgb8: depth must be 8, 16 or 32 bits");
  }
  cv::Mat src(height, width, type, const_cast<void*>(data));
  cv::Mat eight;
  if (depth_bits == 8) {
    eight = src;
  } else if (depth_bits == 16) {
    src.convertTo(eight, CV_8U, 1.0 / 257.0);
  } else {
    src.convertTo(eight, CV_8U, 255.0);  // saturating: clamps to [0, 255]
  }
  Image8 out(width, height, 3);
  cv::Mat rgb(height, width, CV_8UC3, out.data.data());
  switch (channels) {
    case 1: cv::cvtColor(eight, rgb, cv::COLOR_GRAY2RGB); *input_flags |= kInputFromGrayscale; break;
    case 2: {
      cv::Mat gray;
      cv::extractChannel(eight, gray, 0);
      cv::cvtColor(gray, rgb, cv::COLOR_GRAY2RGB);
      *input_flags |= kInputFromGrayscale | kInputDroppedAlpha;
      break;
    }
    case 3: cv::cvtColor(eight, rgb, cv::COLOR_BGR2RGB); break;
    case 4: cv::cvtColor(eight, rgb, cv::COLOR_BGRA2RGB); *input_flags |= kInputDroppedAlpha; break;
    default: throw InvalidInputError("ToRgb8: channels must be 1-4");
  }
  return out;
}

DecodedFrame ReadImageFile(const std::string& path, int64_t max_pixels) {
  DecodedFrame f;
  try {
    const cv::Mat mat = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (mat.empty()) {
      f.error = path + ": cannot decode the image (unsupported, truncated or too large for "
                       "the decoder)";
      return f;
    }
    f = FromMat(mat, max_pixels);
    if (!f.ok) f.error = path + ": " + f.error;
  } catch (const cv::Exception& e) {
    f = DecodedFrame();
    f.error = path + ": " + e.what();
  } catch (const std::bad_alloc&) {
    f = DecodedFrame();
    f.error = path + ": out of memory decoding the image";
  }
  return f;
}

void WriteVideo(const std::string& path, const std::vector<Image8>& frames, double fps) {
  if (frames.empty()) throw OutputError(path + ": no frames to write");
  const int w = frames[0].width, h = frames[0].height;
  cv::VideoWriter writer(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps,
                         cv::Size(w, h), true);
  if (!writer.isOpened()) throw OutputError(path + ": cannot open a Motion-JPEG video writer");
  cv::Mat bgr;
  for (const Image8& f : frames) {
    if (f.width != w || f.height != h || f.channels != 3) {
      throw OutputError(path + ": frames must be RGB and of equal size");
    }
    cv::Mat rgb(h, w, CV_8UC3, const_cast<uint8_t*>(f.data.data()));
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    writer.write(bgr);
  }
  writer.release();
}

std::vector<Image8> CameraMoveClip(const Image8& photo, int width, int height, int num_frames) {
  if (photo.channels != 3 || photo.empty()) throw InvalidInputError("CameraMoveClip: needs an RGB photo");
  cv::Mat src(photo.height, photo.width, CV_8UC3, const_cast<uint8_t*>(photo.data.data()));
  std::vector<Image8> frames;
  for (int i = 0; i < num_frames; ++i) {
    const double t = num_frames > 1 ? static_cast<double>(i) / (num_frames - 1) : 0.0;
    // The photo's height fills 80-95% of the frame; it drifts left-right and slightly rotates.
    const double scale = (0.80 + 0.15 * std::sin(M_PI * t)) * height / photo.height;
    const double angle = 6.0 * std::sin(2.0 * M_PI * t);  // degrees
    const cv::Point2f centre(static_cast<float>(width * (0.5 + 0.15 * std::sin(2.0 * M_PI * t))),
                             static_cast<float>(height * 0.5));
    cv::Mat m = cv::getRotationMatrix2D(cv::Point2f(photo.width * 0.5f, photo.height * 0.5f),
                                        angle, scale);
    m.at<double>(0, 2) += centre.x - photo.width * 0.5;
    m.at<double>(1, 2) += centre.y - photo.height * 0.5;
    Image8 frame(width, height, 3);
    cv::Mat dst(height, width, CV_8UC3, frame.data.data());
    cv::warpAffine(src, dst, m, dst.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                   cv::Scalar(96, 104, 112));
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace facecap::face
