// Contact sheets: many equally sized images tiled into one grid (`facecap render --sheet`).
#ifndef FACECAP_RENDER_CONTACT_SHEET_H_
#define FACECAP_RENDER_CONTACT_SHEET_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "util/image.h"

namespace facecap::render {

struct ContactSheetOptions {
  // Tiles per row; 0 picks ceil(sqrt(#tiles)) for a roughly square sheet.
  int columns = 0;
  // Border width in pixels around and between tiles; 0 packs the tiles edge to edge.
  int border = 1;
  // Border value per channel (white); channels beyond the fourth use the fourth value.
  std::array<uint8_t, 4> border_value{255, 255, 255, 255};
  // Value of grid cells left without a tile in the last row.
  uint8_t empty_value = 0;

  // False, with the reason in *why, when a field is out of range.
  bool Check(std::string* why) const;
};

// Tiles images of equal size and channel count row by row into a grid:
//   width  = columns * tile_width + (columns + 1) * border
//   height = rows * tile_height + (rows + 1) * border,  rows = ceil(#tiles / columns)
//
// Inputs:
//   tiles    images of equal width, height and channels (at least one)
//   options  columns, border
// Returns the sheet.
// Throws InvalidInputError when there are no tiles, their shapes differ, or options are bad.
Image8 ContactSheet(const std::vector<Image8>& tiles,
                    const ContactSheetOptions& options = ContactSheetOptions());

}  // namespace facecap::render

#endif  // FACECAP_RENDER_CONTACT_SHEET_H_
