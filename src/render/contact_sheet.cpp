#include "render/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include "util/errors.h"

namespace facecap::render {

bool ContactSheetOptions::Check(std::string* why) const {
  if (columns < 0) {
    if (why) *why = "columns must be >= 0 (0: automatic)";
    return false;
  }
  if (border < 0) {
    if (why) *why = "border must be >= 0";
    return false;
  }
  return true;
}

Image8 ContactSheet(const std::vector<Image8>& tiles, const ContactSheetOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("ContactSheet: " + why);
  if (tiles.empty()) throw InvalidInputError("ContactSheet: no images to tile");
  const int tile_width = tiles[0].width, tile_height = tiles[0].height;
  const int channels = tiles[0].channels;
  for (size_t i = 0; i < tiles.size(); ++i) {
    const Image8& tile = tiles[i];
    if (tile.width != tile_width || tile.height != tile_height || tile.channels != channels ||
        tile.data.size() != static_cast<size_t>(tile_width) * tile_height * channels) {
      std::ostringstream message;
      message << "ContactSheet: image " << i << " is " << tile.width << "x" << tile.height
              << "x" << tile.channels << ", image 0 is " << tile_width << "x" << tile_height
              << "x" << channels;
      throw InvalidInputError(message.str());
    }
  }
  const int num_tiles = static_cast<int>(tiles.size());
  const int columns =
      options.columns > 0
          ? std::min(options.columns, num_tiles)
          : static_cast<int>(std::ceil(std::sqrt(static_cast<double>(num_tiles))));
  const int rows = (num_tiles + columns - 1) / columns;
  const int border = options.border;
  Image8 sheet(columns * tile_width + (columns + 1) * border,
               rows * tile_height + (rows + 1) * border, channels, options.empty_value);

  // Borders: paint every pixel outside the tile cells.
  auto border_channel = [&](int c) {
    return options.border_value[std::min<size_t>(c, options.border_value.size() - 1)];
  };
  const int stride_x = tile_width + border, stride_y = tile_height + border;
  for (int y = 0; y < sheet.height; ++y) {
    const bool border_row = (y % stride_y) < border;
    for (int x = 0; x < sheet.width; ++x) {
      if (border_row || (x % stride_x) < border) {
        for (int c = 0; c < channels; ++c) sheet.at(x, y, c) = border_channel(c);
      }
    }
  }
  const size_t row_bytes = static_cast<size_t>(tile_width) * channels;
  for (int i = 0; i < num_tiles; ++i) {
    const int left = border + (i % columns) * stride_x;
    const int top = border + (i / columns) * stride_y;
    for (int y = 0; y < tile_height; ++y) {
      std::memcpy(sheet.pixel(left, top + y), tiles[i].pixel(0, y), row_bytes);
    }
  }
  return sheet;
}

}  // namespace facecap::render
