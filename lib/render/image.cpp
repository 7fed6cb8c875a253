#include "render/image.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "core/error.hpp"
#include "io/atomic.hpp"

namespace ebh {

Image::Image(int w, int h, Rgb fill) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3) {
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = fill.r;
    rgb[i + 1] = fill.g;
    rgb[i + 2] = fill.b;
  }
}

Rgb Image::at(int c, int r) const {
  const std::size_t i = 3 * (static_cast<std::size_t>(r) * width + c);
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

void Image::set(int c, int r, Rgb v) {
  if (c < 0 || r < 0 || c >= width || r >= height) return;
  const std::size_t i = 3 * (static_cast<std::size_t>(r) * width + c);
  rgb[i] = v.r;
  rgb[i + 1] = v.g;
  rgb[i + 2] = v.b;
}

Image downsample(const Image& in, int k) {
  if (k <= 1) return in;
  Image out(in.width / k, in.height / k);
  const unsigned n = static_cast<unsigned>(k * k);
  for (int r = 0; r < out.height; ++r)
    for (int c = 0; c < out.width; ++c)
      for (int ch = 0; ch < 3; ++ch) {
        unsigned sum = 0;
        for (int dr = 0; dr < k; ++dr)
          for (int dc = 0; dc < k; ++dc)
            sum += in.rgb[3 * (static_cast<std::size_t>(r * k + dr) * in.width + (c * k + dc)) + ch];
        out.rgb[3 * (static_cast<std::size_t>(r) * out.width + c) + ch] = static_cast<std::uint8_t>((sum + n / 2) / n);
      }
  return out;
}

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { if (f) std::fclose(f); }
};

// libpng reports errors by longjmp back to the setjmp in the function that called it; the two
// helpers below hold no object with a destructor, so the jump skips nothing that needs cleaning.
void png_error_jump(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void png_warning_ignore(png_structp, png_const_charp) {}

void png_append(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), n);
}
void png_no_flush(png_structp) {}

// Encodes the image into `bytes` (written to the disk by the caller, every write checked).
bool png_write_image(std::string& bytes, const Image& img, png_text* chunks, int nchunks) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, png_error_jump, png_warning_ignore);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &bytes, png_append, png_no_flush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(img.width), static_cast<png_uint_32>(img.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (nchunks > 0) png_set_text(png, info, chunks, nchunks);
  png_write_info(png, info);
  for (int r = 0; r < img.height; ++r) png_write_row(png, img.rgb.data() + 3 * static_cast<std::size_t>(r) * img.width);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

/// Returns "" on success, else what is wrong.
const char* png_read_image(std::FILE* fp, Image& img) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, png_error_jump, png_warning_ignore);
  if (!png) return "libpng could not start";
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return "libpng could not start";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return "not a readable PNG file";
  }
  png_init_io(png, fp);
  png_read_info(png, info);
  const int type = png_get_color_type(png, info);
  if (png_get_bit_depth(png, info) != 8 || (type != PNG_COLOR_TYPE_RGB && type != PNG_COLOR_TYPE_RGB_ALPHA)) {
    png_destroy_read_struct(&png, &info, nullptr);
    return "not an 8-bit RGB PNG";
  }
  if (type == PNG_COLOR_TYPE_RGB_ALPHA) png_set_strip_alpha(png);
  png_read_update_info(png, info);
  img.width = static_cast<int>(png_get_image_width(png, info));
  img.height = static_cast<int>(png_get_image_height(png, info));
  img.rgb.resize(3 * static_cast<std::size_t>(img.width) * img.height);
  for (int r = 0; r < img.height; ++r) png_read_row(png, img.rgb.data() + 3 * static_cast<std::size_t>(r) * img.width, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return "";
}

}  // namespace

void write_png(const std::string& path, const Image& img, const std::vector<std::pair<std::string, std::string>>& text) {
  if (img.width <= 0 || img.height <= 0) throw InputError(path + ": cannot write an empty image");
  std::vector<png_text> chunks(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    chunks[i].compression = PNG_TEXT_COMPRESSION_NONE;
    chunks[i].key = const_cast<char*>(text[i].first.c_str());
    chunks[i].text = const_cast<char*>(text[i].second.c_str());
  }
  std::string bytes;
  if (!png_write_image(bytes, img, chunks.data(), static_cast<int>(chunks.size())))
    throw InputError(path + ": libpng could not encode the image");
  write_file_atomically(path, bytes);
}

Image read_png(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> fp(std::fopen(path.c_str(), "rb"));
  if (!fp) throw InputError(path + ": cannot open");
  Image img;
  const std::string err = png_read_image(fp.get(), img);
  if (!err.empty()) throw InputError(path + ": " + err);
  return img;
}

std::array<float, 3> colormap(double s) {
  struct Stop { double s; float r, g, b; };
  static constexpr Stop stops[] = {
      {0.00, 0.19f, 0.25f, 0.62f},  // deep blue: at rest
      {0.30, 0.13f, 0.57f, 0.55f},  // teal
      {0.60, 0.60f, 0.80f, 0.25f},  // yellow-green
      {0.80, 0.98f, 0.78f, 0.15f},  // yellow
      {1.00, 0.82f, 0.12f, 0.10f},  // red: the range's top
  };
  if (!(s > 0)) s = 0;  // NaN too
  if (s > 1) s = 1;
  for (std::size_t i = 1; i < std::size(stops); ++i)
    if (s <= stops[i].s) {
      const Stop& a = stops[i - 1];
      const Stop& b = stops[i];
      const float w = static_cast<float>((s - a.s) / (b.s - a.s));
      return {a.r + w * (b.r - a.r), a.g + w * (b.g - a.g), a.b + w * (b.b - a.b)};
    }
  return {stops[4].r, stops[4].g, stops[4].b};
}

void draw_legend(Image& img) {
  const int bw = std::max(6, img.width / 60), margin = std::max(4, img.width / 80);
  const int x1 = img.width - margin, x0 = x1 - bw;
  const int y0 = img.height / 5, y1 = img.height - img.height / 5;
  if (x0 < 1 || y1 - y0 < 4) return;  // too small an image for a legend
  const Rgb border{40, 40, 40};
  for (int r = y0 - 1; r <= y1; ++r) {
    for (int c = x0 - 1; c <= x1; ++c) {
      if (r == y0 - 1 || r == y1 || c == x0 - 1 || c == x1) {
        img.set(c, r, border);
        continue;
      }
      const auto col = colormap(static_cast<double>(y1 - 1 - r) / std::max(1, y1 - y0 - 1));
      img.set(c, r, {static_cast<std::uint8_t>(std::lround(255 * col[0])), static_cast<std::uint8_t>(std::lround(255 * col[1])),
                     static_cast<std::uint8_t>(std::lround(255 * col[2]))});
    }
  }
}

void draw_time_bar(Image& img, double fraction) {
  if (!(fraction >= 0)) fraction = 0;
  fraction = std::min(fraction, 1.0);
  const int h = std::max(2, img.height / 150);
  const int w = static_cast<int>(std::lround(fraction * img.width));
  for (int r = img.height - h; r < img.height; ++r)
    for (int c = 0; c < w; ++c) img.set(c, r, kTimeBarColour);
}

}  // namespace ebh
