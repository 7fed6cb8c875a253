// ebh table1: the paper's Table 1 on this machine — mesh sizes and the simulation (physical step)
// and haptic rates reached when both sides run concurrently in realtime mode.
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <memory>
#include <optional>

#include "command.hpp"
#include "core/error.hpp"
#include "io/json.hpp"
#include "mesh/boundary.hpp"
#include "metrics/signal.hpp"
#include "options.hpp"
#include "replay_common.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/replay_output.hpp"
#include "schedule/scheduler.hpp"
#include "table1_columns.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#endif

namespace ebh::cli {
namespace {

struct Rates {
  double sim_fps = 0, haptic_fps = 0, haptic_p99_ms = 0;
};

/// Counts ticks and steps of a realtime replay.
class RateCounter : public ReplayObserver {
 public:
  std::vector<double> tick_s;
  void on_tick(const World&, const HapticSide& h, double) override { tick_s.push_back(h.timing.total); }
};

Rates measure(const std::string& scene, const std::string& recording, double start, double seconds, Backend backend) {
  const LoadedReplay in = load_replay_inputs(scene, recording, {}, std::nullopt, std::nullopt, false, backend);
  ReplayOptions opt;
  opt.mode = Mode::Realtime;
  opt.start = start;
  opt.duration = seconds;
  opt.pace_physical = false;  // Table 1's "Sim FPS": as many physical steps as the machine gives
  RateCounter c;
  c.tick_s.reserve(static_cast<std::size_t>(seconds * 1100));
  const ReplaySummary s = replay(*in.world, in.recording, opt, c);
  Rates r;
  r.sim_fps = s.wall_s > 0 ? static_cast<double>(s.steps) / s.wall_s : 0;
  r.haptic_fps = s.wall_s > 0 ? static_cast<double>(s.ticks) / s.wall_s : 0;
  if (!c.tick_s.empty()) r.haptic_p99_ms = 1e3 * percentile(std::move(c.tick_s), 99.0);  // as `ebh metrics`
  return r;
}

/// The 1-minute load average (getloadavg), or -1 where the system does not say: Table 1's rates
/// are wall-clock rates, and other work on the machine lowers them.
double load_average() {
  double load[1];
  return getloadavg(load, 1) == 1 ? load[0] : -1.0;
}

struct Table1Args {
  double seconds = 3.0;
  std::string backend = "cpu";
  bool json = false;
  std::vector<std::string> only;
};

void run_table1(const Table1Args& a) {
  check_backend(a.backend);
  const Backend backend = a.backend == "cuda" ? Backend::Cuda : Backend::Cpu;
  // As `ebh replay` records it: the GPU (with --backend cuda) and the CPU that drives it.
  std::string device = cpu_description();
#if EBH_HAVE_CUDA
  if (backend == Backend::Cuda) device = cuda_device_description() + " + " + device;
#endif
  std::vector<std::string> known;
  for (const Table1Column& col : kTable1Columns) known.push_back(col.label);
  check_known_names("--scene", "Table 1 column", a.only, known);
  const double load_before = load_average();
  Json rows = Json::array();
  if (!a.json)
    std::printf("%-16s %7s %7s %9s %9s | %9s %9s %9s | %8s %8s %8s\n", "scene", "tets", "(paper)", "triangles",
                "(paper)", "sim press", "sim grasp", "haptic", "press", "grasp", "haptic");
  for (const Table1Column& col : kTable1Columns) {
    if (!a.only.empty() && std::find(a.only.begin(), a.only.end(), col.label) == a.only.end()) continue;
    const Scene scene = load_scene(resolve_scene_path(col.press_scene));
    const FaceCounts faces = count_faces(scene.physical.tets);
    const Rates press = measure(col.press_scene, col.press_recording, col.press_start, a.seconds, backend);
    std::optional<Rates> grasp;
    if (col.grasp_scene) grasp = measure(col.grasp_scene, col.grasp_recording, col.grasp_start, a.seconds, backend);
    const double haptic = grasp ? std::min(press.haptic_fps, grasp->haptic_fps) : press.haptic_fps;
    if (a.json) {
      Json j = Json::object();
      j.set("scene", col.label);
      j.set("tets", static_cast<long long>(scene.physical.tets.size()));
      j.set("interior_triangles", static_cast<long long>(faces.interior));
      j.set("sim_fps_pressing", press.sim_fps);
      j.set("sim_fps_grasping", grasp ? Json(grasp->sim_fps) : Json());
      j.set("haptic_fps", haptic);
      j.set("haptic_tick_p99_ms", press.haptic_p99_ms);
      auto run = [](const char* scene_name, const char* recording, double start) {
        Json r = Json::object();
        r.set("scene", scene_name);
        r.set("recording", recording);
        r.set("start_s", start);
        return r;
      };
      j.set("pressing", run(col.press_scene, col.press_recording, col.press_start));
      j.set("grasping", col.grasp_scene ? run(col.grasp_scene, col.grasp_recording, col.grasp_start) : Json());
      Json paper = Json::object();
      paper.set("tets", col.paper_tets);
      paper.set("triangles", col.paper_triangles);
      paper.set("sim_fps_pressing", col.paper_press_fps);
      paper.set("sim_fps_grasping", col.paper_grasp_fps);
      paper.set("haptic_fps", col.paper_haptic_fps);
      j.set("paper", paper);
      rows.push(j);
    } else {
      char grasp_text[32] = "      n/a";
      if (grasp) std::snprintf(grasp_text, sizeof grasp_text, "%9.1f", grasp->sim_fps);
      std::printf("%-16s %7zu %7d %9lld %9d | %9.1f %s %9.1f | %8.1f %8.1f %8.1f\n", col.label,
                  scene.physical.tets.size(), col.paper_tets, static_cast<long long>(faces.interior), col.paper_triangles,
                  press.sim_fps, grasp_text, haptic, col.paper_press_fps, col.paper_grasp_fps, col.paper_haptic_fps);
    }
  }
  const double load_after = load_average();
  if (a.json) {
    Json out = Json::object();
    out.set("backend", a.backend);
    out.set("load_average_before", load_before);
    out.set("load_average_after", load_after);
    out.set("device", device);
    out.set("seconds_per_run", a.seconds);
    out.set("threads", omp_get_max_threads());
    out.set("rows", rows);
    std::printf("%s\n", out.dump().c_str());
  } else {
    std::printf("realtime mode, %.1f s per run (the press and grasp recordings from where contact starts: --json names "
                "them), physical side unpaced; haptic: the lower of the two runs; the paper's rates right of the bar; "
                "backend %s on %s, %d OpenMP threads\n",
                a.seconds, a.backend.c_str(), device.c_str(), omp_get_max_threads());
    if (load_before >= 0) std::printf("1-minute load average %.2f before, %.2f after\n", load_before, load_after);
  }
  // Other work on the machine while measuring: a table1 on a busy machine reads as a slow build.
  const double cores = static_cast<double>(std::max(1u, std::thread::hardware_concurrency()));
  if (load_before >= 0.5 * cores)
    std::fprintf(stderr, "ebh: warning: the machine was busy before measuring (1-minute load average %.2f on %.0f cores): "
                 "the rates are lower than on an idle machine\n", load_before, cores);
}

void setup(CLI::App& root) {
  auto args = std::make_shared<Table1Args>();
  CLI::App* c = root.add_subcommand("table1", "Reproduce the paper's Table 1 (sizes, simulation and haptic rates)");
  c->add_option("--seconds", args->seconds, "Wall seconds of realtime replay per measurement (default 3)")
      ->check(finite_number(0.1, 3600, false, "s"));  // a run shorter than 0.1 s times too few ticks and steps
  c->add_option("--scene", args->only, "Only these columns (cholecystectomy, gynaecology, tube, gap)");
  c->add_option("--backend", args->backend,
                "cpu (default) or cuda: the physical step and the virtual mesh's iterations on the GPU (the paper "
                "measured Table 1 on one)");
  c->add_flag("--json", args->json, "JSON output");
  c->callback([args] { run_table1(*args); });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
