// ebh replay SCENE RECORDING -o OUT.h5: the toolkit's main job (DESIGN.md §2, §4).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "command.hpp"
#include "core/error.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "metrics/force_metrics.hpp"
#include "options.hpp"
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
  bool allow_outside = false, quiet = false;
};

/// A progress bar on a terminal (stderr), nothing otherwise.
class Progress : public ReplayObserver {
 public:
  Progress(std::int64_t ticks, bool enabled) : ticks_(ticks), enabled_(enabled), t0_(Clock::now()) {}
  void on_tick(const World& w, const HapticSide& h, double t) override {
    if (!enabled_ || (h.tick % 50) != 0) return;
    const auto now = Clock::now();
    if (now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    const double frac = static_cast<double>(h.tick) / static_cast<double>(ticks_);
    const double wall = std::chrono::duration<double>(now - t0_).count();
    const int width = 30, done = static_cast<int>(frac * width);
    std::fprintf(stderr, "\r[%.*s%*s] %3.0f%%  t=%6.2f s  %5.2fx real time  |F|=%5.2f N ", done,
                 "##############################", width - done, "", 100 * frac, t + w.h_haptic,
                 wall > 0 ? (t + w.h_haptic) / wall : 0.0, norm(h.output.force));
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\r%*s\r", 90, "");
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::int64_t ticks_;
  bool enabled_;
  Clock::time_point t0_, last_{};
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

void run_replay(const ReplayArgs& a) {
  const Mode mode = parse_mode(a.mode);
  check_backend(a.backend);
  const Backend backend = a.backend == "cuda" ? Backend::Cuda : Backend::Cpu;
  // Before any work: no output may replace one of the files the replay reads.
  check_outputs({{a.out, "the replay output"}, {xdmf_path_for(a.out), "the replay's XDMF index"}},
                replay_input_files(a.scene, a.recording, a.overrides));
  if (std::error_code ec; !a.render_dir.empty() && std::filesystem::exists(a.render_dir, ec) &&
                          !std::filesystem::is_directory(a.render_dir, ec))
    throw InputError("--render " + a.render_dir + ": not a folder");
  LoadedReplay in = load_replay_inputs(a.scene, a.recording, a.overrides, a.haptic_hz, a.physical_hz,
                                       a.allow_outside, backend, a.transforms);
  const World& world = *in.world;
  for (const std::string& w : world.scene.warnings) std::fprintf(stderr, "ebh: warning: %s\n", w.c_str());
  const double length = in.recording.duration();
  if (!(a.start < length))
    throw InputError("--start " + format_number(a.start) + ": the recording " + in.recording_path + " is " + format_number(length) +
                     " s long; start before its end");
  ReplayOptions opt;
  opt.mode = mode;
  opt.start = a.start;
  opt.duration = a.duration.value_or(0);  // 0: the rest of the recording
  opt.frames_hz = a.frames_hz.value_or(world.scene.spec.stages.frames ? 30.0 : 0.0);
  if (!a.render_dir.empty() && opt.frames_hz <= 0) opt.frames_hz = 30.0;  // --render needs frames
  if (opt.frames_hz * world.h_haptic > 1 + 1e-9)
    throw InputError("--frames-hz " + format_number(opt.frames_hz) + ": more snapshots than haptic ticks (" +
                     format_number(1.0 / world.h_haptic) + " Hz)");

  const double rest = length - a.start;
  const double duration = a.duration ? std::min(*a.duration, rest) : rest;
  check_replay_size(world, duration, opt.frames_hz, in.recording_path, a.out);
  const std::int64_t ticks = tick_count(world, duration);
  ReplayMetadata meta;
  meta.recording = in.recording_path;
  meta.start = opt.start;
  meta.duration = opt.duration;
  meta.frames_hz = opt.frames_hz;
  meta.mode = mode_name(mode);
  meta.backend = a.backend;
  meta.device = cpu_description();
#if EBH_HAVE_CUDA
  if (backend == Backend::Cuda) meta.device = cuda_device_description() + " + " + meta.device;
#endif
  meta.overrides = a.overrides;
  meta.transforms = a.transforms;
  meta.applied = in.transforms;
  // After the checks that refuse the replay: a refused one says one line, its error.
  for (const std::string& w : in.warnings) std::fprintf(stderr, "ebh: warning: %s\n", w.c_str());
  install_interrupt_handlers();
  ReplayWriter writer(a.out, world, meta, ticks, opt.frames_hz > 0);
  Progress progress(ticks, !a.quiet && isatty(STDERR_FILENO));
  Tee tee(writer, progress);
  const ReplaySummary s = replay(world, in.recording, opt, tee);
  progress.finish();
  if (s.stopped) throw InputError(a.out + ": interrupted; no output written");
  writer.commit(s);
  index_replay_frames(a.out);
  const std::string contact = contact_warning(static_cast<std::size_t>(writer.contact_ticks()),
                                              static_cast<std::size_t>(s.ticks));
  if (!contact.empty()) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), contact.c_str());
  if (writer.recovered_steps() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps did not converge and were redone with the direct "
                 "solve (/physical/recovered; `ebh scene info` shows the mesh's worst tets)\n",
                 a.out.c_str(), static_cast<long long>(writer.recovered_steps()), static_cast<long long>(s.steps));
  if (writer.capped_steps() > 0)
    std::fprintf(stderr,
                 "ebh: warning: %s: %lld of %lld physical steps ran solver.physical_max_iterations (%d) and still left "
                 "more than solver.physical_tolerance (%g mesh weights) unbalanced (/physical/residual)\n",
                 a.out.c_str(), static_cast<long long>(writer.capped_steps()), static_cast<long long>(s.steps),
                 world.physical_params.max_iterations, world.physical_params.tolerance);
  // From the recording's first sample only: a window may well start in contact.
  const std::string start = a.start == 0 ? start_warning(writer.first_penetration_physical()) : "";
  if (!start.empty()) std::fprintf(stderr, "ebh: warning: %s: %s\n", a.out.c_str(), start.c_str());
  if (!a.quiet) {
    std::printf("%s: %s + %s, %s mode, %lld ticks, %lld physical steps\n", a.out.c_str(),
                world.scene.spec.name.c_str(), std::filesystem::path(in.recording_path).filename().c_str(),
                mode_name(mode), static_cast<long long>(s.ticks), static_cast<long long>(s.steps));
    if (world.settle_steps > 0)
      std::printf("  started from the static equilibrium under gravity (%d static steps)\n", world.settle_steps);
    std::printf("  virtual %.3f s in %.3f s wall: %.2fx real time\n", s.virtual_s, s.wall_s,
                s.wall_s > 0 ? s.virtual_s / s.wall_s : 0.0);
    std::printf("  peak force %.3f N (%lld ticks at the %.1f N limit), max penetration %.3f mm\n",
                writer.peak_force(), static_cast<long long>(writer.clamped_ticks()), world.scene.spec.tool.force_limit,
                1e3 * writer.max_penetration());
  }
  if (!a.render_dir.empty()) render_after_replay(a.out, a.render_dir);
}

void setup(CLI::App& root) {
  auto args = std::make_shared<ReplayArgs>();
  CLI::App* c = root.add_subcommand("replay", "Replay a recorded device trajectory through the two-rate solver");
  c->add_option("scene", args->scene, "Scene name (scenarios/NAME.yaml) or path")->required();
  c->add_option("recording", args->recording, "Recording: an HDF5 file or a name in recordings/")->required();
  c->add_option("-o,--output", args->out, "Output HDF5 file")->required();
  c->add_option("--mode", args->mode, "async (default), lockstep or realtime");
  c->add_option("--haptic-hz", args->haptic_hz, "Haptic tick rate (default: the scene's, 1000)")
      ->check(finite_number(0, kMaxHapticHz, true, "Hz"));
  c->add_option("--physical-hz", args->physical_hz, "Physical step rate (default: the scene's, 100)")
      ->check(finite_number(0, kMaxHapticHz, true, "Hz"));
  c->add_option("--backend", args->backend, "cpu (default) or cuda");
  c->add_option("--frames-hz", args->frames_hz,
                "Mesh snapshots per second in /frames, 0 for none (default: 30 if the scene asks)")
      ->check(finite_number(0, kMaxHapticHz, false, "Hz"));
  c->add_option("--start", args->start, "Start S seconds into the recording")->check(finite_number(0, kNoUpperLimit));
  c->add_option("--duration", args->duration, "Replay only S seconds (default: the rest of the recording)")
      ->check(finite_number(0, kNoUpperLimit, true));
  c->add_option("--set", args->overrides, "Override a scene key: --set stiffness.k_con=800 (repeatable)");
  c->add_option("--transform", args->transforms.world,
                "Device workspace -> scene, on the left: \"tx,ty,tz,rx,ry,rz\" (translation in the scene's world unit, "
                "rotation vector in degrees)");
  c->add_option("--tool-transform", args->transforms.tool,
                "Device tool frame -> ebh's, on the right (in the tool's frame): \"x,y,z,rx,ry,rz\" (the scene's "
                "world unit, degrees)");
  c->add_option("--render", args->render_dir, "Also render the frames to PNG files in DIR (needs OSMesa)");
  c->add_flag("--allow-outside", args->allow_outside, "Accept a trajectory far outside the scene");
  c->add_flag("-q,--quiet", args->quiet, "No progress bar and no summary");
  c->callback([args] { run_replay(*args); });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
