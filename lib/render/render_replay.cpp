#include "render/render_replay.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <thread>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "io/sha256.hpp"
#include "mesh/surface.hpp"
#include "render/image.hpp"
#include "render/tessellate.hpp"

extern char** environ;

namespace ebh {
namespace fs = std::filesystem;

namespace {

/// Drops triangles with a non-finite vertex (a blown-up run), so they cannot smear across the
/// image. Returns how many were dropped.
std::size_t finite_triangles(const std::vector<Vec3f>& q, const std::vector<std::array<int, 3>>& all,
                             std::vector<std::array<int, 3>>& out) {
  std::vector<char> ok(q.size());
  bool every = true;
  for (std::size_t i = 0; i < q.size(); ++i) {
    ok[i] = std::isfinite(q[i].x) && std::isfinite(q[i].y) && std::isfinite(q[i].z);
    every = every && ok[i];
  }
  out.clear();
  if (every) return 0;
  for (const auto& t : all)
    if (ok[t[0]] && ok[t[1]] && ok[t[2]]) out.push_back(t);
  return all.size() - out.size();
}

bool finite_pose(const ToolPose& p) { return std::isfinite(p.position.x + p.position.y + p.position.z); }

double frame_rate(const ReplayFrames& f, int every) {
  if (f.frame_count() < 2) return 10.0;
  std::vector<double> dt;
  for (std::size_t i = 1; i < f.frame_count(); ++i) dt.push_back(f.t[i] - f.t[i - 1]);
  std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  const double d = dt[dt.size() / 2] * every;
  return d > 0 && std::isfinite(d) ? 1.0 / d : 10.0;
}

/// Waits for the child `pid` to end and returns its wait status (nullopt when it cannot be waited
/// for). An interrupt (interrupted()) stops it: SIGTERM, then SIGKILL when it is still running
/// half a second later, and it is reaped before this returns, so that no child outlives the
/// process and writes on into an output's temporary after that is removed. The interrupt's grace
/// (io/atomic.hpp) or a second signal would otherwise end this process with the child still
/// running: the child is recorded for them to kill (set_child_to_kill) until it has ended.
std::optional<int> wait_for_child(pid_t pid) {
  using namespace std::chrono_literals;
  set_child_to_kill(pid);
  int status = 0;
  enum class State { running, ended, lost };
  // Whether it ended, without reaping it: its record is cleared first, so that a signal between
  // the two does not kill another process that got its PID.
  auto poll = [&] {
    siginfo_t info{};
    const int r = waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT);
    if (r < 0) return errno == EINTR ? State::running : State::lost;
    return info.si_pid == pid ? State::ended : State::running;
  };
  // Polled, not a blocking waitpid: a signal arriving just before that call would go unseen until
  // the child ended by itself.
  State state = State::running;
  while (!interrupted() && (state = poll()) == State::running) std::this_thread::sleep_for(20ms);
  if (state == State::running) {
    kill(pid, SIGTERM);
    for (int i = 0; i < 25 && (state = poll()) == State::running; ++i) std::this_thread::sleep_for(20ms);
  }
  if (state == State::running) kill(pid, SIGKILL);
  set_child_to_kill(0);
  if (state == State::lost) return std::nullopt;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return std::nullopt;
  return status;
}

void run_ffmpeg(const std::string& dir, const std::string& video, double fps) {
  const std::string ffmpeg = find_on_path("ffmpeg");
  if (ffmpeg.empty())
    throw InputError("--video " + video + ": ffmpeg was not found on the PATH (install ffmpeg; the PNG frames are in " +
                     dir + ")");
  AtomicOutput out(video);
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", fps);
  const std::string pattern = (fs::path(dir) / "frame_%05d.png").string();
  std::vector<std::string> args = {ffmpeg, "-y", "-nostdin", "-loglevel", "error", "-framerate", rate, "-i", pattern,
                                   "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-f", "mp4",
                                   out.temp_path()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, ffmpeg.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
    throw InputError("--video " + video + ": cannot start " + ffmpeg);
  const std::optional<int> status = wait_for_child(pid);
  // Interrupted: ffmpeg is gone (stopped here, or by the same signal sent to the process group, as
  // `timeout` and a terminal's Ctrl-C send it), and `out` removes what it wrote.
  if (interrupted())
    throw InputError("--video " + video + ": interrupted while ffmpeg assembled the video; no video written (the frames "
                     "are in " + dir + ")");
  if (!status) throw InputError("--video " + video + ": lost the ffmpeg process");
  if (WIFSIGNALED(*status))
    throw InputError(video + ": ffmpeg was killed by signal " + std::to_string(WTERMSIG(*status)) + " (" +
                     strsignal(WTERMSIG(*status)) + ")");
  if (!WIFEXITED(*status) || WEXITSTATUS(*status) != 0)
    throw InputError(video + ": ffmpeg failed (exit status " + std::to_string(WEXITSTATUS(*status)) + ")");
  out.commit();
}

bool is_frame_name(const fs::path& p) {
  return p.filename().string().rfind("frame_", 0) == 0 && p.extension() == ".png";
}

/// Whether `file` is in the folder `dir`, which need not exist yet.
bool in_folder(const fs::path& file, const fs::path& dir) {
  const fs::path folder = file.parent_path().empty() ? fs::path(".") : file.parent_path();
  std::error_code ec;
  if (fs::exists(folder, ec) && fs::exists(dir, ec)) return fs::equivalent(folder, dir, ec);
  auto normal = [](const fs::path& p) {
    std::error_code e;
    fs::path n = fs::weakly_canonical(fs::absolute(p), e).lexically_normal();
    return n.has_filename() ? n : n.parent_path();
  };
  return normal(folder) == normal(dir);
}

/// The frames rendered into `fresh` (a folder beside them) take the place of the frame_*.png
/// files in `dir`: the old ones are moved aside first (a frame that cannot be moved, an immutable
/// file, stops it with every old frame back in place), then the new ones are moved in.
void replace_frames(const fs::path& dir, const fs::path& fresh) {
  const fs::path aside = partial_path_for((dir / "old_frames").string());
  std::error_code ec;
  fs::remove_all(aside, ec);
  fs::create_directory(aside, ec);
  if (ec) throw InputError(dir.string() + ": cannot make the folder " + aside.string() + ": " + ec.message());
  std::vector<fs::path> moved;
  auto put_back = [&] {
    for (const fs::path& m : moved) {
      std::error_code back;
      fs::rename(aside / m.filename(), m, back);
    }
    fs::remove_all(aside, ec);
  };
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!is_frame_name(e.path())) continue;
    if (std::rename(e.path().c_str(), (aside / e.path().filename()).c_str()) != 0) {
      const int err = errno;
      put_back();
      throw InputError(e.path().string() + ": cannot replace the previous frame: " + os_reason(err) +
                       " (the previous frames are kept; the new ones are not written)");
    }
    moved.push_back(e.path());
  }
  std::vector<fs::path> placed;
  for (const auto& e : fs::directory_iterator(fresh)) {
    const fs::path target = dir / e.path().filename();
    if (std::rename(e.path().c_str(), target.c_str()) != 0) {
      const int err = errno;
      for (const fs::path& p : placed) {
        std::error_code gone;
        fs::remove(p, gone);
      }
      put_back();
      throw InputError(target.string() + ": cannot move the new frame into place: " + os_reason(err) +
                       " (the previous frames are kept; the new ones are not written)");
    }
    placed.push_back(target);
  }
  fs::remove_all(aside, ec);
}

/// What replace_frames would move aside must be frames: a folder (or a device, a pipe) named
/// frame_*.png is the user's, refused before any frame is rendered rather than deleted with the
/// old frames. A link is replaced as a file (the link, not what it names).
void check_frame_names(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!is_frame_name(e.path())) continue;
    std::error_code ec;
    const fs::file_type type = e.symlink_status(ec).type();
    if (type != fs::file_type::regular && type != fs::file_type::symlink)
      throw InputError(e.path().string() + ": named like a frame but " +
                       (type == fs::file_type::directory ? "a folder" : "not a file") +
                       ": `ebh render` replaces the frame_*.png files of its folder; move it away or render into "
                       "another folder");
  }
}

}  // namespace

std::string format_mm(double metres) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g mm", 1e3 * metres);
  return buf;
}

std::string find_on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return {};
  std::istringstream in(path);
  std::string d;
  while (std::getline(in, d, ':')) {
    if (d.empty()) continue;
    const fs::path p = fs::path(d) / program;
    if (::access(p.c_str(), X_OK) == 0 && fs::is_regular_file(p)) return p.string();
  }
  return {};
}

std::optional<SceneSpec> find_replay_scene(const ReplayFrames& f, std::vector<std::string>& warnings) {
  const std::vector<std::string>& overrides = f.overrides;
  std::string why;
  // The scene the replay ran (its tool, camera and overrides), whatever became of the scene file
  // and its meshes since (the output holds the meshes it drew: a moved project or a copied output
  // fell back to the scene file or name, another camera and tool); outputs written before it was
  // stored reload the file.
  if (!f.scene_yaml.empty()) {
    try {
      // Named as what it is (OUT.h5:scene_yaml) in messages and the camera's source: the scene
      // file may say otherwise by now, or be gone.
      return load_scene_spec_text(f.scene_yaml, fs::path(f.file + ":scene_yaml"), /*mesh_files_must_exist=*/false);
    } catch (const std::exception& e) {
      why = e.what();
    }
  }
  // A stored scene that does not load (an edited or damaged attribute) is said when the file or the
  // name stands in for it: their scene as it is now may not be the one the replay ran.
  const std::string stored_failed = why;
  auto standing_in = [&](SceneSpec spec, const std::string& source) {
    if (!stored_failed.empty())
      warnings.push_back(f.file + ": its scene_yaml does not load (" + clipped(stored_failed, 200) + "): rendered with " +
                         source + " as it is now");
    return spec;
  };
  if (!f.scene_file.empty()) {
    try {
      SceneSpec spec = load_scene_spec(f.scene_file, overrides);
      // An output without its scene (written before it was stored) of a scene file edited since:
      // its camera and tool may not be the replay's.
      if (stored_failed.empty() && !f.scene_file_sha256.empty() && sha256_file(f.scene_file) != f.scene_file_sha256)
        warnings.push_back(f.file + ": the scene file " + f.scene_file +
                           " changed since the replay (its SHA-256 is not the output's scene_file_sha256): rendered "
                           "with it as it is now");
      return standing_in(std::move(spec), "the scene file " + f.scene_file);
    } catch (const std::exception& e) {
      why = e.what();
    }
  }
  if (!f.scene_name.empty()) {
    try {
      return standing_in(load_scene_spec(resolve_scene_path(f.scene_name), overrides), "the scene '" + f.scene_name + "'");
    } catch (const std::exception& e) {
      if (why.empty()) why = e.what();
    }
  }
  warnings.push_back(f.file + ": the replay's scene could not be loaded (" + (why.empty() ? "no scene attributes" : why) +
                     "): framing the mesh's bounding box and drawing a default tool");
  return std::nullopt;
}

ViewCamera choose_camera(const std::string& name, const std::optional<SceneSpec>& scene, const Bounds& rest,
                         double aspect, std::string& source) {
  if (name == "scene") {
    if (scene) {
      source = "scene " + scene->file.string();
      return scene_camera(scene->camera, rest);
    }
    source = "bounding box (no scene), iso";
    return preset_camera("iso", rest, aspect);
  }
  source = "preset " + name;
  return preset_camera(name, rest, aspect, scene ? scene->camera.fov_deg : 40.0);
}

ToolModel replay_tool(const ReplayFrames& f, const std::optional<SceneSpec>& scene) {
  if (scene) return build_tool(scene->tool);
  ToolSpec spec;
  spec.kind = f.tool_kind == "forceps" ? ToolSpec::Kind::Forceps : ToolSpec::Kind::Hook;
  if (f.shaft_radius > 0 && std::isfinite(f.shaft_radius)) spec.shaft_radius = f.shaft_radius;
  return build_tool(spec);
}

std::unique_ptr<OffscreenRenderer> start_renderer(const RenderOptions& opt) {
  if (opt.width < 16 || opt.height < 16 || opt.width > 4096 || opt.height > 4096)
    throw InputError("--size: width and height must be within 16..4096 pixels, got " + std::to_string(opt.width) + "x" +
                     std::to_string(opt.height));
  if (opt.every < 1) throw InputError("--every: expected a positive frame count, got " + std::to_string(opt.every));
  if (opt.supersample < 1 || opt.supersample > 4) throw InputError("--supersample: expected 1..4");
  if (!(opt.max_displacement >= 0) || !std::isfinite(opt.max_displacement))
    throw InputError("--max-displacement: expected a non-negative length");
  // ffmpeg is told to write MP4 (-f mp4): a video named otherwise (.avi, .mkv) would be an MP4
  // under another container's name.
  if (!opt.video.empty()) {
    if (lower_extension(opt.video) != ".mp4")
      throw InputError("--video " + opt.video + ": the video is written as MP4 (H.264); name it FILE.mp4");
  }
  if (!opt.video.empty() && find_on_path("ffmpeg").empty())  // before any work
    throw InputError("--video " + opt.video + ": ffmpeg was not found on the PATH (install ffmpeg)");
  if (!have_osmesa()) throw InputError(kNoOsmesa);
  const int ss = std::max(1, std::min(opt.supersample, 8192 / std::max(opt.width, opt.height)));
  return std::make_unique<OffscreenRenderer>(opt.width, opt.height, ss);
}

void check_frames_folder(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return;
  if (!fs::is_directory(dir, ec)) throw InputError(dir + ": not a directory");
  check_frame_names(dir);
}

void check_frames_spare(const std::string& dir, const std::vector<RoleFile>& files) {
  for (const RoleFile& f : files)
    if (!f.path.empty() && is_frame_name(f.path) && in_folder(f.path, dir))
      throw InputError(dir + ": the frames would replace " + f.role + " " + f.path +
                       " (frame_*.png files in the folder are the render's): rename it or render into another folder");
}

RenderSummary render_replay(const std::string& replay, const std::string& dir, const RenderOptions& opt,
                            OffscreenRenderer* renderer) {
  // The video written among the frames under a frame's name would replace that frame (and be
  // taken for one by the next render).
  if (!opt.video.empty() && is_frame_name(opt.video) && in_folder(opt.video, dir))
    throw InputError("--video " + opt.video + ": named like a frame in " + dir +
                     ", where the render writes its frame_*.png files; name the video otherwise (video.mp4)");
  std::unique_ptr<OffscreenRenderer> own;
  if (!renderer) {
    own = start_renderer(opt);
    renderer = own.get();
  }

  const ReplayFrames frames = open_replay_frames(replay);
  RenderSummary summary;
  const std::optional<SceneSpec> scene = find_replay_scene(frames, summary.warnings);
  std::vector<RoleFile> inputs{{replay, "the replay"}};
  if (scene) inputs.push_back({scene->file.string(), "the scene file"});
  check_outputs({{opt.video, "the video"}}, inputs);
  check_frames_spare(dir, inputs);
  const Bounds rest = bounds_of(frames.virtual_rest);
  const double aspect = static_cast<double>(opt.width) / opt.height;
  summary.camera = choose_camera(opt.camera, scene, rest, aspect, summary.camera_source);
  const ToolModel tool = replay_tool(frames, scene);

  std::vector<std::size_t> chosen;
  for (std::size_t f = 0; f < frames.frame_count(); f += static_cast<std::size_t>(opt.every)) chosen.push_back(f);

  std::vector<Vec3f> q, normals;
  std::vector<std::array<float, 3>> colours;
  const bool by_disp = opt.color_by == ColorBy::Displacement;
  auto displacement = [&](std::size_t i) { return norm(static_cast<Vec3d>(q[i]) - static_cast<Vec3d>(frames.virtual_rest[i])); };
  if (by_disp) {
    summary.displacement_range = opt.max_displacement;
    if (summary.displacement_range == 0.0) {  // the largest finite displacement over the chosen frames
      for (std::size_t f : chosen) {
        frames.read_virtual_positions(f, q);
        for (std::size_t i = 0; i < q.size(); ++i) {
          const double d = displacement(i);
          if (std::isfinite(d)) summary.displacement_range = std::max(summary.displacement_range, d);
        }
      }
    }
  }
  // A range of zero (nothing moved) maps everything to the colour map's bottom.
  const double scale = summary.displacement_range > 0 ? 1.0 / summary.displacement_range : 0.0;

  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": cannot create the folder: " + ec.message());
  if (!fs::is_directory(dir)) throw InputError(dir + ": not a directory");
  check_frame_names(dir);
  // The frames are rendered into a hidden folder beside the old ones and take their place only
  // once all are written: an interrupt or a full disk keeps the previous frames.
  install_interrupt_handlers();
  const fs::path fresh = partial_path_for((fs::path(dir) / "frames").string());
  remove_stale_partials((fs::path(dir) / "frames").string());
  remove_stale_partials((fs::path(dir) / "old_frames").string());
  fs::remove_all(fresh, ec);
  fs::create_directory(fresh, ec);
  if (ec) throw InputError(dir + ": cannot write the frames: " + ec.message());
  struct RemoveFolder {
    fs::path path;
    ~RemoveFolder() {
      std::error_code e;
      fs::remove_all(path, e);
    }
  } remove_fresh{fresh};

  // Shading takes a vertex's normal from its triangles': one wound against its neighbours (an OBJ
  // exported so) would cancel them and draw a chequer. The triangles are drawn wound alike.
  std::vector<Tri> triangles = frames.triangles;
  if (const std::size_t turned = orient_consistently(triangles); turned > 0)
    summary.warnings.push_back(std::to_string(turned) + " of the virtual mesh's " + std::to_string(triangles.size()) +
                               " triangles are wound against their neighbours: drawn turned (contact does not "
                               "depend on the winding)");
  const RenderStyle style;
  std::vector<std::array<int, 3>> kept;
  std::size_t broken_frames = 0, blank_frames = 0;  // frames with non-finite positions; frames showing no tissue
  // The bar shows a frame's time in the replayed window (t / t_end), not in the frames' span: one
  // frame at t = 0 of a 2 s replay is at its start, not its end.
  const double t0 = frames.t.front();
  const double t1 = std::isfinite(frames.replay_s) ? std::max(frames.t.back(), frames.replay_s) : frames.t.back();
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (interrupted())
      throw InputError(dir + ": interrupted after " + std::to_string(k) + " frames; the previous frames are kept");
    const std::size_t f = chosen[k];
    frames.read_virtual_positions(f, q);
    const bool dropped = finite_triangles(q, triangles, kept) > 0;
    broken_frames += dropped;
    vertex_normals(q, dropped ? kept : triangles, normals);
    if (by_disp) {
      colours.resize(q.size());
      for (std::size_t i = 0; i < q.size(); ++i) colours[i] = colormap(displacement(i) * scale);
    }
    const auto& [physical, virt] = frames.poses[f];
    const double jaw = std::isfinite(frames.jaw[f]) ? std::clamp(frames.jaw[f], 0.0, 1.0) : 1.0;
    TriangleSoup physical_mesh, virtual_mesh;
    if (finite_pose(physical)) physical_mesh = tessellate(pose_tool(tool, physical, jaw));
    if (finite_pose(virt)) virtual_mesh = tessellate(pose_tool(tool, virt, jaw));

    FrameGeometry g;
    g.tissue = &q;
    g.tissue_normals = &normals;
    g.triangles = dropped ? &kept : &triangles;
    g.tissue_colors = by_disp ? &colours : nullptr;
    g.virtual_tool = &virtual_mesh;
    g.physical_tool = &physical_mesh;
    Image img = renderer->render(g, summary.camera, style);
    blank_frames += !renderer->tissue_drawn();
    if (by_disp) draw_legend(img);
    if (opt.time_bar) draw_time_bar(img, t1 > t0 ? (frames.t[f] - t0) / (t1 - t0) : 1.0);

    char name[32], title[160];
    std::snprintf(name, sizeof name, "frame_%05zu.png", k);
    std::snprintf(title, sizeof title, "%s: frame %zu of %zu, t = %.4f s", frames.scene_name.c_str(), f,
                  frames.frame_count(), frames.t[f]);
    std::vector<std::pair<std::string, std::string>> text = {{"Title", title},
                                                             {"Software", std::string("ebh ") + kVersion}};
    if (const std::string gl = renderer->renderer_name(); !gl.empty()) text.push_back({"Source", "OSMesa " + gl});
    if (by_disp)
      text.push_back({"Comment", "tissue colour = displacement from rest, 0 (blue, bottom of the bar) to " +
                                     format_mm(summary.displacement_range) + " (red, top)"});
    try {
      write_png((fresh / name).string(), img, text);
    } catch (const InputError& e) {  // named by the frame's final name, not the hidden folder's
      const std::string why = e.what(), hidden = (fresh / name).string();
      throw InputError((fs::path(dir) / name).string() + (why.rfind(hidden, 0) == 0 ? why.substr(hidden.size()) : ": " + why) +
                       "; the previous frames are kept");
    }
    summary.files.push_back((fs::path(dir) / name).string());
  }
  if (interrupted())
    throw InputError(dir + ": interrupted after " + std::to_string(chosen.size()) + " frames; the previous frames are kept");
  replace_frames(dir, fresh);
  if (broken_frames > 0)
    summary.warnings.push_back(replay + ": " + std::to_string(broken_frames) +
                               " frames have non-finite virtual-mesh positions (the simulation blew up); their "
                               "triangles were left out");
  // The frames are what was asked, but a camera that sees none of the tissue (looking away, too
  // far, too close, a near plane past the mesh) is most likely a mistake: said once, not per frame.
  if (blank_frames > 0)
    summary.warnings.push_back(replay + ": " + std::to_string(blank_frames) + " of " + std::to_string(chosen.size()) +
                               " frames show no tissue: the camera (" + summary.camera_source +
                               ") sees none of the virtual mesh; check camera.eye, camera.target and camera.fov_deg");
  if (!opt.video.empty()) {
    run_ffmpeg(dir, opt.video, frame_rate(frames, opt.every));
    summary.video = opt.video;
  }
  return summary;
}

}  // namespace ebh
