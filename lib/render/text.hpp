#pragma once
// Text on images without a font library: a 5 x 7 pixel bitmap font of printable ASCII, drawn at
// an integer scale. Labels of plots (`ebh sweep report --plot`).
#include <string>

#include "render/image.hpp"

namespace ebh {

/// Width and height in pixels of `text` at `scale` (6 x 8 pixels a character at scale 1: the
/// glyph and one pixel of spacing).
int text_width(const std::string& text, int scale);
inline int text_height(int scale) { return 8 * scale; }

/// Draws `text` with its top-left corner at (x, y); pixels outside the image are skipped.
/// Characters outside printable ASCII (and the few the font lacks) are drawn as a box.
void draw_text(Image& img, int x, int y, const std::string& text, Rgb color, int scale = 1);

}  // namespace ebh
