// ebh replay SCENE RECORDING -o OUT.h5: the toolkit's main job (docs/MODEL.md "Between the two rates", docs/FORMATS.md "Replay output").
#include <unistd.h>

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "command.hpp"
#include "core/error.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "tool/newton.hpp"
#include "mesh/boundary.hpp"
#include "metrics/force_metrics.hpp"
#include "options.hpp"
#include "render/render_replay.hpp"
#include "render/xdmf.hpp"
#include "replay_common.hpp"
#include "schedule/replay_output.hpp"
#include "schedule/scheduler.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace ebh::cli {
namespace {

struct ReplayArgs {
  std::string scene, recording, out, mode = "async", backend = "cpu";
  std::optional<double> haptic_hz, physical_hz, frames_hz, duration;
  double start = 0;
  std::vector<std::string> overrides;
  std::string render_dir;
  ReplayTransformOptions transforms;
  int haptic_threads = 0;
  double progress_every = 60;  ///< s of wall time between progress lines off a terminal
  bool allow_outside = false, quiet = false;
};

/// Progress on stderr: a bar on a terminal; elsewhere (nohup, a Slurm log, a pipe) one line every
/// `line_seconds` of wall time (0: none), so a long replay says how far it is without filling a log.
class Progress : public ReplayObserver {
 public:
  Progress(std::int64_t ticks, bool enabled, bool terminal, double line_seconds)
      : ticks_(ticks), bar_(enabled && terminal), line_seconds_(enabled && !terminal ? line_seconds : 0),
        t0_(Clock::now()), last_(t0_) {}
  void on_tick(const World& w, const HapticSide& h, double t) override {
    if ((!bar_ && line_seconds_ <= 0) || (h.tick % 50) != 0) return;
    const auto now = Clock::now();
    const double since_last = std::chrono::duration<double>(now - last_).count();
    if (since_last < (bar_ ? 0.1 : line_seconds_)) return;
    last_ = now;
    const double frac = static_cast<double>(h.tick) / static_cast<double>(ticks_);
    const double wall = std::chrono::duration<double>(now - t0_).count();
    const double done_s = t + w.h_haptic, rate = wall > 0 ? done_s / wall : 0.0;
    if (bar_) {
      const int width = 30, done = static_cast<int>(frac * width);
      std::fprintf(stderr, "\r[%.*s%*s] %3.0f%%  t=%6.2f s  %5.2fx real time  |F|=%5.2f N ", done,
                   "##############################", width - done, "", 100 * frac, done_s, rate, norm(h.output.force));
    } else {
      std::fprintf(stderr, "ebh: progress: %.2f of %.2f s (%.0f%%) after %.0f s, %.2fx real time, |F| = %.2f N\n",
                   done_s, static_cast<double>(ticks_) * w.h_haptic, 100 * frac, wall, rate, norm(h.output.force));
    }
    std::fflush(stderr);
  }
  void finish() {
    if (bar_) std::fprintf(stderr, "\r%*s\r", 90, "");
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::int64_t ticks_;
  bool bar_;
  double line_seconds_;
  Clock::time_point t0_, last_;
};

/// Forwards every event to the writer and the progress bar.
class Tee : public ReplayObserver {
 public:
  Tee(ReplayObserver& a, ReplayObserver& b) : a_(a), b_(b) {}
  void on_tick(const World& w, const HapticSide& h, double t) override { a_.on_tick(w, h, t); b_.on_tick(w, h, t); }
  void on_step(const World& w, const PhysicalSide& p, double t) override { a_.on_step(w, p, t); b_.on_step(w, p, t); }
  void on_frame(const World& w, const HapticSide& h, double t) override { a_.on_frame(w, h, t); b_.on_frame(w, h, t); }
  bool should_stop() override { return a_.should_stop() || b_.should_stop(); }

 private:
  ReplayObserver& a_;
  ReplayObserver& b_;
};

/// A replay ready to run: its inputs loaded, its options and its output writer (created last).
struct PreparedReplay {
  LoadedReplay in;
  ReplayOptions opt;
  ReplayMetadata meta;
  std::int64_t ticks = 0;
  std::unique_ptr<ReplayWriter> writer;
};

/// The scene's warnings, each after `where`, with its tool's stiffnesses' (this replay's: replays
/// that differ only in them share a scene); outside lockstep mode also the one about k_s above
/// k_svc, whose instability is the step's beside the ticks and which recommends lockstep.
void print_scene_warnings(const Scene& scene, Mode mode, const std::string& where) {
  std::vector<std::string> warnings = scene.warnings;
  for (std::string& w : tool_stiffness_warnings(scene.spec)) warnings.push_back(std::move(w));
  if (mode != Mode::Lockstep)
    if (std::string w = edges_outweigh_coupling_warning(scene.spec); !w.empty()) warnings.push_back(std::move(w));
  for (const std::string& w : warnings)
    std::fprintf(stderr, "ebh: warning: %s%s\n", where.c_str(), ebh::escape_unprintable(w).c_str());
}

/// The world's rates, window and frames checked, the output's metadata; `in` already loaded.
void prepare_replay(const ReplayArgs& a, PreparedReplay& p) {
  const Mode mode = parse_mode(a.mode);
  const World& world = *p.in.world;
  const double duration =
      replay_window(a.start, a.duration, p.in.recording.duration(), world.h_haptic, p.in.recording_path, "--start",
                    "--duration");
  if (a.duration && *a.duration > duration)
    std::fprintf(stderr, "ebh: warning: %s: the recording ends %s s after --start; replaying those, not --duration's %s s\n",
                 p.in.recording_path.c_str(), format_number(duration).c_str(), format_number(*a.duration).c_str());
  // A window that starts with the tool in the tissue, said before the replay (which can be stopped
  // and started earlier), against the tissue where the replay starts (settled under gravity). From
  // the recording's first sample start_warning says it after the replay, as a misplaced log.
  if (std::string w = window_start_warning(p.in, a.start, "--start"); !w.empty()) p.in.warnings.push_back(std::move(w));
  ReplayOptions& opt = p.opt;
  opt.mode = mode;
  opt.start = a.start;
  opt.duration = a.duration.value_or(0);  // 0: the rest of the recording
  opt.haptic_threads = a.haptic_threads;
  // The split of the OpenMP threads between the two sides: what --haptic-threads asked may not fit.
  const int total_threads = std::max(1, omp_get_max_threads());
  if (a.haptic_threads > 0 && mode == Mode::Lockstep)
    std::fprintf(stderr, "ebh: warning: --haptic-threads %d: not used in lockstep, where the ticks and the physical "
                 "step take turns, each with all %d OpenMP threads (OMP_NUM_THREADS sets them)\n",
                 a.haptic_threads, total_threads);
  if (a.haptic_threads > 0 && mode != Mode::Lockstep)
    if (const ThreadSplit split = split_threads(mode, a.haptic_threads); split.haptic != a.haptic_threads)
      std::fprintf(stderr, "ebh: warning: --haptic-threads %d: of the %d OpenMP threads (OMP_NUM_THREADS, else the "
                   "cores) the physical step keeps at least one, so the haptic side runs %d; raise OMP_NUM_THREADS "
                   "for more\n", a.haptic_threads, total_threads, split.haptic);
  // More threads than the machine runs at once take turns: the ticks and the step slow down.
  // The cores are those the process may run on (taskset, a job's cpuset), not the machine's.
  if (const unsigned cores = usable_cores(); cores > 0 && total_threads > static_cast<int>(cores)) {
    const char* policy = std::getenv("OMP_WAIT_POLICY");
    const bool passive = policy && (std::string(policy) == "passive" || std::string(policy) == "PASSIVE");
    std::fprintf(stderr, "ebh: warning: %d OpenMP threads (OMP_NUM_THREADS) are more than the %u core%s this process "
                 "runs on: they take turns%s; set OMP_NUM_THREADS to at most %u%s\n",
                 total_threads, cores, cores == 1 ? "" : "s",
                 passive ? "" : ", and while one waits at a barrier it spins on a core another needs (3 threads on 2 "
                                "cores ran 15-60 times slower)",
                 cores, passive ? "" : ", or OMP_WAIT_POLICY=passive");
  }
  // 30 a second by default, or a snapshot every tick where the haptic rate is below that.
  const double default_frames_hz = std::min(30.0, 1.0 / world.h_haptic);
  opt.frames_hz = a.frames_hz.value_or(world.scene.spec.stages.frames ? default_frames_hz : 0.0);
  if (!a.render_dir.empty() && a.frames_hz && *a.frames_hz <= 0)
    throw InputError("--render " + a.render_dir + ": renders the mesh snapshots, and --frames-hz " +
                     format_number(*a.frames_hz) + " asks for none (leave --frames-hz out for 30 a second)");
  if (!a.render_dir.empty() && opt.frames_hz <= 0) opt.frames_hz = default_frames_hz;  // --render needs frames
  if (opt.frames_hz * world.h_haptic > 1 + 1e-9)
    throw InputError("--frames-hz " + format_number(opt.frames_hz) + ": more snapshots than haptic ticks (" +
                     format_number(1.0 / world.h_haptic) + " Hz)");
  if (opt.frames_hz > 0) check_name_length(xdmf_path_for(a.out));  // the snapshots' index beside the output
  check_replay_size(world, duration, opt.frames_hz, p.in.recording_path, a.out);
  p.ticks = tick_count(world, duration);
  // In async mode the first physical step's result reaches the haptic side one physical period
  // after it starts (tick N): a window no longer than that renders a tissue that never moved.
  if (mode == Mode::Async && p.ticks <= world.ticks_per_step)
    p.in.warnings.push_back(
        a.out + ": the haptic side never saw a physical result: the window's " + std::to_string(p.ticks) +
        " ticks end before the first physical step's result arrives at tick " + std::to_string(world.ticks_per_step) +
        " (" + format_number(world.h_physical) + " s, one physical period, async mode), so the tissue stayed at its "
        "start; raise the physical rate (--physical-hz, time.physical_hz), lengthen --duration or replay --mode lockstep");
  ReplayMetadata& meta = p.meta;
  meta.recording = p.in.recording_path;
  meta.start = opt.start;
  meta.duration = a.duration ? duration : 0.0;  // what was replayed: a --duration past the end is cut to it
  meta.frames_hz = opt.frames_hz;
  meta.mode = mode_name(mode);
  meta.backend = a.backend;
  meta.device = cpu_description();
  meta.threads = split_threads(mode, opt.haptic_threads);
#if EBH_HAVE_CUDA
  if (world.backend == Backend::Cuda) meta.device = cuda_device_description() + " + " + meta.device;
#endif
  meta.overrides = a.overrides;
  meta.transforms = a.transforms;
  meta.applied = p.in.transforms;
}

/// After the replay: its output committed (unless it was stopped), then its warnings and summary.
void finish_replay(const ReplayArgs& a, PreparedReplay& p, const ReplaySummary& s,
                   OffscreenRenderer* renderer = nullptr) {
  const World& world = *p.in.world;
  ReplayWriter& writer = *p.writer;
  // How far it got: of a long replay, the time lost.
  if (s.stopped) {
    char far[160];
    std::snprintf(far, sizeof far, "after %.3g of %.3g s", s.virtual_s, replayed_seconds(p.ticks, world.h_haptic));
    throw InputError(a.out + ": interrupted " + far + "; no output written");
  }
  // --render: the frames are rendered from the finished output before it replaces the previous one,
  // and take the previous frames' place just before it does.
  writer.finish(s);
  if (renderer) render_after_replay(writer.temp_path(), a.out, a.render_dir, *renderer);
  writer.publish();
  // A time of the replay (its /haptic/t and /physical/t count from the window's start), and where
  // that is in the recording when the window starts later.
  const auto at = [&a](double t) { return replay_time_text(t, a.start); };
  // A force that fell while the tool pressed on: it went through the tissue (with vertex contact,
  // between the virtual vertices) or slipped off it.
  const auto collapse = find_force_collapse(
      writer.tick_times(), [&writer](std::size_t n) { return writer.force_at(n); },
      [&writer](std::size_t n) { return writer.device_position_at(n); }, writer.contacts(), writer.grasped(),
      writer.jaw(), 1.0 / world.h_haptic);
  if (collapse)
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(),
                 collapse_warning(*collapse, world.scene.spec.contact == ContactModel::Vertices, a.start).c_str());
  if (const auto held = find_force_saturation(writer.tick_times(), writer.force_clamped(), 1.0 / world.h_haptic))
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), saturation_warning(*held, a.start).c_str());
  if (const auto relaxed = find_held_relaxation(
          writer.tick_times(), [&writer](std::size_t n) { return writer.force_at(n); },
          [&writer](std::size_t n) { return writer.device_position_at(n); }, writer.contacts(), writer.grasped()))
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), held_relaxation_warning(*relaxed, a.start).c_str());
  // Energy the rendering fed the user (the passivity observer below 0).
  if (const std::string w = passivity_warning(passivity_energy(
          writer.tick_times(), [&writer](std::size_t n) { return writer.force_at(n); },
          [&writer](std::size_t n) { return writer.device_position_at(n); }, 0,
          writer.tick_times().empty() ? 0 : writer.tick_times().size() - 1),
          world.scene.spec.contact == ContactModel::Vertices);
      !w.empty())
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), w.c_str());
  index_replay_frames(a.out);
  std::string contact = contact_warning(static_cast<std::size_t>(writer.contact_ticks()),
                                        static_cast<std::size_t>(s.ticks));
  // No contact although the device went into the tissue: the tool slipped between the virtual
  // vertices (a tool thinner than their spacing), which vertex contact cannot feel.
  // With surface contact, or through an opening of an OBJ virtual mesh, the tool's tip can also go in
  // unfelt: the hint names which.
  // The tip is checked against the mesh where the replay found it: settled under gravity
  // (stages.settle), not the rest shape an organ sagged away from (a soft block's rest shape put the
  // tip "inside" tissue it never reached).
  TetMesh start_mesh;
  if (writer.contact_ticks() == 0) {
    start_mesh = world.scene.physical;
    if (world.initial_physical.x.size() == start_mesh.vertices.size()) start_mesh.vertices = world.initial_physical.x;
  }
  if (!start_mesh.tets.empty()) {
    if (const auto t = tip_inside_mesh(p.in.recording, start_mesh, a.start, a.duration.value_or(0), &world.tool)) {
      const long long open = surface_edges(world.scene.virtual_surface.triangles).open;
      const bool vertices = world.scene.spec.contact == ContactModel::Vertices;
      char line[480];
      if (open > 0)
        std::snprintf(line, sizeof line,
                      ", yet the tool's tip went inside the physical mesh (at the recording's t = %.3f s): it passed "
                      "through an opening of the virtual mesh%s unfelt (mesh.virtual is not closed: %lld of its edges "
                      "belong to one face only)", *t, vertices ? ", or between its vertices," : "", open);
      else if (vertices)
        std::snprintf(line, sizeof line,
                      ", yet the tool's tip went inside the physical mesh (at the recording's t = %.3f s): it passed "
                      "between the virtual vertices unfelt (contact: vertices; `--set contact=surface` feels it, "
                      "docs/MODEL.md)", *t);
      else if (world.scene.spec.virtual_mesh)
        std::snprintf(line, sizeof line,
                      ", yet the tool's tip went inside the physical mesh (at the recording's t = %.3f s): the virtual "
                      "mesh is not where the physical mesh is there (mesh.virtual)", *t);
      else  // the virtual mesh is the physical mesh's boundary: it is where the tissue is
        std::snprintf(line, sizeof line,
                      ", yet the tool's tip went inside the physical mesh where the replay started (at the recording's "
                      "t = %.3f s): the tissue moved away from it (a part sinking, or swinging on its pins), or the "
                      "virtual tool did not follow the device (stiffness.k_vcs, stiffness.k_con)", *t);
      contact += line;
    } else if (a.start == 0 && !a.duration && p.in.recording.source == "device") {
      // A whole device log that never met the tissue passes it by: a placement from the import.
      contact += ": the path passes the tissue by; a tool tip offset (--tool-transform) or a world transform "
                 "(--transform) that misplaces it? (docs/OWN_DATA.md, \"What the warnings mean\")";
    }
  }
  if (!contact.empty()) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), contact.c_str());
  // A device faster than the virtual tool's Newton steps reach in a tick (a low haptic rate,
  // tool.max_step in the wrong unit): the tool lags and the force grows with the lag, to the limit
  // with nothing touched, where it is the coupling's stretch.
  if (writer.outpaced_ticks() == 0 && writer.free_clamped_ticks() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld ticks rendered the force limit (%g N) with no contact: the virtual "
                 "tool was held far from the device, and that force is the coupling's stretch, not tissue\n",
                 a.out.c_str(), static_cast<long long>(writer.free_clamped_ticks()), static_cast<long long>(s.ticks),
                 world.scene.spec.tool.force_limit);
  else if (writer.outpaced_ticks() > 0) {
    const double reach = writer.tool_reach();
    char clamped[160] = "";
    if (writer.free_clamped_ticks() > 0)
      std::snprintf(clamped, sizeof clamped, "; %lld ticks rendered the force limit (%g N) with no contact: the "
                    "coupling's stretch, not tissue", static_cast<long long>(writer.free_clamped_ticks()),
                    world.scene.spec.tool.force_limit);
    std::fprintf(stderr,
                 "ebh: warning: %s: the device moved farther in a tick than the virtual tool can follow in %lld of "
                 "%lld ticks (up to %.3g mm, against %.3g mm a tick: tool.max_step x its Newton steps a tick, %.3g "
                 "mm/s at %g Hz), so the tool lags it and the force grows with the lag%s; raise tool.max_step "
                 "(tool.unit %s) or the haptic rate\n",
                 a.out.c_str(), static_cast<long long>(writer.outpaced_ticks()), static_cast<long long>(s.ticks),
                 writer.max_device_step() * 1e3, reach * 1e3, reach * 1e3 / world.h_haptic, 1.0 / world.h_haptic,
                 clamped, world.scene.spec.tool.unit_name.c_str());
  }
  // The same for turns (a spin, a brisk wrist roll): the torque grows with the lag, stiffness.k_vct
  // a radian, and turns round past half a turn, with nothing touched.
  char torque_clamped[200] = "";
  if (writer.free_torque_clamped_ticks() > 0)
    std::snprintf(torque_clamped, sizeof torque_clamped,
                  "%lld of %lld ticks rendered the torque limit (%g N m) with no contact: the virtual tool was held "
                  "turned from the device, and that torque is the coupling's twist, not tissue",
                  static_cast<long long>(writer.free_torque_clamped_ticks()), static_cast<long long>(s.ticks),
                  world.scene.spec.tool.torque_limit);
  if (writer.outturned_ticks() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: the device turned farther in a tick than the virtual tool can follow in %lld of "
                 "%lld ticks (up to %.3g degrees, against %.3g degrees a tick: tool.max_step_rotation_deg x its Newton "
                 "steps a tick, %.3g rad/s at %g Hz), so the tool lags it and the torque grows with the lag "
                 "(stiffness.k_vct %g N m a radian)%s%s; raise tool.max_step_rotation_deg or the haptic rate\n",
                 a.out.c_str(), static_cast<long long>(writer.outturned_ticks()), static_cast<long long>(s.ticks),
                 writer.max_device_turn() * 180 / std::numbers::pi, writer.tool_turn_reach() * 180 / std::numbers::pi,
                 writer.tool_turn_reach() / world.h_haptic, 1.0 / world.h_haptic, world.scene.spec.stiffness.k_vct,
                 torque_clamped[0] ? "; " : "", torque_clamped);
  else if (torque_clamped[0])
    std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), torque_clamped);
  if (writer.recovered_steps() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps did not converge and were redone with the direct "
                 "solve (/physical/recovered; `ebh scene info` shows the mesh's worst tets); the first factorised the "
                 "physical mesh's matrix in %.3g s, counted in its /timing/physical_step_s\n",
                 a.out.c_str(), static_cast<long long>(writer.recovered_steps()), static_cast<long long>(s.steps),
                 writer.recovery_factorize_s());
  if (writer.capped_steps() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps ran solver.physical_max_iterations (%d) and still left "
                 "more than solver.physical_tolerance (%g mesh weights) unbalanced (/physical/residual)\n",
                 a.out.c_str(), static_cast<long long>(writer.capped_steps()), static_cast<long long>(s.steps),
                 world.physical_params.max_iterations, world.physical_params.tolerance);
  if (writer.stalled_steps() > 0) {
    // On the device a stall within a few times the mesh's float32 floor is round-off, not the mesh;
    // a mesh far from the origin against its size loses its positions' bits in double too.
    char why[400];
    std::string far;  // named first, where it applies
    if (float32_round_off(world, writer.max_stalled())) {
      std::snprintf(why, sizeof why,
                    "float32's round-off on this mesh (%.2g mesh weights at rest, `ebh scene info`; the device's "
                    "steps stall at a few times it) lies above the tolerance, so each ran until it stalled; "
                    "solver.physical_tolerance at about %.2g saves those iterations, or --backend cpu",
                    world.float32_floor, writer.max_stalled());
    } else {
      far = double_round_off_cause(world.scene.spec, world.physical_mesh);
      if (!far.empty()) far += "; else ";
      std::snprintf(why, sizeof why,
                    "the iteration makes no headway on this mesh (`ebh scene info` prints its rate and worst tets) "
                    "or with these stiffnesses (one far above the others, stiffness.k_det or k_vol, slows every "
                    "method), and those steps are not converged; solver.method: direct (CPU backend) balances each step "
                    "further");
    }
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps stopped when their iterations stalled, with up to "
                 "%.3g mesh weights unbalanced (more than %g times solver.physical_tolerance; the first at %s; "
                 "/physical/residual): %s%s\n",
                 a.out.c_str(), static_cast<long long>(writer.stalled_steps()), static_cast<long long>(s.steps),
                 writer.max_stalled(), kStalledResidualFactor, at(writer.first_stalled_t()).c_str(), far.c_str(), why);
  }
  if (writer.short_steps() > 0) {
    const PhysicalStepParams& params = world.physical_params;
    const bool direct = params.method == SolverSpec::Method::Direct;
    char against[96], rule[160];
    if (params.tolerance > 0)
      std::snprintf(against, sizeof against, "solver.physical_tolerance");
    else
      std::snprintf(against, sizeof against, "the default solver.physical_tolerance, %g", short_step_yardstick(params));
    if (direct)
      std::snprintf(rule, sizeof rule, "let an iterative method's stopping rule run them (chebyshev)");
    else
      std::snprintf(rule, sizeof rule, "let the stopping rule run the steps that need more (solver.physical_tolerance: %g)",
                    short_step_yardstick(params));
    // On the device a fixed count's residual within a few times the mesh's float32 floor is
    // round-off (a refined tube: 0.041 mesh weights), which no iteration count lowers.
    char fix[400];
    if (float32_round_off(world, writer.max_short()))
      std::snprintf(fix, sizeof fix,
                    "it is this mesh's float32 round-off on the device (%.2g mesh weights at rest, `ebh scene info`; its "
                    "steps stall at a few times it), which no iteration count lowers: replay with --backend cpu",
                    world.float32_floor);
    else
      std::snprintf(fix, sizeof fix,
                    "raise solver.physical_iterations (a grasp or a hard press needs more, and so does a stiffness far "
                    "above the others), or %s", rule);
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps left up to %.3g mesh weights unbalanced after their "
                 "%d %s, more than %g times %s; the first at %s (/physical/residual): %s\n",
                 a.out.c_str(), static_cast<long long>(writer.short_steps()), static_cast<long long>(s.steps),
                 writer.max_short(), params.iterations,
                 direct ? "local-global iterations (solver.method: direct stops after solver.physical_iterations)"
                        : "iterations (solver.physical_tolerance 0: a fixed count, no stopping rule)",
                 kStalledResidualFactor, against, at(writer.first_short_t()).c_str(), fix);
  }
  if (writer.unbalanced_steps() > 0) {
    const SolverSpec& solver = world.scene.spec.solver;
    // One iteration measures its step's residual before it runs (at the start of the last
    // iteration): a step redone with the direct solve reports where it started, not where it ended.
    const char* fix = world.backend == Backend::Cuda ? ", or replay with --backend cpu, whose recovery redoes such a step"
                      : solver.recovery == SolverSpec::Recovery::None ? ", or turn solver.recovery back on"
                      : world.physical_params.iterations == 1 && solver.physical_tolerance == 0
                          ? " (with 1 iteration a step's residual is measured before it runs, also where the direct "
                            "solve redid the step)"
                          : "";
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps ended with more than %g mesh weights unbalanced "
                 "(solver.recovery_residual; the largest %.3g, the first at %s; /physical/residual): the "
                 "physical mesh was far from balance there, and its force is not a converged response; raise "
                 "solver.physical_iterations%s\n",
                 a.out.c_str(), static_cast<long long>(writer.unbalanced_steps()), static_cast<long long>(s.steps),
                 solver.recovery_residual, writer.max_unbalanced(), at(writer.first_unbalanced_t()).c_str(), fix);
  }
  if (writer.max_inverted_tets() > 0) {
    // What resists the deformation: the paper's E_vol alone, or with the volume term E_det.
    const double k_det = world.scene.spec.stiffness.k_det;
    char resists[160];
    if (k_det > 0)
      std::snprintf(resists, sizeof resists, "E_vol (ARAP) and the volume term (stiffness.k_det = %g Pa)", k_det);
    else
      std::snprintf(resists, sizeof resists, "E_vol (ARAP, with no volume term: stiffness.k_det is 0)");
    std::fprintf(stderr,
                 "ebh: warning: %s: up to %d of the physical mesh's %d tets were inverted after a step, the first at "
                 "%s (/physical/inverted): the tissue there was deformed past what %s resists, and the force "
                 "is not a physical response while they are (docs/MODEL.md, \"Inverted tets\")\n",
                 a.out.c_str(), writer.max_inverted_tets(), world.physical_mesh.num_tets, at(writer.first_inverted_t()).c_str(),
                 resists);
  }
  // A realtime run paces its ticks by the clock: one that could not keep up ran slower than the
  // device it stands for, and its timings are not the ones a real-time loop would have.
  if (p.opt.mode == Mode::Realtime && s.wall_s > 0 && s.virtual_s / s.wall_s < 0.95)
    std::fprintf(stderr,
                 "ebh: warning: %s: the realtime replay fell behind the clock (%.2fx real time: %.3f s of virtual "
                 "time took %.3f s): its ticks missed their %g ms (`ebh metrics`, haptic ticks over budget)\n",
                 a.out.c_str(), s.virtual_s / s.wall_s, s.virtual_s, s.wall_s, world.h_haptic * 1e3);
  // From the recording's first sample only: a window that starts in the tissue is said before the
  // replay (window_starts_in_tissue).
  const std::string start =
      a.start == 0 ? start_warning(writer.first_penetration_physical(), writer.grasped().empty() ? 0 : writer.grasped().front(),
                                   world.tool.surface != nullptr)
                   : "";
  if (!start.empty()) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), start.c_str());
  if (!a.quiet) {
    std::printf("%s: %s + %s, %s mode, %lld ticks, %lld physical steps\n", a.out.c_str(),
                world.scene.spec.name.c_str(), std::filesystem::path(p.in.recording_path).filename().c_str(),
                mode_name(p.opt.mode), static_cast<long long>(s.ticks), static_cast<long long>(s.steps));
    if (world.settle_steps > 0)
      std::printf(world.settle_capped ? "  started after %d static steps under gravity, before the mesh had settled (the warning above)\n"
                                      : "  started from the static equilibrium under gravity (%d static steps)\n",
                  world.settle_steps);
    if (writer.slept_steps() > 0)
      std::printf("  %lld of %lld physical steps skipped while the physical mesh slept (solver.sleep, "
                  "or no vertex awake)\n",
                  static_cast<long long>(writer.slept_steps()), static_cast<long long>(s.steps));
    if (writer.active_mean() >= 0)
      std::printf("  %.0f of %d virtual vertices iterated per tick on average (solver.active_region)\n",
                  writer.active_mean(),
                  static_cast<int>(std::count(world.virtual_mesh.pinned.begin(), world.virtual_mesh.pinned.end(), 0)));
    if (writer.awake_mean() >= 0)
      std::printf("  %.0f of %d physical vertices awake per step on average (solver.physical_region)\n",
                  writer.awake_mean(), world.physical_mesh.num_free);
    const double rate = s.wall_s > 0 ? s.virtual_s / s.wall_s : 0.0;
    std::printf(rate > 0 && rate < 0.01 ? "  virtual %.3f s in %.3f s wall: %.2gx real time\n"  // 0.004x, not 0.00x
                                        : "  virtual %.3f s in %.3f s wall: %.2fx real time\n",
                s.virtual_s, s.wall_s, rate);
    char torque_limit[64] = "";
    if (world.scene.spec.tool.torque_limit > 0)
      std::snprintf(torque_limit, sizeof torque_limit, " (%lld ticks at the %g N m limit)",
                    static_cast<long long>(std::count(writer.torque_clamped().begin(), writer.torque_clamped().end(), 1)),
                    world.scene.spec.tool.torque_limit);
    std::printf("  peak force %.3f N (%lld ticks at the %g N limit), max penetration %.3f mm, peak torque %.3g N m%s\n",
                writer.peak_force(), static_cast<long long>(writer.clamped_ticks()), world.scene.spec.tool.force_limit,
                1e3 * writer.max_penetration(), writer.peak_torque(), torque_limit);
  }
}

/// The files a replay writes (checked against every input before any work).
std::vector<RoleFile> replay_outputs(const ReplayArgs& a) {
  std::vector<RoleFile> out{{a.out, "the replay output"}};
  // The XDMF index beside it, written with mesh snapshots (a stale one removed without them). A name
  // longer than the file system allows (a 255-byte OUT.h5 makes a 257-byte OUT.xdmf) cannot be there
  // to replace: it is checked where snapshots are asked for (prepare_replay).
  try {
    check_name_length(xdmf_path_for(a.out));
    out.push_back({xdmf_path_for(a.out), "the replay's XDMF index"});
  } catch (const InputError&) {
  }
  return out;
}

/// --haptic-hz and --physical-hz against an override of the same rate.
void check_rates_once(const ReplayArgs& a) {
  check_option_not_set(a.overrides, "--haptic-hz", a.haptic_hz.has_value(), format_number(a.haptic_hz.value_or(0)),
                       "time.haptic_hz");
  check_option_not_set(a.overrides, "--physical-hz", a.physical_hz.has_value(), format_number(a.physical_hz.value_or(0)),
                       "time.physical_hz");
}

void run_replay(const ReplayArgs& a) {
  parse_mode(a.mode);
  check_backend(a.backend);
  check_set_once(a.overrides);
  check_rates_once(a);
  const Backend backend = a.backend == "cuda" ? Backend::Cuda : Backend::Cpu;
  // Before any work: no output may replace one of the files the replay reads.
  const std::vector<RoleFile> inputs = replay_input_files(a.scene, a.recording, a.overrides);
  check_outputs(replay_outputs(a), inputs);
  if (std::error_code ec; !a.render_dir.empty() && std::filesystem::exists(a.render_dir, ec) &&
                          !std::filesystem::is_directory(a.render_dir, ec))
    throw InputError("--render " + a.render_dir + ": not a folder");
  // Nor may the frames, which replace every frame_*.png in their folder.
  if (!a.render_dir.empty()) {
    std::vector<RoleFile> files = inputs;
    for (RoleFile& o : replay_outputs(a)) files.push_back(std::move(o));
    check_frames_spare(a.render_dir, files);
  }
  // A folder named like an output would fail only after the replay wrote that output.
  for (const RoleFile& o : replay_outputs(a))
    if (!a.render_dir.empty() && std::filesystem::absolute(a.render_dir).lexically_normal() ==
                                     std::filesystem::absolute(o.path).lexically_normal())
      throw InputError("--render " + a.render_dir + ": is the name of " + o.role + " (-o): name another folder");
  PreparedReplay p;
  p.in = load_replay_inputs(a.scene, a.recording, a.overrides, a.haptic_hz, a.physical_hz, a.allow_outside, backend,
                            a.transforms, RecordingWindow{a.start, a.duration.value_or(0)});
  print_scene_warnings(p.in.world->scene, parse_mode(a.mode), "");
  prepare_replay(a, p);
  // The renderer's setup can fail (no OSMesa context): before the replay replaces a previous output.
  std::unique_ptr<OffscreenRenderer> renderer;
  if (!a.render_dir.empty()) renderer = start_render_after_replay(a.render_dir);
  // After the checks that refuse the replay: a refused one says one line, its error.
  for (const std::string& w : p.in.warnings) std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  install_interrupt_handlers();
  p.writer = std::make_unique<ReplayWriter>(a.out, *p.in.world, p.meta, p.ticks, p.opt.frames_hz > 0);
  Progress progress(p.ticks, !a.quiet, isatty(STDERR_FILENO), a.progress_every);
  Tee tee(*p.writer, progress);
  const ReplaySummary s = replay(*p.in.world, p.in.recording, p.opt, tee);
  progress.finish();
  finish_replay(a, p, s, renderer.get());
}

/// The options of one replay, on `ebh replay` and on each line of a --batch file.
void add_replay_options(CLI::App* c, ReplayArgs& a) {
  c->add_option("scene", a.scene, "Scene name (scenarios/NAME.yaml) or path");
  c->add_option("recording", a.recording, "Recording: an HDF5 file or a name in recordings/");
  c->add_option("-o,--output", a.out, "Output HDF5 file");
  c->add_option("--mode", a.mode, "async (default), lockstep or realtime");
  c->add_option("--haptic-hz", a.haptic_hz, "Haptic tick rate (default: the scene's, 1000)")
      ->check(finite_number(kMinReplayHapticHz, kMaxHapticHz, false, "Hz"));
  c->add_option("--physical-hz", a.physical_hz, "Physical step rate (default: the scene's, 100)")
      ->check(finite_number(kMinReplayPhysicalHz, kMaxHapticHz, false, "Hz"));
  c->add_option("--backend", a.backend, "cpu (default) or cuda");
  c->add_option("--frames-hz", a.frames_hz,
                "Mesh snapshots per second in /frames, 0 for none (default: 30 if the scene asks)")
      ->check(finite_number(0, kMaxHapticHz, false, "Hz"));
  c->add_option("--start", a.start, "Start S seconds into the recording")->check(finite_number(0, kNoUpperLimit));
  c->add_option("--duration", a.duration, "Replay only S seconds (default: the rest of the recording)")
      ->check(finite_number(0, kNoUpperLimit, true));
  c->add_option("--set", a.overrides, "Override a scene key: --set stiffness.k_con=800 (repeatable)");
  c->add_option("--transform", a.transforms.world,
                "Device workspace -> scene, on the left: \"tx,ty,tz,rx,ry,rz\" (translation in the scene's world unit, "
                "rotation vector in degrees)");
  c->add_option("--tool-transform", a.transforms.tool,
                "Device tool frame -> ebh's, on the right (in the tool's frame): \"x,y,z,rx,ry,rz\" (the scene's "
                "world unit, degrees)");
  c->add_option("--render", a.render_dir, "Also render the frames to PNG files in DIR (needs OSMesa)");
  c->add_option("--haptic-threads", a.haptic_threads,
                "CPU, async and realtime: OpenMP threads of the haptic side; the physical step gets the rest "
                "(default: half of OMP_NUM_THREADS or the cores, rounded up)")
      ->check(ebh::cli::whole_number(1, 4096));
  c->add_flag("--allow-outside", a.allow_outside, "Accept a trajectory far outside the scene");
  c->add_flag("-q,--quiet", a.quiet, "No progress bar, no progress lines and no summary");
}

/// One line of a --batch file: the arguments of an `ebh replay` command (after `ebh replay`).
struct BatchLine {
  std::string where;  ///< FILE:LINE
  ReplayArgs args;
};

std::vector<BatchLine> read_batch_file(const std::string& file, bool quiet) {
  check_input_file(file);
  std::ifstream f(file, std::ios::binary);
  // A recording or a replay output given where the list of replays belongs (its bytes read as text
  // made 'line 1: expected SCENE RECORDING').
  if (char head[8] = {}; f.read(head, sizeof head) && std::string_view(head, sizeof head) == "\x89HDF\r\n\x1a\n")
    throw InputError(file + ": an HDF5 file (a recording or a replay output), not a batch list: a text file of "
                            "`SCENE RECORDING -o OUT.h5 [options]` lines");
  f.clear();
  f.seekg(0);
  std::vector<BatchLine> lines;
  std::string text;
  for (int number = 1; std::getline(f, text); ++number) {
    if (number == 1 && text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);  // a UTF-8 byte-order mark
    const std::size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos || text[first] == '#') continue;
    BatchLine line{file + ":" + std::to_string(number), {}};
    CLI::App app{"a replay of the batch"};
    add_replay_options(&app, line.args);
    refuse_empty_values(app);
    try {
      app.parse(text, false);
    } catch (const CLI::ParseError& e) {
      throw InputError(line.where + ": " + e.what());
    }
    ReplayArgs& a = line.args;
    auto refuse = [&](const std::string& what) { throw InputError(line.where + ": " + what); };
    if (a.scene.empty() || a.recording.empty() || a.out.empty()) refuse("expected SCENE RECORDING -o OUT.h5 and options");
    if (a.backend != "cpu" && a.backend != "cuda") refuse("--backend: expected cuda, got '" + a.backend + "'");
    if (app.count("--backend") && a.backend != "cuda") refuse("--backend cpu: a batch runs on the CUDA backend");
    if (a.mode != "async") refuse("--mode " + a.mode + ": a batch runs in async mode");
    if (a.frames_hz.value_or(0) > 0 || !a.render_dir.empty()) refuse("a batch writes no mesh frames (--frames-hz 0, no --render)");
    try {
      check_set_once(a.overrides);
      check_rates_once(a);
    } catch (const InputError& e) {
      refuse(e.what());
    }
    a.backend = "cuda";
    a.frames_hz = 0.0;
    a.quiet = a.quiet || quiet;
    lines.push_back(std::move(line));
  }
  if (lines.empty()) throw InputError(file + ": no replays (one `ebh replay` argument list per line)");
  return lines;
}

/// ebh replay --batch FILE: every line's replay on one GPU at once (replay_batch). Everything is
/// checked and loaded before any replay runs; the worlds are built on several threads.
void run_batch(const ReplayArgs& top, const std::string& file, int at_once) {
  if (!top.scene.empty() || !top.recording.empty() || !top.out.empty() || !top.overrides.empty())
    throw InputError("--batch " + file + ": give each replay's scene, recording, output and options on its line of the file");
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  std::vector<BatchLine> lines = read_batch_file(file, top.quiet);
  std::vector<RoleFile> outputs, inputs{{file, "the batch file"}};
  // Each file's role names its line ("FILE:3's replay output"): two lines may name one output.
  auto of_line = [](const BatchLine& l, RoleFile f) {
    const std::string role = f.role.starts_with("the ") ? f.role.substr(4) : f.role;
    return RoleFile{std::move(f.path), l.where + "'s " + role};
  };
  for (const BatchLine& l : lines) {
    for (RoleFile& o : replay_outputs(l.args)) outputs.push_back(of_line(l, std::move(o)));
    try {
      for (RoleFile& i : replay_input_files(l.args.scene, l.args.recording, l.args.overrides))
        inputs.push_back(of_line(l, std::move(i)));
    } catch (const InputError& e) {
      throw InputError(l.where + ": " + e.what());
    }
  }
  check_outputs(outputs, inputs);
  check_backend("cuda");
  const std::size_t B = lines.size();
  std::vector<RecordingFile> read(B);
  std::map<std::tuple<std::string, double, double>, std::size_t> first_read;  // each recording's window read once
  for (std::size_t i = 0; i < B; ++i) {
    try {
      const ReplayArgs& l = lines[i].args;
      const RecordingWindow window{l.start, l.duration.value_or(0)};
      const auto [it, inserted] = first_read.try_emplace({l.recording, window.start, window.duration}, i);
      read[i] = inserted ? read_replay_recording(l.recording, window) : read[it->second];
    } catch (const InputError& e) {
      throw InputError(lines[i].where + ": " + e.what());
    }
  }
  // The scenes, their meshes and the worlds (settling, the solvers' set-up) on up to one thread per
  // core, one OpenMP thread each; replays of one scene share its world (WorldCache).
  std::vector<PreparedReplay> prepared(B);
  std::vector<std::string> errors(B);
  WorldCache worlds;
  {
    std::atomic<std::size_t> next{0};
    const std::size_t workers = std::min<std::size_t>(B, std::max(1u, std::thread::hardware_concurrency()));
    std::vector<std::thread> pool;
    for (std::size_t w = 0; w < workers; ++w)
      pool.emplace_back([&] {
        omp_set_num_threads(1);
        for (std::size_t i; (i = next++) < B;) {
          const ReplayArgs& a = lines[i].args;
          try {
            prepared[i].in = load_replay_scene(std::move(read[i]), a.scene, a.overrides, a.haptic_hz, a.physical_hz,
                                               a.allow_outside, Backend::Cuda, a.transforms, &worlds);
          } catch (const std::exception& e) {
            errors[i] = e.what();
          }
        }
      });
    for (std::thread& t : pool) t.join();
  }
  for (std::size_t i = 0; i < B; ++i)
    if (!errors[i].empty()) throw InputError(lines[i].where + ": " + errors[i]);
  for (std::size_t i = 0; i < B; ++i) {
    try {
      prepare_replay(lines[i].args, prepared[i]);
    } catch (const InputError& e) {
      throw InputError(lines[i].where + ": " + e.what());
    }
  }
  for (std::size_t i = 0; i < B; ++i) {
    print_scene_warnings(prepared[i].in.world->scene, prepared[i].opt.mode, lines[i].where + ": ");
    for (const std::string& w : prepared[i].in.warnings)
      std::fprintf(stderr, "ebh: warning: %s\n", ebh::escape_unprintable(w).c_str());
  }
  install_interrupt_handlers();
  std::vector<BatchReplay> batch(B);
  std::map<std::string, std::string> digests;  // each input file hashed once for the outputs' provenance
  for (std::size_t i = 0; i < B; ++i) {
    PreparedReplay& p = prepared[i];
    p.meta.digests = &digests;
    p.writer = std::make_unique<ReplayWriter>(lines[i].args.out, *p.in.world, p.meta, p.ticks, false);
    batch[i] = {p.in.world.get(), &p.in.recording, p.opt, p.writer.get()};
  }
  const auto t1 = Clock::now();
  const std::vector<BatchOutcome> outcomes = replay_batch(batch, at_once);
  const auto t2 = Clock::now();
  std::size_t failed = 0;
  double virtual_s = 0;
  for (std::size_t i = 0; i < B; ++i) {
    const BatchOutcome& o = outcomes[i];
    if (o.error.empty()) {
      try {
        finish_replay(lines[i].args, prepared[i], o.summary);
        virtual_s += o.summary.virtual_s;
        continue;
      } catch (const InputError& e) {
        if (interrupted()) throw;
        std::fprintf(stderr, "ebh: error: %s: %s\n", lines[i].where.c_str(), e.what());
      }
    } else {
      std::fprintf(stderr, "ebh: error: %s: %s: %s; no output written\n", lines[i].where.c_str(),
                   lines[i].args.out.c_str(), o.error.c_str());
    }
    ++failed;
    prepared[i].writer.reset();  // removes its temporary file
  }
  const double load = std::chrono::duration<double>(t1 - t0).count(), run = std::chrono::duration<double>(t2 - t1).count();
  if (!top.quiet)
    std::printf("batch of %zu replays on one GPU, %d at once: virtual %.3f s in %.3f s wall (%.3f s loading, %d %s "
                "built): %.2fx real time in total (%.2fx from the start)\n",
                B, std::min(at_once, static_cast<int>(B)), virtual_s, run, load, worlds.built(),
                worlds.built() == 1 ? "world" : "worlds", run > 0 ? virtual_s / run : 0.0, virtual_s / (load + run));
  if (failed > 0) throw InputError("--batch " + file + ": " + std::to_string(failed) + " of " + std::to_string(B) + " replays failed");
}

void setup(CLI::App& root) {
  auto args = std::make_shared<ReplayArgs>();
  auto batch = std::make_shared<std::string>();
  auto at_once = std::make_shared<int>(kBatchAtOnce);
  CLI::App* c = root.add_subcommand("replay", "Replay a recorded device trajectory through the two-rate solver");
  add_replay_options(c, *args);
  CLI::Option* batch_option = c->add_option("--batch", *batch,
                "Replay every line of FILE (the arguments of an `ebh replay` each) on one GPU at once (--backend cuda, "
                "async, no frames)");
  c->add_option("--at-once", *at_once, "With --batch: replays that run side by side (default 8; the others wait their turn)")
      ->check(ebh::cli::whole_number(1, 1024))
      ->needs(batch_option);
  c->add_option("--progress-every", args->progress_every,
                 "Where stderr is not a terminal (nohup, a Slurm job's log): a progress line every S seconds of wall "
                 "time (default 60, 0 for none)")
      ->check(finite_number(0, kNoUpperLimit))
      ->excludes(batch_option);
  c->callback([args, batch, at_once, c] {
    if (!batch->empty() && c->count("--backend") && args->backend != "cuda")
      throw InputError("--backend " + args->backend + ": --batch runs its replays on the CUDA backend, on one GPU "
                       "(on the CPU, replay them one by one or with ebh sweep)");
    if (!batch->empty()) return run_batch(*args, *batch, *at_once);
    if (args->scene.empty() || args->recording.empty() || args->out.empty())
      throw InputError("ebh replay: expected SCENE RECORDING -o OUT.h5 (or --batch FILE); see --help");
    run_replay(*args);
  });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
