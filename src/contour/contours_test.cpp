// Region borders on a synthetic label image whose borders are known.
#include "contour/contours.h"

#include <gtest/gtest.h>

namespace facecap::contour {
namespace {

Palette TwoRegions() {
  Palette p;
  p.names = {"skin", "upper_lip"};
  p.colors = {{0.85f, 0.62f, 0.48f}, {0.95f, 0.08f, 0.08f}};
  return p;
}

// A skin square on black with a lip rectangle inside it, slightly off-colour (as a network
// output is).
Image8 Face() {
  Image8 image(32, 32, 3, 0);
  for (int y = 4; y < 28; ++y) {
    for (int x = 4; x < 28; ++x) {
      uint8_t* p = image.pixel(x, y);
      const bool lip = x >= 10 && x < 22 && y >= 18 && y < 22;
      p[0] = lip ? 236 : 212; p[1] = lip ? 30 : 160; p[2] = lip ? 25 : 118;
    }
  }
  return image;
}

TEST(Contours, ClassifiesToTheNearestColourAndTracesEachRegionPair) {
  const Palette palette = TwoRegions();
  const Image8 image = Face();
  const std::vector<int16_t> labels = ClassifyPixels(image, palette);
  EXPECT_EQ(labels[0], palette.background());
  EXPECT_EQ(labels[5 * 32 + 5], 0);
  EXPECT_EQ(labels[19 * 32 + 12], 1);
  const auto borders = ExtractBorders(labels, 32, 32, palette.num_labels());
  bool skin_lip = false, skin_background = false;
  for (const Border& b : borders) {
    EXPECT_LT(b.region, b.neighbor);
    if (b.region == 0 && b.neighbor == 1) {
      skin_lip = true;
      EXPECT_TRUE(b.closed);
      for (const auto& p : b.points) {  // on the skin side of the lip's outline
        EXPECT_GE(p[0], 9.f); EXPECT_LE(p[0], 23.f);
        EXPECT_GE(p[1], 17.f); EXPECT_LE(p[1], 23.f);
      }
    }
    if (b.region == 0 && b.neighbor == palette.background()) {
      skin_background = true;
      EXPECT_EQ(b.points.size(), 4u * 23u);  // the square's outline pixels
    }
  }
  EXPECT_TRUE(skin_lip);
  EXPECT_TRUE(skin_background);
  const Image8 overlay = DrawBorders(image, borders, palette, 2);
  EXPECT_EQ(overlay.width, 64);
  EXPECT_EQ(overlay.height, 64);
}

TEST(Contours, IouCountsPerLabel) {
  IouCounts counts;
  counts.Resize(3);
  counts.Add({0, 0, 1, 1}, {0, 1, 1, 1});
  EXPECT_DOUBLE_EQ(counts.Iou(0), 0.5);
  EXPECT_DOUBLE_EQ(counts.Iou(1), 2.0 / 3.0);
  EXPECT_EQ(counts.Iou(2), -1);
}

}  // namespace
}  // namespace facecap::contour
