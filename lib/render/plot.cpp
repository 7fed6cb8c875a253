// Log-log charts (render/plot.hpp).
#include "render/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "render/text.hpp"

namespace ebh {
namespace {

const Rgb kGrid{205, 205, 205}, kMinorGrid{238, 238, 238};

/// A decade's label: 0.01, 0.1, 1, 10, 100, else 1e-5.
std::string decade(int e) {
  if (e >= -2 && e <= 2) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, e));
    return buf;
  }
  return "1e" + std::to_string(e);
}

}  // namespace

void fill_rect(Image& img, int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y <= std::min(img.height - 1, y1); ++y)
    for (int x = std::max(0, x0); x <= std::min(img.width - 1, x1); ++x) img.set(x, y, c);
}

void draw_line(Image& img, int x0, int y0, int x1, int y1, Rgb c, int width) {
  const int steps = std::max({std::abs(x1 - x0), std::abs(y1 - y0), 1});
  for (int i = 0; i <= steps; ++i) {
    const int x = x0 + (x1 - x0) * i / steps, y = y0 + (y1 - y0) * i / steps;
    fill_rect(img, x - width / 2, y - width / 2, x - width / 2 + width - 1, y - width / 2 + width - 1, c);
  }
}

void draw_marker(Image& img, int x, int y, Rgb c, bool filled) {
  fill_rect(img, x - 5, y - 5, x + 5, y + 5, c);
  if (!filled) fill_rect(img, x - 3, y - 3, x + 3, y + 3, kPlotWhite);
}

void draw_ring(Image& img, int cx, int cy, int r, Rgb c) {
  for (int y = -r - 1; y <= r + 1; ++y)
    for (int x = -r - 1; x <= r + 1; ++x) {
      const double d = std::sqrt(static_cast<double>(x * x + y * y));
      if (d >= r - 1.5 && d <= r + 0.5 && cx + x >= 0 && cy + y >= 0 && cx + x < img.width && cy + y < img.height)
        img.set(cx + x, cy + y, c);
    }
}

LogAxis::LogAxis(const std::vector<double>& values) {
  double mn = std::numeric_limits<double>::infinity(), mx = 0;
  for (double v : values)
    if (v > 0 && std::isfinite(v)) {
      mn = std::min(mn, v);
      mx = std::max(mx, v);
    }
  if (!(mx > 0)) return;
  lo = static_cast<int>(std::floor(std::log10(mn)));
  hi = static_cast<int>(std::ceil(std::log10(mx)));
  if (hi == lo) ++hi;
}

double LogAxis::at(double v) const {
  return v > 0 ? 0.04 + 0.92 * std::clamp((std::log10(v) - lo) / (hi - lo), 0.0, 1.0) : 0.0;
}

int LogLogFrame::px(double v) const { return x0 + static_cast<int>(std::lround(ax.at(v) * (x1 - x0))); }
int LogLogFrame::py(double v) const { return y0 - static_cast<int>(std::lround(ay.at(v) * (y0 - y1))); }

LogLogFrame draw_log_log_frame(Image& img, const LogAxis& ax, const LogAxis& ay, int left, int right, int top, int bottom,
                               const std::string& xlabel, const std::string& ylabel, int text_scale) {
  const LogLogFrame f{ax, ay, left, img.width - right, img.height - bottom, top};
  for (int e = ax.lo; e < ax.hi; ++e)  // 2..9 within each decade, fainter
    for (int k = 2; k <= 9; ++k)
      draw_line(img, f.px(k * std::pow(10.0, e)), f.y1, f.px(k * std::pow(10.0, e)), f.y0, kMinorGrid, 1);
  for (int e = ay.lo; e < ay.hi; ++e)
    for (int k = 2; k <= 9; ++k)
      draw_line(img, f.x0, f.py(k * std::pow(10.0, e)), f.x1, f.py(k * std::pow(10.0, e)), kMinorGrid, 1);
  for (int e = ax.lo; e <= ax.hi; ++e) {
    const int x = f.px(std::pow(10.0, e));
    draw_line(img, x, f.y1, x, f.y0, kGrid, 1);
    const std::string s = decade(e);
    draw_text(img, x - text_width(s, text_scale) / 2, f.y0 + 10, s, kPlotBlack, text_scale);
  }
  for (int e = ay.lo; e <= ay.hi; ++e) {
    const int y = f.py(std::pow(10.0, e));
    draw_line(img, f.x0, y, f.x1, y, kGrid, 1);
    const std::string s = decade(e);
    draw_text(img, f.x0 - 10 - text_width(s, text_scale), y - text_height(text_scale) / 2, s, kPlotBlack, text_scale);
  }
  draw_line(img, f.x0, f.y0, f.x1, f.y0, kPlotBlack, 2);
  draw_line(img, f.x0, f.y0, f.x0, f.y1, kPlotBlack, 2);
  draw_text(img, (f.x0 + f.x1 - text_width(xlabel, text_scale)) / 2, f.y0 + 40, xlabel, kPlotBlack, text_scale);
  draw_text(img, f.x0 - 60, f.y1 - 40, ylabel, kPlotBlack, text_scale);
  return f;
}

}  // namespace ebh
