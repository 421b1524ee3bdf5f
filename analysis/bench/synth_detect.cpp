// Does a wild clip look like a face to a face detector? Runs dlib's HOG frontal face detector
// (face::FaceAnalyzer) on every wild frame of a clip made by `facecap synth clip` and prints
// the fraction of frames where it finds the face, overall and per |yaw| bucket of the true
// pose. A detection counts when its box centre lies inside the box of the frame's true
// visible landmarks (a box elsewhere is a false alarm, counted apart).
//
//   facecap_bench_synth_detect --clip clip.h5 [--upsample 1] [--threshold 0]
//
// The last line is one JSON object with the figures.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "face/face_analyzer.h"
#include "io/hdf5.h"

namespace {

constexpr int kNumLandmarks = 68;
constexpr double kRadToDeg = 180.0 / M_PI;
// |yaw| bucket edges in degrees.
const double kBucketEdges[] = {0, 15, 30, 45, 60, 90.0001};
constexpr int kNumBuckets = 5;

int Main(int argc, char** argv) {
  std::string clip;
  int upsample = 1;
  double threshold = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--clip" && i + 1 < argc) clip = argv[++i];
    else if (a == "--upsample" && i + 1 < argc) upsample = std::atoi(argv[++i]);
    else if (a == "--threshold" && i + 1 < argc) threshold = std::atof(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s --clip clip.h5 [--upsample N] [--threshold T]\n", argv[0]);
      return 2;
    }
  }
  if (clip.empty()) {
    std::fprintf(stderr, "--clip is required\n");
    return 2;
  }
  using namespace facecap;
  io::H5File f = io::H5File::OpenRead(clip);
  const io::Shape shape = f.DatasetShape("/frames/image");
  const int64_t num_frames = shape[0];
  const int H = static_cast<int>(shape[1]), W = static_cast<int>(shape[2]);
  const std::vector<float> pose = f.Read<float>("/frames/pose", {num_frames, 3});
  const std::vector<float> landmarks = f.Read<float>("/frames/landmarks", {num_frames, kNumLandmarks, 2});
  const std::vector<uint8_t> visible = f.Read<uint8_t>("/frames/landmark_visible", {num_frames, kNumLandmarks});

  face::FaceAnalyzerOptions options;
  options.detect_max_side = 0;
  options.detect_upsample = upsample;
  options.detect_threshold = threshold;
  face::FaceAnalyzer analyzer(options);

  int64_t found = 0, any_box = 0;
  int64_t bucket_total[kNumBuckets] = {}, bucket_found[kNumBuckets] = {};
  Image8 image(W, H, 3);
  for (int64_t i = 0; i < num_frames; ++i) {
    f.ReadFrames<uint8_t>("/frames/image", i, 1, image.data.data());
    const std::vector<face::FaceBox> boxes = analyzer.Detect(image);
    float x0 = 1e9f, y0 = 1e9f, x1 = -1e9f, y1 = -1e9f;
    for (int l = 0; l < kNumLandmarks; ++l) {
      if (!visible[i * kNumLandmarks + l]) continue;
      const float x = landmarks[(i * kNumLandmarks + l) * 2], y = landmarks[(i * kNumLandmarks + l) * 2 + 1];
      x0 = std::min(x0, x); x1 = std::max(x1, x);
      y0 = std::min(y0, y); y1 = std::max(y1, y);
    }
    bool hit = false;
    for (const face::FaceBox& b : boxes) {
      hit = hit || (b.CenterX() >= x0 && b.CenterX() <= x1 && b.CenterY() >= y0 && b.CenterY() <= y1);
    }
    any_box += boxes.empty() ? 0 : 1;
    found += hit ? 1 : 0;
    const double yaw = std::abs(pose[i * 3 + 1]) * kRadToDeg;
    for (int b = 0; b < kNumBuckets; ++b) {
      if (yaw >= kBucketEdges[b] && yaw < kBucketEdges[b + 1]) {
        ++bucket_total[b];
        bucket_found[b] += hit ? 1 : 0;
      }
    }
  }
  std::printf("clip %s: %lld frames of %dx%d, dlib HOG frontal detector (upsample %d)\n",
              clip.c_str(), static_cast<long long>(num_frames), W, H, upsample);
  std::printf("faces found on %lld of %lld frames: %.1f%% (frames with any box: %.1f%%)\n",
              static_cast<long long>(found), static_cast<long long>(num_frames),
              100.0 * found / std::max<int64_t>(1, num_frames),
              100.0 * any_box / std::max<int64_t>(1, num_frames));
  std::printf("%-14s %8s %8s %8s\n", "|yaw| (deg)", "frames", "found", "rate");
  std::string buckets_json;
  for (int b = 0; b < kNumBuckets; ++b) {
    char label[32];
    std::snprintf(label, sizeof(label), "[%.0f, %.0f)", kBucketEdges[b], std::floor(kBucketEdges[b + 1]));
    const double rate = bucket_total[b] ? static_cast<double>(bucket_found[b]) / bucket_total[b] : 0.0;
    std::printf("%-14s %8lld %8lld %7.1f%%\n", label, static_cast<long long>(bucket_total[b]),
                static_cast<long long>(bucket_found[b]), 100.0 * rate);
    char entry[160];
    std::snprintf(entry, sizeof(entry), "%s{\"yaw_deg\": [%.0f, %.0f], \"frames\": %lld, \"found\": %lld}",
                  b ? ", " : "", kBucketEdges[b], std::floor(kBucketEdges[b + 1]),
                  static_cast<long long>(bucket_total[b]), static_cast<long long>(bucket_found[b]));
    buckets_json += entry;
  }
  std::printf("{\"frames\": %lld, \"found\": %lld, \"rate\": %.4f, \"by_yaw\": [%s]}\n",
              static_cast<long long>(num_frames), static_cast<long long>(found),
              static_cast<double>(found) / std::max<int64_t>(1, num_frames), buckets_json.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
