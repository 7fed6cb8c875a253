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
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <thread>

#include "core/error.hpp"
#include "core/file_names.hpp"
#include "core/number_text.hpp"
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

/// How far from the virtual mesh's centre a vertex may lie, in multiples of the rest vertices'
/// median distance from it, and still be tissue: a mesh's farthest vertex lies a few times that
/// distance out (a long, thin organ's ends some 2-5 times), and tissue a tool drags stays within
/// the mesh's size. Beyond it a position is a damaged or edited value or a run that blew up (1e30
/// m stays finite in float32): drawn, it stretched the camera (the rest mesh's bounds) and the
/// displacement colours (their largest value) until the tissue was a dot of one colour.
constexpr double kFarFromMeshFactor = 1000;

/// Where the virtual mesh's vertices may plausibly lie: within `limit` of `centre` (the per-axis
/// median of the finite rest vertices; limit kFarFromMeshFactor times their median distance from
/// it, at least a micrometre; infinite when no rest vertex is finite).
struct MeshReach {
  Vec3d centre{};
  double limit = std::numeric_limits<double>::infinity();
  double median = 0;  ///< the rest vertices' median distance from the centre, m
};

double median_of(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

bool finite3(const Vec3f& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

MeshReach mesh_reach(const std::vector<Vec3f>& rest) {
  std::vector<double> xs, ys, zs;
  for (const Vec3f& p : rest)
    if (finite3(p)) {
      xs.push_back(p.x);
      ys.push_back(p.y);
      zs.push_back(p.z);
    }
  MeshReach r;
  if (xs.empty()) return r;
  r.centre = {median_of(xs), median_of(ys), median_of(zs)};
  std::vector<double> d;
  for (const Vec3f& p : rest)
    if (finite3(p)) d.push_back(norm(static_cast<Vec3d>(p) - r.centre));
  r.median = median_of(d);
  r.limit = kFarFromMeshFactor * std::max(r.median, 1e-6);
  return r;
}

/// Why a vertex is left out: 0 drawn, 1 not finite, 2 far off the mesh (MeshReach).
int vertex_problem(const Vec3f& p, const MeshReach& reach) {
  if (!finite3(p)) return 1;
  return norm(static_cast<Vec3d>(p) - reach.centre) > reach.limit ? 2 : 0;
}

std::string point_text(const Vec3f& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", static_cast<double>(p.x), static_cast<double>(p.y),
                static_cast<double>(p.z));
  return buf;
}

std::string more_text(std::size_t count, const char* what) {
  return count > 1 ? ", and " + std::to_string(count - 1) + " more " + what : std::string();
}

/// "1 frame holds", "2 frames hold": a count with its noun and verb in number.
std::string counted(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

/// The first of a kind of left-out data, and how many (warned of once the frames are drawn).
struct LeftOutData {
  std::size_t count = 0;  ///< frames (or vertices) with one
  std::string first;      ///< where the first is, "frame 2, vertex 9 at (1e+30, 0, 0) m"
  void add(const std::string& where) {
    if (count++ == 0) first = where;
  }
};

/// Drops triangles with a vertex that is not drawn (`problem` nonzero: not finite, a blown-up
/// run, or far off the mesh), so they cannot smear across the image. Returns how many were dropped.
std::size_t drawn_triangles(const std::vector<char>& problem, const std::vector<std::array<int, 3>>& all,
                            std::vector<std::array<int, 3>>& out) {
  out.clear();
  if (std::all_of(problem.begin(), problem.end(), [](char c) { return c == 0; })) return 0;
  for (const auto& t : all)
    if (!problem[t[0]] && !problem[t[1]] && !problem[t[2]]) out.push_back(t);
  return all.size() - out.size();
}

/// A tool pose to draw: a finite position and a finite, non-zero quaternion (open_replay_frames
/// keeps a stored one that is neither, to be left out here).
bool drawable_pose(const ToolPose& p) {
  const Quatd& q = p.orientation;
  const double n = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
  return std::isfinite(p.position.x + p.position.y + p.position.z) && std::isfinite(n) && n > 0;
}

std::string pose_text(const ToolPose& p) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "at (%g, %g, %g) m, quaternion (%g, %g, %g, %g)", p.position.x, p.position.y,
                p.position.z, p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z);
  return buf;
}

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
  // The rest mesh frames the camera and is what displacements are measured from: a vertex that is
  // not finite or lies far off the mesh (a damaged or edited file) is left out of both, said.
  const MeshReach reach = mesh_reach(frames.virtual_rest);
  std::vector<char> rest_problem(frames.virtual_vertices());
  std::vector<Vec3f> rest_drawn;
  LeftOutData rest_nonfinite, rest_far;
  for (std::size_t i = 0; i < rest_problem.size(); ++i) {
    const Vec3f& p = frames.virtual_rest[i];
    rest_problem[i] = static_cast<char>(vertex_problem(p, reach));
    if (rest_problem[i] == 0)
      rest_drawn.push_back(p);
    else
      (rest_problem[i] == 1 ? rest_nonfinite : rest_far).add("vertex " + std::to_string(i) + " at " + point_text(p) + " m");
  }
  auto without = [](std::size_t n) {
    return std::string(": the camera frames the mesh and the displacement colours are measured without ") +
           (n == 1 ? "it" : "them");
  };
  if (rest_nonfinite.count > 0)
    summary.warnings.push_back(replay + ": /mesh/virtual_rest: " + rest_nonfinite.first + " is not finite" +
                               more_text(rest_nonfinite.count, "vertices") + without(rest_nonfinite.count));
  if (rest_far.count > 0)
    summary.warnings.push_back(replay + ": /mesh/virtual_rest: " + rest_far.first + " lies more than " +
                               shown_number(kFarFromMeshFactor) + " times the mesh's median distance from its centre (" +
                               format_mm(reach.median) + ")" + more_text(rest_far.count, "vertices") +
                               without(rest_far.count));
  const Bounds rest = bounds_of(rest_drawn);
  const double aspect = static_cast<double>(opt.width) / opt.height;
  summary.camera = choose_camera(opt.camera, scene, rest, aspect, summary.camera_source);
  const ToolModel tool = replay_tool(frames, scene);

  std::vector<std::size_t> chosen;
  for (std::size_t f = 0; f < frames.frame_count(); f += static_cast<std::size_t>(opt.every)) chosen.push_back(f);

  std::vector<Vec3f> q, normals;
  std::vector<std::array<float, 3>> colours;
  const bool by_disp = opt.color_by == ColorBy::Displacement;
  // NaN where a vertex or its rest position is not drawn: left out of the range, and of the frame.
  auto displacement = [&](std::size_t i) {
    return rest_problem[i] != 0 || vertex_problem(q[i], reach) != 0
               ? std::numeric_limits<double>::quiet_NaN()
               : norm(static_cast<Vec3d>(q[i]) - static_cast<Vec3d>(frames.virtual_rest[i]));
  };
  if (by_disp) {
    summary.displacement_range = opt.max_displacement;
    if (summary.displacement_range == 0.0) {  // the largest displacement drawn over the chosen frames
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
  std::vector<char> problem;
  std::size_t blank_frames = 0;  // frames showing no tissue
  // Frames with positions not finite, with positions far off the mesh; tool poses that are none
  LeftOutData nonfinite_frames, far_frames, bad_poses;
  // The bar shows a frame's time in the replayed window (t / t_end), not in the frames' span: one
  // frame at t = 0 of a 2 s replay is at its start, not its end.
  const double t0 = frames.t.front();
  const double t1 = std::isfinite(frames.replay_s) ? std::max(frames.t.back(), frames.replay_s) : frames.t.back();
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (interrupted())
      throw InputError(dir + ": interrupted after " + std::to_string(k) + " frames; the previous frames are kept");
    const std::size_t f = chosen[k];
    frames.read_virtual_positions(f, q);
    problem.assign(q.size(), 0);
    std::size_t first_nonfinite = q.size(), first_far = q.size();
    for (std::size_t i = 0; i < q.size(); ++i) {
      problem[i] = static_cast<char>(vertex_problem(q[i], reach));
      std::size_t& first = problem[i] == 1 ? first_nonfinite : first_far;
      if (problem[i] != 0 && first == q.size()) first = i;
    }
    const std::string in_frame = "frame " + std::to_string(f) + ", vertex ";
    if (first_nonfinite < q.size()) nonfinite_frames.add(in_frame + std::to_string(first_nonfinite));
    if (first_far < q.size())
      far_frames.add(in_frame + std::to_string(first_far) + " at " + point_text(q[first_far]) + " m");
    const bool dropped = drawn_triangles(problem, triangles, kept) > 0;
    vertex_normals(q, dropped ? kept : triangles, normals);
    if (by_disp) {
      colours.resize(q.size());
      for (std::size_t i = 0; i < q.size(); ++i) colours[i] = colormap(displacement(i) * scale);
    }
    const auto& [physical, virt] = frames.poses[f];
    const double jaw = std::isfinite(frames.jaw[f]) ? std::clamp(frames.jaw[f], 0.0, 1.0) : 1.0;
    TriangleSoup physical_mesh, virtual_mesh;
    if (drawable_pose(physical)) physical_mesh = tessellate(pose_tool(tool, physical, jaw));
    if (drawable_pose(virt)) virtual_mesh = tessellate(pose_tool(tool, virt, jaw));
    for (int row = 0; row < 2; ++row)
      if (const ToolPose& p = row == 0 ? physical : virt; !drawable_pose(p))
        bad_poses.add("frame " + std::to_string(f) + ", row " + std::to_string(row) +
                      (row == 0 ? " (the physical tool) " : " (the virtual tool) ") + pose_text(p));

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
  if (nonfinite_frames.count > 0)
    summary.warnings.push_back(replay + ": /frames/virtual_positions: " +
                               counted(nonfinite_frames.count, "frame holds", "frames hold") +
                               " positions that are not finite (the simulation blew up; the first: " +
                               nonfinite_frames.first + "): their triangles were left out");
  if (far_frames.count > 0)
    summary.warnings.push_back(replay + ": /frames/virtual_positions: " +
                               counted(far_frames.count, "frame holds", "frames hold") + " positions more than " +
                               shown_number(kFarFromMeshFactor) +
                               " times the mesh's median distance from its centre (a damaged file or a run that blew "
                               "up; the first: " + far_frames.first +
                               "): their triangles were left out, and the displacement colours measured without them");
  if (bad_poses.count > 0)
    summary.warnings.push_back(replay + ": /frames/tool_poses: " + counted(bad_poses.count, "row holds", "rows hold") +
                               " no pose (a value that is not finite, or a zero quaternion; the first: " +
                               bad_poses.first + "): the tool is left out of the frame where its pose is");
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
