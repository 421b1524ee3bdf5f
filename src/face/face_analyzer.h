// Face detection and 68 landmarks with dlib: the HOG frontal face detector
// (dlib::get_frontal_face_detector) and the 68-point shape predictor of Debian's
// libdlib-data. dlib stays inside face_analyzer.cpp.
#ifndef FACECAP_FACE_FACE_ANALYZER_H_
#define FACECAP_FACE_FACE_ANALYZER_H_

#include <memory>
#include <string>
#include <vector>

#include "face/landmarks68.h"
#include "util/image.h"

namespace facecap::face {

// The path Debian's libdlib-data installs the 68-point model to.
constexpr const char* kDefaultLandmarkModel = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";

struct FaceAnalyzerOptions {
  // dlib 68-point shape predictor model file.
  std::string landmark_model = kDefaultLandmarkModel;
  // Detection runs on a copy scaled down so its longer side is at most this many pixels
  // (0: full resolution). The HOG detector's window is 80x80 pixels, so the smallest face
  // found is about 80 * source_side / detect_max_side pixels; landmarks always use the
  // full-resolution image.
  int detect_max_side = 480;
  // Times the detection image is doubled (dlib pyramid_up) before detection: finds faces
  // half as large per step, at about 4x the cost.
  int detect_upsample = 0;
  // Added to the detector's threshold: > 0 keeps only confident faces, < 0 finds more.
  double detect_threshold = 0.0;
  // Small faces: when an image gives no face at the detection scale above and that scale
  // cannot find faces as narrow as small_face_size source pixels, it is searched once more at
  // the scale that can (upsampled where needed), with the detection image's longer side at
  // most small_face_max_side. 0 (either): no second search.
  int small_face_size = 0;
  int small_face_max_side = 1280;

  bool Check(std::string* why) const;
};

// A face box in source pixels: top-left corner, size, and the detector's score.
struct FaceBox {
  float x = 0.f;
  float y = 0.f;
  float width = 0.f;
  float height = 0.f;
  float score = 0.f;

  float Area() const { return width * height; }
  float CenterX() const { return x + 0.5f * width; }
  float CenterY() const { return y + 0.5f * height; }
};

// Intersection over union of two boxes (0 when either is empty).
float IntersectionOverUnion(const FaceBox& a, const FaceBox& b);

// One analyzer per thread: Detect is not thread-safe (the detector keeps scratch state);
// Clone() gives another analyzer that shares the loaded landmark model.
class FaceAnalyzer {
 public:
  // Loads the landmark model; FileIOError naming the file (and the Debian package that ships
  // it) when it is missing or not a dlib shape predictor.
  explicit FaceAnalyzer(const FaceAnalyzerOptions& options = FaceAnalyzerOptions());
  ~FaceAnalyzer();
  FaceAnalyzer(FaceAnalyzer&&) noexcept;
  FaceAnalyzer& operator=(FaceAnalyzer&&) noexcept;
  std::unique_ptr<FaceAnalyzer> Clone() const;

  // Faces in `image` (8-bit, 1 or 3 channels), in source pixels, largest first.
  std::vector<FaceBox> Detect(const Image8& image);
  // About the narrowest face (pixels) Detect finds in a width x height image: at the first
  // scale, and with the small-face search (equal when there is none).
  double SmallestFace(int width, int height) const;
  double SmallestFaceWithSearch(int width, int height) const;
  // The 68 landmarks (iBUG order, source pixels) of the face in `box`. dlib places them on
  // whole pixels; upsample > 1 fits them on a copy enlarged that many times (bilinear), which
  // gives positions in steps of 1 / upsample source pixels (for small images).
  Landmarks FitLandmarks(const Image8& image, const FaceBox& box, int upsample = 1) const;

  const FaceAnalyzerOptions& options() const;

 private:
  struct Impl;
  explicit FaceAnalyzer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::face

#endif  // FACECAP_FACE_FACE_ANALYZER_H_
