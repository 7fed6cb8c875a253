// The CPU haptic tick (Algorithm 2, schedule/simulation.cpp haptic_tick) over the whole
// cholecystectomy_grasp recording (and gap_insert, whose blocks hang under gravity with a strained
// surface, and tube_grasp, whose squeeze spreads around the tube), with the whole virtual mesh
// iterated (full) and with active regions of the named tolerances in mm (solver/active_region.hpp;
// "both": the physical mesh's awake region of the same tolerance too, solver.physical_region,
// whose resting vertices hold their E_svc targets still between physical results): one async
// replay per benchmark, every tick timed by the tick itself (HapticSide::timing). Counters: the tick's median, mean (what a replay's speed follows),
// 99th and 99.9th percentiles (us), each stage's median (us; sync = reading the device and the
// E_svc targets, with the region's update), the tick's and its sync's median on the ticks a
// physical result arrived at (fresh: the E_svc targets paired again), and the mean number of
// active virtual vertices.
//   OMP_NUM_THREADS=1 ./build/benchmarks/bench_haptic_tick
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "metrics/signal.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

namespace {

/// Each tick's stage times (s) and the active region's size.
struct TickTimes : ebh::ReplayObserver {
  std::vector<double> total, sync, grasp, mesh, tool, output, active;
  std::vector<double> total_fresh, sync_fresh;  // the ticks a physical result arrived at
  void on_tick(const ebh::World&, const ebh::HapticSide& h, double) override {
    total.push_back(h.timing.total);
    sync.push_back(h.timing.device + h.timing.physical_sync);
    // delivered_tick starts at 0 before any result: the first tick is not one a result arrived at
    if (h.delivered_tick == h.tick - 1 && h.tick > 1) {
      total_fresh.push_back(total.back());
      sync_fresh.push_back(sync.back());
    }
    grasp.push_back(h.timing.grasp);
    mesh.push_back(h.timing.virtual_mesh);
    tool.push_back(h.timing.virtual_tool);
    output.push_back(h.timing.output);
    active.push_back(h.region ? static_cast<double>(h.region->vertices.size()) : h.mesh.q.size());
  }
};

const ebh::LoadedReplay& inputs(const std::string& scene, const std::string& recording, const std::string& region,
                                const std::string& physical_region) {
  static std::map<std::string, std::unique_ptr<ebh::LoadedReplay>> cache;
  auto& slot = cache[scene + "/" + recording + "/" + region + "/" + physical_region];
  if (!slot) {
    const std::vector<std::string> set{"solver.active_region=" + region, "solver.physical_region=" + physical_region};
    slot = std::make_unique<ebh::LoadedReplay>(
        ebh::load_replay_inputs(scene, recording, set, std::nullopt, std::nullopt, false));
  }
  return *slot;
}

/// region: the solver.active_region override (mm; "0": the full solve); physical_region: the
/// solver.physical_region override (mm; "0": the whole physical mesh).
void BM_HapticTick(benchmark::State& state, const std::string& scene, const std::string& recording,
                   const std::string& region, const std::string& physical_region = "0") {
  const ebh::LoadedReplay& in = inputs(scene, recording, region, physical_region);
  TickTimes times;
  for (auto _ : state) {
    times = TickTimes{};
    ebh::replay(*in.world, in.recording, ebh::ReplayOptions{}, times);
  }
  const auto us = [](std::vector<double> v, double p) { return 1e6 * ebh::percentile(v, p); };
  state.counters["tick_p50_us"] = us(times.total, 50);
  double sum = 0;
  for (const double t : times.total) sum += t;
  state.counters["tick_mean_us"] = times.total.empty() ? 0 : 1e6 * sum / static_cast<double>(times.total.size());
  state.counters["tick_p99_us"] = us(times.total, 99);
  state.counters["tick_p999_us"] = us(times.total, 99.9);
  state.counters["sync_p50_us"] = us(times.sync, 50);
  state.counters["grasp_p50_us"] = us(times.grasp, 50);
  state.counters["mesh_p50_us"] = us(times.mesh, 50);
  state.counters["tool_p50_us"] = us(times.tool, 50);
  state.counters["output_p50_us"] = us(times.output, 50);
  state.counters["fresh_tick_p50_us"] = us(times.total_fresh, 50);
  state.counters["fresh_sync_p50_us"] = us(times.sync_fresh, 50);
  double active = 0;
  for (const double a : times.active) active += a;
  state.counters["active_mean"] = times.active.empty() ? 0 : active / static_cast<double>(times.active.size());
}

BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_full, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_region_0_001mm, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_region_0_0003mm, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0.0003"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_region_0_01mm, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0.01"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_both_0_001mm, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0.001"), std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, cholecystectomy_grasp_both_0_0003mm, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), std::string("0.0003"), std::string("0.0003"))
    ->Unit(benchmark::kSecond)->Iterations(1);
// The gap scene, whose blocks hang under gravity: their strained surface joins the region where a
// physical result moves it.
BENCHMARK_CAPTURE(BM_HapticTick, gap_insert_full, std::string("gap"), std::string("gap_insert"), std::string("0"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, gap_insert_region_0_001mm, std::string("gap"), std::string("gap_insert"),
                  std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, gap_insert_region_0_0003mm, std::string("gap"), std::string("gap_insert"),
                  std::string("0.0003"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, gap_insert_both_0_001mm, std::string("gap"), std::string("gap_insert"),
                  std::string("0.001"), std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);
// The tube squeezed by the forceps: a grasp whose strain spreads around the tube.
BENCHMARK_CAPTURE(BM_HapticTick, tube_grasp_full, std::string("tube_forceps"), std::string("tube_grasp"),
                  std::string("0"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, tube_grasp_region_0_001mm, std::string("tube_forceps"), std::string("tube_grasp"),
                  std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_HapticTick, tube_grasp_both_0_001mm, std::string("tube_forceps"), std::string("tube_grasp"),
                  std::string("0.001"), std::string("0.001"))
    ->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
