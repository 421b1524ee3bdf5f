#include "render/contact_sheet.h"

#include <gtest/gtest.h>

#include "util/errors.h"

namespace facecap::render {
namespace {

Image8 Tile(int index) {
  Image8 tile(5, 4, 3);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 5; ++x) {
      tile.at(x, y, 0) = static_cast<uint8_t>(index);
      tile.at(x, y, 1) = static_cast<uint8_t>(x);
      tile.at(x, y, 2) = static_cast<uint8_t>(y);
    }
  }
  return tile;
}

TEST(ContactSheetTest, TilesRowByRowWithBorders) {
  std::vector<Image8> tiles;
  for (int i = 0; i < 5; ++i) tiles.push_back(Tile(10 + i));
  ContactSheetOptions options;
  options.border = 2;
  options.border_value = {200, 100, 50, 0};
  const Image8 sheet = ContactSheet(tiles, options);  // ceil(sqrt(5)) = 3 columns, 2 rows
  EXPECT_EQ(sheet.width, 3 * 5 + 4 * 2);
  EXPECT_EQ(sheet.height, 2 * 4 + 3 * 2);
  EXPECT_EQ(sheet.channels, 3);
  for (int i = 0; i < 5; ++i) {
    const int left = 2 + (i % 3) * 7, top = 2 + (i / 3) * 6;
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 5; ++x) {
        ASSERT_EQ(sheet.at(left + x, top + y, 0), 10 + i);
        ASSERT_EQ(sheet.at(left + x, top + y, 1), x);
        ASSERT_EQ(sheet.at(left + x, top + y, 2), y);
      }
    }
  }
  EXPECT_EQ(sheet.at(0, 0, 0), 200);
  EXPECT_EQ(sheet.at(1, 5, 1), 100);
  EXPECT_EQ(sheet.at(7, 1, 2), 50);
  EXPECT_EQ(sheet.at(sheet.width - 1, sheet.height - 1, 0), 200);
  // The empty sixth cell.
  EXPECT_EQ(sheet.at(2 + 2 * 7 + 1, 2 + 6 + 1, 0), options.empty_value);
}

TEST(ContactSheetTest, FixedColumnsNoBorderAndErrors) {
  std::vector<Image8> tiles = {Tile(1), Tile(2), Tile(3)};
  ContactSheetOptions options;
  options.columns = 1;
  options.border = 0;
  const Image8 sheet = ContactSheet(tiles, options);
  EXPECT_EQ(sheet.width, 5);
  EXPECT_EQ(sheet.height, 12);
  EXPECT_EQ(sheet.at(0, 8, 0), 3);

  EXPECT_THROW(ContactSheet({}), InvalidInputError);
  tiles.push_back(Image8(4, 4, 3));
  EXPECT_THROW(ContactSheet(tiles), InvalidInputError);
  options.border = -1;
  EXPECT_THROW(ContactSheet({Tile(0)}, options), InvalidInputError);
}

}  // namespace
}  // namespace facecap::render
