#pragma once
// Charts on log-log axes drawn into an Image with the bitmap font (render/text.hpp): the decade
// grid and labels, lines, markers and rings. `ebh sweep report --plot` (run time against error)
// and `ebh bench sizes --plot` (costs against mesh size) draw with these.
#include <iterator>
#include <string>
#include <vector>

#include "render/image.hpp"

namespace ebh {

/// Colours of a chart's series, in order (matplotlib's "tab10").
inline constexpr Rgb kPlotPalette[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44},  {214, 39, 40},
                                       {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {23, 190, 207}};
inline constexpr std::size_t kPlotPaletteSize = std::size(kPlotPalette);
inline constexpr Rgb kPlotBlack{0, 0, 0}, kPlotWhite{255, 255, 255};

/// The rectangle [x0, x1] x [y0, y1] (pixels, clipped to the image).
void fill_rect(Image& img, int x0, int y0, int x1, int y1, Rgb c);
/// A straight line `width` pixels wide.
void draw_line(Image& img, int x0, int y0, int x1, int y1, Rgb c, int width);
/// An 11 x 11 square marker centred on (x, y), hollow unless `filled`.
void draw_marker(Image& img, int x, int y, Rgb c, bool filled);
/// A circle of radius r pixels, 2 pixels thick.
void draw_ring(Image& img, int cx, int cy, int r, Rgb c);

/// A log10 axis over whole decades covering the positive, finite values (1 decade around a
/// single one).
struct LogAxis {
  int lo = 0, hi = 1;  ///< decades
  explicit LogAxis(const std::vector<double>& values);
  /// Position in [0, 1]: the decades span [0.04, 0.96], so no point sits on an axis; values <= 0
  /// at 0 (the bottom edge: an error of exactly 0).
  double at(double v) const;
};

/// A chart's axes box in an image, y up: x0 < x1 left to right, y0 > y1 bottom to top.
struct LogLogFrame {
  LogAxis ax, ay;
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  int px(double v) const;  ///< the column of x value v
  int py(double v) const;  ///< the row of y value v
};

/// Draws the grid (decades and their 2..9 subdivisions), the decade labels, the axes and their
/// titles for a chart whose box leaves `left`, `right`, `top`, `bottom` pixels of margin; returns
/// the frame that places values. Text at scale `text_scale`.
LogLogFrame draw_log_log_frame(Image& img, const LogAxis& ax, const LogAxis& ay, int left, int right, int top, int bottom,
                               const std::string& xlabel, const std::string& ylabel, int text_scale);

}  // namespace ebh
