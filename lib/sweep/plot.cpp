// `ebh sweep report --plot`: force RMS error against wall time, log-log, drawn into an Image and
// written with libpng (render/image.hpp), like the project's other pictures.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "render/image.hpp"
#include "render/text.hpp"
#include "sweep/report.hpp"

namespace ebh {
namespace {

constexpr int kWidth = 1100, kHeight = 680;
constexpr int kLeft = 110, kRight = 330, kTop = 60, kBottom = 80;  // margins around the axes, px
constexpr int kScale = 2;                                            // text scale

const Rgb kPalette[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44},  {214, 39, 40},
                        {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {23, 190, 207}};
const Rgb kBlack{0, 0, 0}, kGrid{205, 205, 205}, kMinorGrid{238, 238, 238}, kWhite{255, 255, 255};

void fill_rect(Image& img, int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y <= std::min(img.height - 1, y1); ++y)
    for (int x = std::max(0, x0); x <= std::min(img.width - 1, x1); ++x) img.set(x, y, c);
}

void line(Image& img, int x0, int y0, int x1, int y1, Rgb c, int width) {
  const int steps = std::max({std::abs(x1 - x0), std::abs(y1 - y0), 1});
  for (int i = 0; i <= steps; ++i) {
    const int x = x0 + (x1 - x0) * i / steps, y = y0 + (y1 - y0) * i / steps;
    fill_rect(img, x - width / 2, y - width / 2, x - width / 2 + width - 1, y - width / 2 + width - 1, c);
  }
}

void marker(Image& img, int x, int y, Rgb c, bool filled) {
  fill_rect(img, x - 5, y - 5, x + 5, y + 5, c);
  if (!filled) fill_rect(img, x - 3, y - 3, x + 3, y + 3, kWhite);
}

void ring(Image& img, int cx, int cy, int r, Rgb c) {
  for (int y = -r - 1; y <= r + 1; ++y)
    for (int x = -r - 1; x <= r + 1; ++x) {
      const double d = std::sqrt(static_cast<double>(x * x + y * y));
      if (d >= r - 1.5 && d <= r + 0.5 && cx + x >= 0 && cy + y >= 0 && cx + x < img.width && cy + y < img.height)
        img.set(cx + x, cy + y, c);
    }
}

/// A decade's label: 0.01, 0.1, 1, 10, 100, else 1e-5.
std::string decade(int e) {
  if (e >= -2 && e <= 2) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, e));
    return buf;
  }
  return "1e" + std::to_string(e);
}

/// A log10 axis over whole decades covering the positive values (1 decade around a single one).
struct LogAxis {
  int lo = 0, hi = 1;  // decades
  explicit LogAxis(const std::vector<double>& values) {
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
  /// Position in [0, 1]: the decades span [0.04, 0.96], so no point sits on an axis; values <= 0
  /// at 0 (the bottom edge: an error of exactly 0).
  double at(double v) const {
    return v > 0 ? 0.04 + 0.92 * std::clamp((std::log10(v) - lo) / (hi - lo), 0.0, 1.0) : 0.0;
  }
};

}  // namespace

void write_report_plot(const std::vector<ReportGroup>& groups, const std::string& path) {
  std::vector<double> xs, ys;
  for (const ReportGroup& g : groups)
    for (const ReportPoint& p : g.points) {
      xs.push_back(p.wall_s);
      if (!p.reference) ys.push_back(p.error_rms);
    }
  const LogAxis ax(xs), ay(ys);
  const int x0 = kLeft, x1 = kWidth - kRight, y0 = kHeight - kBottom, y1 = kTop;  // axes box (y up)
  auto px = [&](double v) { return x0 + static_cast<int>(std::lround(ax.at(v) * (x1 - x0))); };
  auto py = [&](double v) { return y0 - static_cast<int>(std::lround(ay.at(v) * (y0 - y1))); };

  Image img(kWidth, kHeight, kWhite);
  for (int e = ax.lo; e < ax.hi; ++e)  // 2..9 within each decade, fainter
    for (int k = 2; k <= 9; ++k)
      line(img, px(k * std::pow(10.0, e)), y1, px(k * std::pow(10.0, e)), y0, kMinorGrid, 1);
  for (int e = ay.lo; e < ay.hi; ++e)
    for (int k = 2; k <= 9; ++k) line(img, x0, py(k * std::pow(10.0, e)), x1, py(k * std::pow(10.0, e)), kMinorGrid, 1);
  for (int e = ax.lo; e <= ax.hi; ++e) {
    const int x = px(std::pow(10.0, e));
    line(img, x, y1, x, y0, kGrid, 1);
    const std::string s = decade(e);
    draw_text(img, x - text_width(s, kScale) / 2, y0 + 10, s, kBlack, kScale);
  }
  for (int e = ay.lo; e <= ay.hi; ++e) {
    const int y = py(std::pow(10.0, e));
    line(img, x0, y, x1, y, kGrid, 1);
    const std::string s = decade(e);
    draw_text(img, x0 - 10 - text_width(s, kScale), y - text_height(kScale) / 2, s, kBlack, kScale);
  }
  line(img, x0, y0, x1, y0, kBlack, 2);
  line(img, x0, y0, x0, y1, kBlack, 2);
  const std::string xlabel = "wall time (s)", ylabel = "force RMS error against the reference (N)";
  draw_text(img, (x0 + x1 - text_width(xlabel, kScale)) / 2, y0 + 40, xlabel, kBlack, kScale);
  draw_text(img, x0 - 60, y1 - 40, ylabel, kBlack, kScale);

  int legend_y = y1;
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const ReportGroup& g = groups[gi];
    const Rgb c = kPalette[gi % std::size(kPalette)];
    int last_x = -1, last_y = -1;
    for (const ReportPoint& p : g.points) {  // by wall time: the front is a staircase left to right
      if (!p.front) continue;
      const int x = px(p.wall_s), y = py(p.error_rms);
      if (last_x >= 0) line(img, last_x, last_y, x, y, c, 2);
      last_x = x;
      last_y = y;
    }
    for (const ReportPoint& p : g.points) {
      if (std::isnan(p.wall_s)) continue;
      if (p.reference) ring(img, px(p.wall_s), y0, 8, c);
      else if (!std::isnan(p.error_rms)) marker(img, px(p.wall_s), py(p.error_rms), c, p.front);
      if (!p.reference && !p.baseline.empty() && !std::isnan(p.error_rms)) ring(img, px(p.wall_s), py(p.error_rms), 10, c);
    }
    marker(img, x1 + 30, legend_y + 7, c, true);
    std::string name = g.scene + " + " + g.recording;
    draw_text(img, x1 + 45, legend_y, name.substr(0, 22), kBlack, kScale);
    draw_text(img, x1 + 45, legend_y + 20, g.backend, kBlack, kScale);
    legend_y += 50;
  }
  const int ky = std::max(legend_y + 10, y0 - 120);
  marker(img, x1 + 30, ky + 7, kBlack, true);
  draw_text(img, x1 + 45, ky, "front", kBlack, kScale);
  marker(img, x1 + 30, ky + 37, kBlack, false);
  draw_text(img, x1 + 45, ky + 30, "dominated", kBlack, kScale);
  ring(img, x1 + 30, ky + 67, 8, kBlack);
  draw_text(img, x1 + 45, ky + 60, "reference", kBlack, kScale);
  marker(img, x1 + 30, ky + 97, kBlack, false);
  ring(img, x1 + 30, ky + 97, 10, kBlack);
  draw_text(img, x1 + 45, ky + 90, "baseline", kBlack, kScale);
  write_png(path, img, {{"Title", "ebh sweep report: " + ylabel + " against " + xlabel}});
}

}  // namespace ebh
