#include "face/face_analyzer.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>
#include <dlib/image_transforms.h>
#include <dlib/opencv.h>
#include <opencv2/imgproc.hpp>

#include "util/errors.h"

namespace facecap::face {

bool FaceAnalyzerOptions::Check(std::string* why) const {
  if (landmark_model.empty()) {
    *why = "landmark_model must name a dlib 68-point shape predictor file";
    return false;
  }
  if (detect_max_side != 0 && detect_max_side < 80) {
    *why = "detect_max_side must be 0 (full resolution) or >= 80 (the detector window)";
    return false;
  }
  if (detect_upsample < 0 || detect_upsample > 2) {
    *why = "detect_upsample must be in [0, 2]";
    return false;
  }
  if (!(std::abs(detect_threshold) <= 5.0)) {
    *why = "detect_threshold must be in [-5, 5]";
    return false;
  }
  if (small_face_size < 0) {
    *why = "small_face_size must be >= 0";
    return false;
  }
  if (small_face_max_side != 0 && small_face_max_side < 80) {
    *why = "small_face_max_side must be 0 (no small-face search) or >= 80 (the detector window)";
    return false;
  }
  return true;
}

float IntersectionOverUnion(const FaceBox& a, const FaceBox& b) {
  const float x0 = std::max(a.x, b.x), y0 = std::max(a.y, b.y);
  const float x1 = std::min(a.x + a.width, b.x + b.width);
  const float y1 = std::min(a.y + a.height, b.y + b.height);
  const float inter = std::max(0.f, x1 - x0) * std::max(0.f, y1 - y0);
  const float uni = a.Area() + b.Area() - inter;
  return uni > 0.f ? inter / uni : 0.f;
}

namespace {

// A grayscale cv::Mat of an 8-bit image with 1, 3 or 4 channels (RGB order).
cv::Mat ToGray(const Image8& image) {
  if (image.empty() || image.width <= 0 || image.height <= 0) {
    throw InvalidInputError("face analyzer: empty image");
  }
  const int type = CV_8UC(image.channels);
  cv::Mat view(image.height, image.width, type, const_cast<uint8_t*>(image.data.data()));
  cv::Mat gray;
  switch (image.channels) {
    case 1: gray = view; break;
    case 3: cv::cvtColor(view, gray, cv::COLOR_RGB2GRAY); break;
    case 4: cv::cvtColor(view, gray, cv::COLOR_RGBA2GRAY); break;
    default:
      throw InvalidInputError("face analyzer: images need 1, 3 or 4 channels, got " +
                              std::to_string(image.channels));
  }
  return gray;
}

// The image the HOG detector reads: the RGB colours for a colour image (dlib's HOG takes each
// pixel's gradient in the channel where it is strongest, which a gray conversion weakens on
// turned heads), else the gray image.
cv::Mat ToDetectable(const Image8& image) {
  if (image.channels != 3 && image.channels != 4) return ToGray(image);
  if (image.width <= 0 || image.height <= 0) throw InvalidInputError("face analyzer: empty image");
  cv::Mat view(image.height, image.width, CV_8UC(image.channels),
               const_cast<uint8_t*>(image.data.data()));
  if (image.channels == 3) return view;
  cv::Mat rgb;
  cv::cvtColor(view, rgb, cv::COLOR_RGBA2RGB);
  return rgb;
}

// The detector on `work` (8-bit gray or RGB, as Pixel), after `upsample` pyramid_up doublings.
template <typename Pixel>
std::vector<dlib::rect_detection> RunDetector(dlib::frontal_face_detector& detector,
                                              const cv::Mat& work, int upsample, double threshold) {
  std::vector<dlib::rect_detection> detections;
  if (upsample == 0) {
    dlib::cv_image<Pixel> view(work);
    detector(view, detections, threshold);
  } else {
    dlib::array2d<Pixel> up;
    dlib::assign_image(up, dlib::cv_image<Pixel>(work));
    for (int i = 0; i < upsample; ++i) dlib::pyramid_up(up);
    detector(up, detections, threshold);
  }
  return detections;
}

}  // namespace

struct FaceAnalyzer::Impl {
  FaceAnalyzerOptions options;
  dlib::frontal_face_detector detector;  // copyable; building one decodes the HOG model
  std::shared_ptr<const dlib::shape_predictor> predictor;
};

FaceAnalyzer::FaceAnalyzer(const FaceAnalyzerOptions& options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("face analyzer: " + why);
  impl_->options = options;
  const std::string& path = options.landmark_model;
  if (!std::filesystem::is_regular_file(path)) {
    throw FileIOError(path + ": landmark model not found (Debian's libdlib-data installs " +
                      std::string(kDefaultLandmarkModel) + "; set landmark_model)");
  }
  auto predictor = std::make_shared<dlib::shape_predictor>();
  try {
    dlib::deserialize(path) >> *predictor;
  } catch (const std::exception& e) {
    throw FileIOError(path + ": not a dlib shape predictor: " + e.what());
  }
  if (predictor->num_parts() != kNumLandmarks) {
    throw FileIOError(path + ": the shape predictor gives " +
                      std::to_string(predictor->num_parts()) + " landmarks, expected 68");
  }
  impl_->predictor = std::move(predictor);
  impl_->detector = dlib::get_frontal_face_detector();
}

FaceAnalyzer::~FaceAnalyzer() = default;
FaceAnalyzer::FaceAnalyzer(FaceAnalyzer&&) noexcept = default;
FaceAnalyzer& FaceAnalyzer::operator=(FaceAnalyzer&&) noexcept = default;

FaceAnalyzer::FaceAnalyzer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

std::unique_ptr<FaceAnalyzer> FaceAnalyzer::Clone() const {
  auto impl = std::make_unique<Impl>();
  impl->options = impl_->options;
  impl->predictor = impl_->predictor;  // shared, read-only
  impl->detector = impl_->detector;
  return std::unique_ptr<FaceAnalyzer>(new FaceAnalyzer(std::move(impl)));
}

const FaceAnalyzerOptions& FaceAnalyzer::options() const { return impl_->options; }

namespace {

// dlib's frontal detector scans an 80 x 80 window over an image pyramid.
constexpr double kDetectorWindow = 80.0;

// Detection pixels per source pixel of the first search.
double FirstScale(const FaceAnalyzerOptions& o, int width, int height) {
  const int side = std::max(width, height);
  double scale = 1.0;
  if (o.detect_max_side > 0 && side > o.detect_max_side) scale = static_cast<double>(o.detect_max_side) / side;
  return scale * std::pow(2.0, o.detect_upsample);
}

// Detection pixels per source pixel of the small-face search (0: none).
double SmallFaceScale(const FaceAnalyzerOptions& o, int width, int height) {
  if (o.small_face_size <= 0 || o.small_face_max_side <= 0) return 0.0;
  const double first = FirstScale(o, width, height);
  if (kDetectorWindow / first <= o.small_face_size) return 0.0;  // the first search sees them
  const int side = std::max(width, height);
  const double scale = std::min(kDetectorWindow / o.small_face_size,
                                static_cast<double>(o.small_face_max_side) / side);
  return scale > 1.05 * first ? scale : 0.0;
}

}  // namespace

double FaceAnalyzer::SmallestFace(int width, int height) const {
  return kDetectorWindow / FirstScale(impl_->options, width, height);
}

double FaceAnalyzer::SmallestFaceWithSearch(int width, int height) const {
  const double scale = SmallFaceScale(impl_->options, width, height);
  return scale > 0.0 ? kDetectorWindow / scale : SmallestFace(width, height);
}

std::vector<FaceBox> FaceAnalyzer::Detect(const Image8& image) {
  const cv::Mat source = ToDetectable(image);
  const FaceAnalyzerOptions& o = impl_->options;
  const double threshold = o.detect_threshold;
  // Detection at `target` detection pixels per source pixel (then `upsample` pyramid_up
  // doublings): the image resized (area filter down, bilinear up), boxes in source pixels.
  auto detect_at = [&](double target, int upsample) {
    cv::Mat work = source;
    double scale = 1.0;
    if (std::abs(target - 1.0) > 1e-9) {
      cv::resize(source, work, cv::Size(), target, target, target < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
      scale = static_cast<double>(work.cols) / source.cols;
    }
    scale *= std::pow(2.0, upsample);
    const std::vector<dlib::rect_detection> detections =
        work.channels() == 3
            ? RunDetector<dlib::rgb_pixel>(impl_->detector, work, upsample, threshold)
            : RunDetector<unsigned char>(impl_->detector, work, upsample, threshold);
    std::vector<FaceBox> boxes;
    for (const dlib::rect_detection& d : detections) {
      FaceBox b;
      b.x = static_cast<float>(d.rect.left() / scale);
      b.y = static_cast<float>(d.rect.top() / scale);
      b.width = static_cast<float>(d.rect.width() / scale);
      b.height = static_cast<float>(d.rect.height() / scale);
      b.score = static_cast<float>(d.detection_confidence);
      boxes.push_back(b);
    }
    return boxes;
  };
  const double first = FirstScale(o, source.cols, source.rows) / std::pow(2.0, o.detect_upsample);
  std::vector<FaceBox> boxes = detect_at(std::min(1.0, first), o.detect_upsample);
  if (boxes.empty()) {
    const double small = SmallFaceScale(o, source.cols, source.rows);
    if (small > 0.0) boxes = detect_at(small, 0);
  }
  std::stable_sort(boxes.begin(), boxes.end(),
                   [](const FaceBox& a, const FaceBox& b) { return a.Area() > b.Area(); });
  return boxes;
}

Landmarks FaceAnalyzer::FitLandmarks(const Image8& image, const FaceBox& box, int upsample) const {
  if (upsample < 1 || upsample > 16) {
    throw InvalidInputError("face analyzer: landmark upsampling must be in [1, 16], got " + std::to_string(upsample));
  }
  cv::Mat gray = ToGray(image);
  if (upsample > 1) {
    cv::Mat large;
    cv::resize(gray, large, cv::Size(gray.cols * upsample, gray.rows * upsample), 0, 0, cv::INTER_LINEAR);
    gray = large;
  }
  // Pixel centres at integers in both images: x_large = k (x + 0.5) - 0.5.
  const float k = static_cast<float>(upsample);
  const auto up = [k](float x) { return k * (x + 0.5f) - 0.5f; };
  dlib::cv_image<unsigned char> view(gray);
  const dlib::rectangle rect(static_cast<long>(std::lround(up(box.x))),
                             static_cast<long>(std::lround(up(box.y))),
                             static_cast<long>(std::lround(up(box.x + box.width))) - 1,
                             static_cast<long>(std::lround(up(box.y + box.height))) - 1);
  const dlib::full_object_detection shape = (*impl_->predictor)(view, rect);
  Landmarks landmarks;
  for (int i = 0; i < kNumLandmarks; ++i) {
    landmarks(i, 0) = (static_cast<float>(shape.part(i).x()) + 0.5f) / k - 0.5f;
    landmarks(i, 1) = (static_cast<float>(shape.part(i).y()) + 0.5f) / k - 0.5f;
  }
  return landmarks;
}

}  // namespace facecap::face
