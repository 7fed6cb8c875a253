// `ebh sweep report --plot`: force RMS error against wall time, log-log (render/plot.hpp), written
// with libpng (render/image.hpp), like the project's other pictures.
#include <algorithm>
#include <cmath>

#include "render/image.hpp"
#include "render/plot.hpp"
#include "render/text.hpp"
#include "sweep/report.hpp"

namespace ebh {
namespace {

constexpr int kWidth = 1100, kHeight = 680;
constexpr int kLeft = 110, kRight = 330, kTop = 60, kBottom = 80;  // margins around the axes, px
constexpr int kScale = 2;                                            // text scale

}  // namespace

void write_report_plot(const std::vector<ReportGroup>& groups, const std::string& path) {
  std::vector<double> xs, ys;
  for (const ReportGroup& g : groups)
    for (const ReportPoint& p : g.points) {
      xs.push_back(p.wall_s);
      if (!p.reference) ys.push_back(p.error_rms);
    }
  Image img(kWidth, kHeight, kPlotWhite);
  const std::string xlabel = "wall time (s)", ylabel = "force RMS error against the reference (N)";
  const LogLogFrame f = draw_log_log_frame(img, LogAxis(xs), LogAxis(ys), kLeft, kRight, kTop, kBottom, xlabel, ylabel, kScale);
  const int x1 = f.x1, y0 = f.y0, y1 = f.y1;

  int legend_y = y1;
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const ReportGroup& g = groups[gi];
    const Rgb c = kPlotPalette[gi % kPlotPaletteSize];
    int last_x = -1, last_y = -1;
    for (const ReportPoint& p : g.points) {  // by wall time: the front is a staircase left to right
      if (!p.front) continue;
      const int x = f.px(p.wall_s), y = f.py(p.error_rms);
      if (last_x >= 0) draw_line(img, last_x, last_y, x, y, c, 2);
      last_x = x;
      last_y = y;
    }
    for (const ReportPoint& p : g.points) {
      if (std::isnan(p.wall_s)) continue;
      if (p.reference) draw_ring(img, f.px(p.wall_s), y0, 8, c);
      else if (!std::isnan(p.error_rms)) draw_marker(img, f.px(p.wall_s), f.py(p.error_rms), c, p.front);
      if (!p.reference && !p.baseline.empty() && !std::isnan(p.error_rms))
        draw_ring(img, f.px(p.wall_s), f.py(p.error_rms), 10, c);
    }
    draw_marker(img, x1 + 30, legend_y + 7, c, true);
    std::string name = g.scene + " + " + g.recording;
    draw_text(img, x1 + 45, legend_y, name.substr(0, 22), kPlotBlack, kScale);
    draw_text(img, x1 + 45, legend_y + 20, g.backend, kPlotBlack, kScale);
    legend_y += 50;
  }
  const int ky = std::max(legend_y + 10, y0 - 120);
  draw_marker(img, x1 + 30, ky + 7, kPlotBlack, true);
  draw_text(img, x1 + 45, ky, "front", kPlotBlack, kScale);
  draw_marker(img, x1 + 30, ky + 37, kPlotBlack, false);
  draw_text(img, x1 + 45, ky + 30, "dominated", kPlotBlack, kScale);
  draw_ring(img, x1 + 30, ky + 67, 8, kPlotBlack);
  draw_text(img, x1 + 45, ky + 60, "reference", kPlotBlack, kScale);
  draw_marker(img, x1 + 30, ky + 97, kPlotBlack, false);
  draw_ring(img, x1 + 30, ky + 97, 10, kPlotBlack);
  draw_text(img, x1 + 45, ky + 90, "baseline", kPlotBlack, kScale);
  write_png(path, img, {{"Title", "ebh sweep report: " + ylabel + " against " + xlabel}});
}

}  // namespace ebh
