#pragma once
// 8-bit RGB images: PNG files (libpng), supersampling, the displacement colour map and its
// text-free legend.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace ebh {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(Rgb a, Rgb b) { return a.r == b.r && a.g == b.g && a.b == b.b; }
};

/// Row 0 is the top row; pixel (column, row) is rgb[3 * (row * width + column) + {0, 1, 2}].
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  Image() = default;
  Image(int w, int h, Rgb fill = {});
  Rgb at(int column, int row) const;
  void set(int column, int row, Rgb c);
};

/// Box filter: each output pixel is the rounded mean of a factor x factor block (exact integer
/// arithmetic, so deterministic). in.width and in.height must be multiples of `factor`.
Image downsample(const Image& in, int factor);

/// Writes `img` as an 8-bit RGB PNG, atomically (write_file_atomically, io/atomic.hpp).
/// `text` become tEXt chunks (key, value); no time stamp is written, so equal images give equal
/// files. Throws InputError naming the file on failure.
void write_png(const std::string& path, const Image& img,
               const std::vector<std::pair<std::string, std::string>>& text = {});

/// Reads an 8-bit RGB or RGBA PNG (alpha dropped). Throws InputError naming the file.
Image read_png(const std::string& path);

/// The displacement colour map at s in [0, 1] (clamped): a perceptually ordered blue -> teal ->
/// yellow -> red ramp (viridis-like for the low end, warm for the high end, so the largest
/// displacements stand out against the tissue's usual tint).
std::array<float, 3> colormap(double s);

/// Draws the colour bar of `colormap` on the right edge of `img` (low at the bottom), with a
/// one-pixel dark border. No text: the range is printed by the command and stored in the PNG.
void draw_legend(Image& img);

/// The time bar's colour.
inline constexpr Rgb kTimeBarColour{90, 90, 100};

/// A thin bar along the bottom edge whose length is `fraction` of the width: where the frame is
/// in the replay, without text.
void draw_time_bar(Image& img, double fraction);

}  // namespace ebh
