// Per-region IoU of translated segmentations (deepfake infer's /frames/translated) against the
// true segmentation renders of the same frames (a wild clip's /frames/segmentation): both are
// classified to the nearest region colour of /regions/colors, and intersections and unions are
// summed over all frames.
//
//   facecap_bench_deepfake_iou --translated translated.h5 --truth clip.h5
//
// Prints one line per region and the means. The pupil is as black as the background, so it is
// counted with the background and left out of the mean over face regions.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "contour/contours.h"
#include "io/hdf5.h"
#include "util/errors.h"

using namespace facecap;

int main(int argc, char** argv) {
  std::string translated_path, truth_path, truth_dataset = "/frames/segmentation";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--translated") translated_path = argv[i + 1];
    else if (flag == "--truth") truth_path = argv[i + 1];
    else if (flag == "--truth-dataset") truth_dataset = argv[i + 1];
  }
  if (translated_path.empty() || truth_path.empty()) {
    std::fprintf(stderr, "usage: %s --translated T.h5 --truth CLIP.h5 [--truth-dataset NAME]\n", argv[0]);
    return 2;
  }
  try {
    io::H5File translated = io::H5File::OpenRead(translated_path);
    io::H5File truth = io::H5File::OpenRead(truth_path);
    const io::H5File& palette_file = translated.Exists("/regions/colors") ? translated : truth;
    contour::Palette palette;
    palette.names = palette_file.ReadStrings("/regions/names");
    const auto colors = palette_file.ReadMatrix<float>("/regions/colors", palette.names.size(), 3);
    for (int r = 0; r < colors.rows(); ++r) palette.colors.push_back({colors(r, 0), colors(r, 1), colors(r, 2)});
    const io::Shape ts = translated.CheckShape("/frames/translated", {-1, -1, -1, 3});
    const io::Shape gs = truth.CheckShape(truth_dataset, {ts[0], -1, -1, 3});
    const int size = static_cast<int>(ts[1]), truth_size = static_cast<int>(gs[1]);
    contour::IouCounts counts;
    counts.Resize(palette.num_labels());
    Image8 image(size, size, 3), truth_image(truth_size, truth_size, 3), truth_resized(size, size, 3);
    for (int64_t frame = 0; frame < ts[0]; ++frame) {
      translated.ReadFrames<uint8_t>("/frames/translated", frame, 1, image.data.data());
      truth.ReadFrames<uint8_t>(truth_dataset, frame, 1, truth_image.data.data());
      // Truth at the network's size: nearest sample (labels must not blend).
      for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
          const int sx = (2 * x + 1) * truth_size / (2 * size), sy = (2 * y + 1) * truth_size / (2 * size);
          std::memcpy(truth_resized.pixel(x, y), truth_image.pixel(sx, sy), 3);
        }
      }
      counts.Add(contour::ClassifyPixels(image, palette), contour::ClassifyPixels(truth_resized, palette));
    }
    double sum = 0;
    int n = 0;
    std::printf("# %lld frames, %dx%d, truth %s:%s\n", static_cast<long long>(ts[0]), size, size,
                truth_path.c_str(), truth_dataset.c_str());
    std::printf("%-22s %8s %10s\n", "region", "IoU", "pixels");
    for (int label = 0; label < palette.num_labels(); ++label) {
      const double iou = counts.Iou(label);
      const std::string name = palette.LabelName(label);
      if (iou < 0) {
        std::printf("%-22s %8s %10d\n", name.c_str(), "absent", 0);
        continue;
      }
      const bool black = label != palette.background() && palette.colors[label][0] == 0 &&
                         palette.colors[label][1] == 0 && palette.colors[label][2] == 0;
      std::printf("%-22s %8.3f %10lld%s\n", name.c_str(), iou,
                  static_cast<long long>(counts.union_[label]),
                  black ? "  (black as the background: not in the mean)" : "");
      if (label != palette.background() && !black) {
        sum += iou;
        ++n;
      }
    }
    const double mean = n ? sum / n : 0;
    std::printf("mean IoU over %d face regions: %.3f\n", n, mean);
    std::printf("mean IoU with the background:  %.3f\n",
                (sum + std::max(0.0, counts.Iou(palette.background()))) / (n + 1));
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return e.code();
  }
}
