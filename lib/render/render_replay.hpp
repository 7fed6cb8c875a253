#pragma once
// `ebh render`: the /frames snapshots of a replay output drawn to numbered PNG files
// (DIR/frame_00000.png, ...), optionally assembled into a video by ffmpeg. docs/RENDER.md.
//
//   RenderOptions opt;               // 800 x 600, the scene's camera, every frame
//   opt.camera = "iso";
//   RenderSummary s = render_replay("out.h5", "frames/", opt);
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/paths.hpp"
#include "render/camera.hpp"
#include "render/offscreen.hpp"
#include "render/replay_frames.hpp"
#include "scene/scene.hpp"
#include "tool/tool_model.hpp"

namespace ebh {

enum class ColorBy { None, Displacement };

struct RenderOptions {
  int width = 800, height = 600;   ///< pixels of each PNG
  std::string camera = "scene";    ///< "scene" or a preset (camera.hpp: top, front, side, iso)
  int every = 1;                   ///< render frames 0, every, 2 every, ...
  ColorBy color_by = ColorBy::None;
  double max_displacement = 0.0;   ///< m, top of the colour map; 0: the largest in the rendered frames
  int supersample = 3;             ///< antialiasing: render k x larger, box-filter down
  bool time_bar = true;            ///< the thin bar along the bottom edge showing t / t_end
  std::string video;               ///< also write this .mp4 with ffmpeg ("" = no video)
};

struct RenderSummary {
  std::vector<std::string> files;      ///< the PNG files written, in order
  ViewCamera camera;                   ///< the camera used for every frame
  std::string camera_source;           ///< "scene file X", "preset iso", "bounding box (no scene)"
  double displacement_range = 0.0;     ///< m, the colour map's top (Displacement only)
  std::string video;                   ///< the video written ("" = none)
  std::vector<std::string> warnings;   ///< one line each (scene not found, non-finite frames)
};

/// The scene the replay ran: its `scene_yaml` attribute; in outputs without it the `scene_file`
/// attribute (with the recorded --set overrides), else the `scene` name resolved like `ebh
/// replay` does; empty (with a warning) if none loads.
std::optional<SceneSpec> find_replay_scene(const ReplayFrames& frames, std::vector<std::string>& warnings);

/// The camera called `name` ("scene" or a preset) for the virtual mesh's rest bounds; "scene"
/// without a scene falls back to the iso preset. `source` says which was used.
ViewCamera choose_camera(const std::string& name, const std::optional<SceneSpec>& scene, const Bounds& rest,
                         double aspect, std::string& source);

/// The tool drawn: the scene's tool, else a default tool of the recorded kind and shaft radius.
ToolModel replay_tool(const ReplayFrames& frames, const std::optional<SceneSpec>& scene);

/// What can fail before a frame is read: checks the options (sizes, --every, ffmpeg for --video)
/// and creates the rendering context (OSMesa) render_replay draws with. Throws InputError for bad
/// options, in a build without OSMesa, or when Mesa cannot create the context. `ebh replay
/// --render` starts it before the replay, so that such a failure leaves the previous output.
std::unique_ptr<OffscreenRenderer> start_renderer(const RenderOptions& opt);

/// Throws InputError when `dir` exists and is not a folder, or holds something named like a frame
/// (frame_*.png) that is not a file (a folder), which the render would replace.
void check_frames_folder(const std::string& dir);

/// Throws InputError when one of `files` (a command's inputs and outputs) is named like a frame
/// (frame_*.png) in `dir`: the render replaces every such file there.
void check_frames_spare(const std::string& dir, const std::vector<RoleFile>& files);

/// Renders the frames of `replay` into `dir` (created if missing; frame_*.png files already in
/// it are removed first so a video never mixes two runs) with `renderer`, one start_renderer(opt)
/// made (nullptr: it starts its own). Throws InputError for bad input or options, in a build
/// without OSMesa, or when --video is asked and ffmpeg is missing.
RenderSummary render_replay(const std::string& replay, const std::string& dir, const RenderOptions& opt,
                            OffscreenRenderer* renderer = nullptr);

/// A length in metres as millimetres to three significant digits ("1.52 mm", "1e+300 mm",
/// "1e-09 mm"): the colour range in a PNG's Comment and on `ebh render`'s stdout.
std::string format_mm(double metres);

/// Where ffmpeg is on the PATH ("" if it is not).
std::string find_on_path(const std::string& program);

}  // namespace ebh
