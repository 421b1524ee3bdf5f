// Face detection and 68 landmarks on a real photo that ships in a Debian package: the
// portrait of Grace Hopper in python-matplotlib-data (datasets/README.md, "Real test media").
#include "face/face_analyzer.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "face/align.h"
#include "face/frame_source.h"
#include "util/errors.h"

namespace facecap::face {
namespace {

constexpr const char* kRealPhoto = "/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg";

Image8 LoadRealPhoto() {
  if (!std::filesystem::exists(kRealPhoto)) {
    ADD_FAILURE() << kRealPhoto << " is missing: install Debian's python-matplotlib-data "
                  << "(./setup.sh does)";
    return {};
  }
  DecodedFrame f = ReadImageFile(kRealPhoto, 0);
  EXPECT_TRUE(f.ok) << f.error;
  return f.image;
}

// One analyzer for the whole binary: the model takes about a second to load.
FaceAnalyzer& Analyzer() {
  static FaceAnalyzer analyzer;
  return analyzer;
}

// Checks that 68 landmarks have the layout of a face: brows above eyes above the nose tip
// above the mouth above the chin, the subject's right eye on the image's left, all in `box`
// grown by half its size.
void ExpectPlausibleFace(const Landmarks& l, const FaceBox& box) {
  const auto mean_y = [&](int a, int b) { return l.middleRows(a, b - a + 1).col(1).mean(); };
  const auto mean_x = [&](int a, int b) { return l.middleRows(a, b - a + 1).col(0).mean(); };
  EXPECT_LT(mean_y(17, 26), mean_y(36, 47));  // brows above eyes
  EXPECT_LT(mean_y(36, 47), l(30, 1));        // eyes above nose tip
  EXPECT_LT(l(30, 1), mean_y(48, 67));        // nose above mouth
  EXPECT_LT(mean_y(48, 67), l(8, 1));         // mouth above chin
  EXPECT_LT(mean_x(36, 41), mean_x(42, 47));  // right eye on the image's left
  EXPECT_LT(l(48, 0), l(54, 0));              // mouth corners in order
  const float eye_distance = (l.row(45) - l.row(36)).norm();
  EXPECT_GT(eye_distance, 0.3f * box.width);
  EXPECT_LT(eye_distance, 0.9f * box.width);
  for (int i = 0; i < kNumLandmarks; ++i) {
    EXPECT_GT(l(i, 0), box.x - 0.5f * box.width) << "landmark " << i;
    EXPECT_LT(l(i, 0), box.x + 1.5f * box.width) << "landmark " << i;
    EXPECT_GT(l(i, 1), box.y - 0.5f * box.height) << "landmark " << i;
    EXPECT_LT(l(i, 1), box.y + 1.5f * box.height) << "landmark " << i;
  }
}

TEST(FaceAnalyzerTest, FindsTheFaceAndPlausibleLandmarksInARealPhoto) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  const std::vector<FaceBox> faces = Analyzer().Detect(photo);
  ASSERT_EQ(faces.size(), 1u);
  const FaceBox& box = faces[0];
  // The portrait's face is large and central.
  EXPECT_GT(box.width, 0.25f * photo.width);
  EXPECT_GT(box.CenterX(), 0.3f * photo.width);
  EXPECT_LT(box.CenterX(), 0.7f * photo.width);
  const Landmarks l = Analyzer().FitLandmarks(photo, box);
  ExpectPlausibleFace(l, box);

  // The aligned crop puts the crop-alignment landmarks near the template.
  CropOptions crop_options;
  const AlignedCrop crop = AlignFace(photo, l, crop_options);
  ASSERT_EQ(crop.image.width, crop_options.size);
  const auto tmpl = CropTemplate(crop_options);
  double error = 0.0;
  for (int i : CropAlignmentLandmarks()) {
    error += (crop.landmarks.row(i).cast<double>() - tmpl.row(i)).norm();
  }
  error /= CropAlignmentLandmarks().size();
  EXPECT_LT(error, 0.05 * crop_options.size);
}

TEST(FaceAnalyzerTest, GrayscaleCopyOfTheRealPhotoGivesTheSameFace) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  Image8 gray(photo.width, photo.height, 1);
  for (int y = 0; y < photo.height; ++y)
    for (int x = 0; x < photo.width; ++x) {
      const uint8_t* p = photo.pixel(x, y);
      gray.at(x, y) = static_cast<uint8_t>((p[0] * 77 + p[1] * 150 + p[2] * 29) >> 8);
    }
  const std::vector<FaceBox> a = Analyzer().Detect(photo);
  const std::vector<FaceBox> b = Analyzer().Detect(gray);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_GT(IntersectionOverUnion(a[0], b[0]), 0.9f);
}

TEST(FaceAnalyzerTest, FindsTheFaceInEveryFrameOfACameraMoveOverTheRealPhoto) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  const std::vector<Image8> frames = CameraMoveClip(photo, 640, 480, 12);
  FaceAnalyzer& analyzer = Analyzer();
  const auto start = std::chrono::steady_clock::now();
  int found = 0;
  for (const Image8& f : frames) {
    const std::vector<FaceBox> faces = analyzer.Detect(f);
    if (faces.empty()) continue;
    ++found;
    ExpectPlausibleFace(analyzer.FitLandmarks(f, faces[0]), faces[0]);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(found, static_cast<int>(frames.size()));
  std::printf("detect + landmarks at 640x480: %.1f ms per frame\n", 1000.0 * seconds / frames.size());
}

TEST(FaceAnalyzerTest, UpsampledFitsPlaceLandmarksBetweenPixelsOfASmallImage) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  const std::vector<FaceBox> faces = Analyzer().Detect(photo);
  ASSERT_EQ(faces.size(), 1u);
  const Landmarks reference = Analyzer().FitLandmarks(photo, faces[0]);
  // The photo box-filtered to 1/k of its size, the box and the landmarks scaled with it
  // (pixel centres at integers: x_small = (x + 0.5) / k - 0.5).
  constexpr int k = 6;
  Image8 small(photo.width / k, photo.height / k, 3);
  for (int y = 0; y < small.height; ++y)
    for (int x = 0; x < small.width; ++x)
      for (int c = 0; c < 3; ++c) {
        int sum = 0;
        for (int v = 0; v < k; ++v)
          for (int u = 0; u < k; ++u) sum += photo.at(k * x + u, k * y + v, c);
        small.at(x, y, c) = static_cast<uint8_t>(sum / (k * k));
      }
  FaceBox box = faces[0];
  box.x = (box.x + 0.5f) / k - 0.5f;
  box.y = (box.y + 0.5f) / k - 0.5f;
  box.width /= k;
  box.height /= k;
  const Landmarks expected = ((reference.array() + 0.5f) / k - 0.5f).matrix();
  const Landmarks whole = Analyzer().FitLandmarks(small, box);
  const Landmarks fine = Analyzer().FitLandmarks(small, box, 4);
  ExpectPlausibleFace(fine, box);
  int between = 0;
  for (int i = 0; i < kNumLandmarks; ++i) between += std::abs(fine(i, 0) - std::round(fine(i, 0))) > 0.1f;
  EXPECT_GT(between, kNumLandmarks / 4);
  const double whole_error = (whole - expected).rowwise().norm().mean();
  const double fine_error = (fine - expected).rowwise().norm().mean();
  EXPECT_LT(fine_error, 1.5) << "small-image pixels";
  std::printf("landmarks on a 1/%d image: %.2f px from the full-size fit on whole pixels, %.2f px upsampled 4x\n",
              k, whole_error, fine_error);
  EXPECT_THROW(Analyzer().FitLandmarks(small, box, 0), InvalidInputError);
}

TEST(FaceAnalyzerTest, NoFaceInAFlatImage) {
  Image8 flat(320, 240, 3, 128);
  EXPECT_TRUE(Analyzer().Detect(flat).empty());
}

TEST(FaceAnalyzerTest, MissingModelIsAClearInputError) {
  FaceAnalyzerOptions options;
  options.landmark_model = "/nonexistent/model.dat";
  try {
    FaceAnalyzer analyzer(options);
    FAIL() << "expected FileIOError";
  } catch (const FileIOError& e) {
    EXPECT_NE(std::string(e.what()).find("libdlib-data"), std::string::npos) << e.what();
  }
}

TEST(FaceAnalyzerTest, TinyFacesAreNotDetectedAtTheDefaultScale) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  // The portrait shrunk to 48 pixels wide inside a 640x480 frame: below the detector window.
  const std::vector<Image8> tiny = CameraMoveClip(photo, 640, 480, 1);
  Image8 small(640, 480, 3, 100);
  for (int y = 0; y < 56; ++y)
    for (int x = 0; x < 48; ++x)
      for (int c = 0; c < 3; ++c)
        small.at(300 + x, 200 + y, c) = photo.at(x * photo.width / 48, y * photo.height / 56, c);
  EXPECT_TRUE(Analyzer().Detect(small).empty());
  EXPECT_FALSE(Analyzer().Detect(tiny[0]).empty());
}

TEST(FaceAnalyzerTest, SmallFaceSearchFindsFacesBelowTheFirstScale) {
  const Image8 photo = LoadRealPhoto();
  ASSERT_FALSE(photo.empty());
  // The portrait 120 pixels wide (a face of about 50) in a 640x480 frame: the first search
  // (detect_max_side 480) sees faces of about 107 pixels and more.
  Image8 frame(640, 480, 3, 110);
  for (int y = 0; y < 140; ++y)
    for (int x = 0; x < 120; ++x)
      for (int c = 0; c < 3; ++c)
        frame.at(300 + x, 200 + y, c) = photo.at(x * photo.width / 120, y * photo.height / 140, c);
  EXPECT_TRUE(Analyzer().Detect(frame).empty());
  FaceAnalyzerOptions options;
  options.small_face_size = 32;
  FaceAnalyzer small(options);
  EXPECT_NEAR(small.SmallestFace(640, 480), 80.0 * 640 / 480, 0.5);
  EXPECT_NEAR(small.SmallestFaceWithSearch(640, 480), 40.0, 0.5);  // 2x: 1280, the side limit
  const std::vector<FaceBox> faces = small.Detect(frame);
  ASSERT_EQ(faces.size(), 1u);
  EXPECT_GT(faces[0].width, 30.f);
  EXPECT_LT(faces[0].width, 70.f);
  EXPECT_GT(faces[0].CenterX(), 300.f);
  EXPECT_LT(faces[0].CenterX(), 420.f);
  // A frame where the first search finds the face is not searched again: same boxes.
  const std::vector<Image8> big = CameraMoveClip(photo, 640, 480, 1);
  const std::vector<FaceBox> a = Analyzer().Detect(big[0]), b = small.Detect(big[0]);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].width, b[i].width);
}

}  // namespace
}  // namespace facecap::face
