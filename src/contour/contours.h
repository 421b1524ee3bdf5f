// Region borders of segmentation images as polylines (paper 000 Sec. 4.1): the boundaries
// between the rig's regions (eyelids, inner and outer lips, brows, nose, jaw line, ...) drawn
// on D_S(E(I_R)) are the curves tracked on the real frame I_R.
//
// Pixels are first classified to the nearest region colour (the palette of the rig's
// /regions/colors plus black for the background), then each region's outline is traced and
// cut into runs by the region across the border, so every polyline separates exactly two
// labels. OpenCV stays in contours.cpp.
#ifndef FACECAP_CONTOUR_CONTOURS_H_
#define FACECAP_CONTOUR_CONTOURS_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "util/image.h"

namespace facecap::contour {

// Region names and flat colours (RGB in [0, 1]); label names.size() is the background (black).
struct Palette {
  std::vector<std::string> names;
  std::vector<std::array<float, 3>> colors;
  int background() const { return static_cast<int>(names.size()); }
  int num_labels() const { return static_cast<int>(names.size()) + 1; }
  std::string LabelName(int label) const {
    return label == background() ? "background" : names.at(label);
  }
};

// Per pixel, the label of the nearest palette colour (background: black). When a region's
// colour is black as well, black pixels go to the background.
std::vector<int16_t> ClassifyPixels(const Image8& image, const Palette& palette);

// One border: points (pixel centres, x right, y down) along the outline of `region` where the
// pixel across is `neighbor` (region < neighbor; the background is the largest label).
struct Border {
  int region = 0;
  int neighbor = 0;
  bool closed = false;  // the whole outline of `region` borders `neighbor`
  std::vector<std::array<float, 2>> points;
};

struct BorderOptions {
  int min_points = 3;  // shorter runs are dropped
};

std::vector<Border> ExtractBorders(const std::vector<int16_t>& labels, int width, int height,
                                   int num_labels, const BorderOptions& options = {});

// The frame scaled by `scale` (nearest) with the borders drawn in the colour of their
// neighbour region (the region colour when the neighbour is the background).
Image8 DrawBorders(const Image8& frame, const std::vector<Border>& borders, const Palette& palette,
                   int scale);

// Intersection and union pixel counts per label of two label images, accumulated.
struct IouCounts {
  std::vector<int64_t> intersection, union_;
  void Resize(int num_labels) { intersection.assign(num_labels, 0); union_.assign(num_labels, 0); }
  void Add(const std::vector<int16_t>& predicted, const std::vector<int16_t>& truth);
  // IoU of a label; -1 when the label is in neither image.
  double Iou(int label) const;
};

}  // namespace facecap::contour

#endif  // FACECAP_CONTOUR_CONTOURS_H_
