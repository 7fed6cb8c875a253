// `ebh render OUT.h5 -o DIR [--size WxH] [--camera NAME] [--every N] [--color-by none|displacement]
//  [--max-displacement-mm MM] [--supersample K] [--no-time-bar] [--video FILE.mp4] [--xdmf-only]`:
// the replay's /frames snapshots to DIR/frame_00000.png, ... with OSMesa (docs/RENDER.md).
// --xdmf-only writes OUT.xdmf (the ParaView index) and renders nothing.
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "options.hpp"
#include "render/render_replay.hpp"
#include "render/xdmf.hpp"

namespace {

struct RenderArgs {
  std::string replay, dir, size = "800x600", color_by = "none", video;
  ebh::RenderOptions opt;
  double max_displacement_mm = 0;
  bool no_time_bar = false, xdmf_only = false, quiet = false;
};

/// WIDTHxHEIGHT, each a whole number of pixels: digits only (sscanf's %d wrapped 4294967312 to
/// 16); render_replay checks the range and names it.
void parse_size(const std::string& s, ebh::RenderOptions& opt) {
  const auto x = s.find('x');
  auto pixels = [&](std::string_view part) {
    int v = 0;
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), v);
    if (part.empty() || ec != std::errc() || end != part.data() + part.size())
      throw ebh::InputError("--size: expected WIDTHxHEIGHT in whole pixels (e.g. 800x600; each 16..4096), got '" + s + "'");
    return v;
  };
  if (x == std::string::npos) pixels("");
  const std::string_view all(s);
  opt.width = pixels(all.substr(0, x));
  opt.height = pixels(all.substr(x + 1));
}

void run(RenderArgs& a, const CLI::App& c) {
  // Options that do nothing where they are given: said, not ignored.
  if (a.xdmf_only)
    for (const char* o : {"--output", "--size", "--camera", "--every", "--color-by", "--max-displacement-mm",
                          "--supersample", "--no-time-bar", "--video"})
      if (c.count(o) > 0) {
        const std::string name = std::string(o) == "--output" ? "-o" : o;
        throw ebh::InputError(name + ": --xdmf-only writes only the .xdmf beside the replay; leave " + name + " out");
      }
  if (c.count("--max-displacement-mm") > 0) {
    if (a.color_by != "displacement")
      throw ebh::InputError("--max-displacement-mm: the top of the displacement colours; give --color-by displacement too");
  }
  if (a.xdmf_only) {
    const std::string x = ebh::write_xdmf(a.replay);
    if (!a.quiet) std::printf("%s\n", x.c_str());
    return;
  }
  if (a.dir.empty()) throw ebh::InputError("-o DIR is required (or --xdmf-only)");
  parse_size(a.size, a.opt);
  if (a.color_by == "none")
    a.opt.color_by = ebh::ColorBy::None;
  else if (a.color_by == "displacement")
    a.opt.color_by = ebh::ColorBy::Displacement;
  else
    throw ebh::InputError("--color-by: expected none or displacement, got '" + a.color_by + "'");
  a.opt.max_displacement = a.max_displacement_mm * 1e-3;
  a.opt.time_bar = !a.no_time_bar;
  a.opt.video = a.video;
  const ebh::RenderSummary s = ebh::render_replay(a.replay, a.dir, a.opt);
  for (const auto& w : s.warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  if (a.quiet) return;
  std::printf("%s: %zu frames, %dx%d, camera: %s\n", a.dir.c_str(), s.files.size(), a.opt.width, a.opt.height,
              s.camera_source.c_str());
  if (a.opt.color_by == ebh::ColorBy::Displacement)
    std::printf("  tissue colour = displacement from rest: 0 mm (blue, bottom of the bar) .. %s (red, top)\n",
                ebh::format_mm(s.displacement_range).c_str());
  if (!s.video.empty()) std::printf("  video %s\n", s.video.c_str());
}

void setup(CLI::App& root) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* c = root.add_subcommand("render", "Render a replay's mesh snapshots to PNG files (OSMesa; docs/RENDER.md)");
  c->add_option("replay", args->replay, "replay output with /frames (ebh replay --frames-hz N)")->required();
  c->add_option("-o,--output", args->dir, "directory for frame_00000.png, ...");
  c->add_option("--size", args->size, "image size WIDTHxHEIGHT")->capture_default_str();
  c->add_option("--camera", args->opt.camera, "scene (the scene file's camera), top, front, side or iso")
      ->capture_default_str();
  c->add_option("--every", args->opt.every, "render every N-th frame")
      ->capture_default_str()
      ->check(ebh::cli::whole_number(1, std::numeric_limits<int>::max()));
  c->add_option("--color-by", args->color_by, "tissue colour: none or displacement")->capture_default_str();
  c->add_option("--max-displacement-mm", args->max_displacement_mm,
                "top of the displacement colour map (default: the largest displacement rendered)")
      ->check(ebh::cli::finite_number(0, ebh::cli::kNoUpperLimit, true, "mm"));
  c->add_option("--supersample", args->opt.supersample, "antialiasing factor 1..4")
      ->capture_default_str()
      ->check(ebh::cli::whole_number(1, 4));
  c->add_flag("--no-time-bar", args->no_time_bar, "leave out the bar along the bottom edge that shows t / t_end");
  c->add_option("--video", args->video, "also assemble the frames into this .mp4 (needs ffmpeg)");
  c->add_flag("--xdmf-only", args->xdmf_only, "only write OUT.xdmf beside the replay (for ParaView)");
  c->add_flag("-q,--quiet", args->quiet, "print nothing but warnings");
  c->callback([args, c] { run(*args, *c); });
}

}  // namespace

EBH_COMMAND(setup);
