// ebh table1: the paper's Table 1 on this machine — mesh sizes and the simulation (physical step)
// and haptic rates reached when both sides run concurrently in realtime mode.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>

#include "command.hpp"
#include "core/error.hpp"
#include "io/json.hpp"
#include "mesh/boundary.hpp"
#include "metrics/signal.hpp"
#include "options.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/replay_output.hpp"
#include "schedule/scheduler.hpp"

namespace ebh::cli {
namespace {

/// One column of Table 1 with the paper's numbers beside ours.
struct Column {
  const char* label;
  const char* press_scene;
  const char* press_recording;
  double press_start;
  const char* grasp_scene;
  const char* grasp_recording;
  double grasp_start;
  int paper_tets, paper_triangles;
  double paper_press_fps, paper_grasp_fps, paper_haptic_fps;
};

// Windows start just before contact (the gate uses the same ones: tests/gate/baselines.yaml).
const Column kColumns[] = {
    {"cholecystectomy", "cholecystectomy_hook", "cholecystectomy_press", 0.9, "cholecystectomy", "cholecystectomy_grasp",
     0.8, 44178, 82748, 125.1, 123.3, 1003.2},
    {"gynaecology", "gynaecology_hook", "gynaecology_press", 0.9, "gynaecology", "gynaecology_grasp", 0.8, 16848, 29102,
     131.0, 132.2, 1004.1},
    {"tube", "tube", "tube_insert", 1.8, "tube_forceps", "tube_grasp", 0.8, 8068, 14588, 137.8, 140.3, 998.1},
    {"gap", "gap", "gap_insert", 2.0, "gap_forceps", "gap_grasp", 0.8, 16630, 30812, 140.0, 140.1, 1007.5},
};

struct Rates {
  double sim_fps = 0, haptic_fps = 0, haptic_p99_ms = 0;
};

/// Counts ticks and steps of a realtime replay.
class RateCounter : public ReplayObserver {
 public:
  std::vector<double> tick_s;
  void on_tick(const World&, const HapticSide& h, double) override { tick_s.push_back(h.timing.total); }
};

Rates measure(const std::string& scene, const std::string& recording, double start, double seconds) {
  const LoadedReplay in = load_replay_inputs(scene, recording, {}, std::nullopt, std::nullopt, false);
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

struct Table1Args {
  double seconds = 3.0;
  bool json = false;
  std::vector<std::string> only;
};

void run_table1(const Table1Args& a) {
  std::vector<std::string> known;
  for (const Column& col : kColumns) known.push_back(col.label);
  check_known_names("--scene", "Table 1 column", a.only, known);
  Json rows = Json::array();
  if (!a.json)
    std::printf("%-16s %7s %7s %9s %9s | %9s %9s %9s | %8s %8s\n", "scene", "tets", "(paper)", "triangles", "(paper)",
                "sim press", "sim grasp", "haptic", "paper sim", "haptic");
  for (const Column& col : kColumns) {
    if (!a.only.empty() && std::find(a.only.begin(), a.only.end(), col.label) == a.only.end()) continue;
    const Scene scene = load_scene(resolve_scene_path(col.press_scene));
    const FaceCounts faces = count_faces(scene.physical.tets);
    const Rates press = measure(col.press_scene, col.press_recording, col.press_start, a.seconds);
    std::optional<Rates> grasp;
    if (col.grasp_scene) grasp = measure(col.grasp_scene, col.grasp_recording, col.grasp_start, a.seconds);
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
      std::printf("%-16s %7zu %7d %9lld %9d | %9.1f %s %9.1f | %8.1f %8.1f\n", col.label, scene.physical.tets.size(),
                  col.paper_tets, static_cast<long long>(faces.interior), col.paper_triangles, press.sim_fps, grasp_text,
                  haptic, col.paper_press_fps, col.paper_haptic_fps);
    }
  }
  if (a.json) {
    Json out = Json::object();
    out.set("device", cpu_description());
    out.set("seconds_per_run", a.seconds);
    out.set("rows", rows);
    std::printf("%s\n", out.dump().c_str());
  } else {
    std::printf("realtime mode, %.1f s per run, physical side unpaced; CPU: %s\n", a.seconds, cpu_description().c_str());
  }
}

void setup(CLI::App& root) {
  auto args = std::make_shared<Table1Args>();
  CLI::App* c = root.add_subcommand("table1", "Reproduce the paper's Table 1 (sizes, simulation and haptic rates)");
  c->add_option("--seconds", args->seconds, "Wall seconds of realtime replay per measurement (default 3)")
      ->check(finite_number(0, 3600, true, "s"));
  c->add_option("--scene", args->only, "Only these columns (cholecystectomy, gynaecology, tube, gap)");
  c->add_flag("--json", args->json, "JSON output");
  c->callback([args] { run_table1(*args); });
}

}  // namespace

EBH_COMMAND(setup);

}  // namespace ebh::cli
