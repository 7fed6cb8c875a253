// Virtual-time replay throughput: virtual seconds per wall second (the real-time factor) of whole
// committed recordings on the CPU backend, async mode, no output file (the observer only counts).
//   ./build/benchmarks/bench_replay --benchmark_filter=tube
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <optional>
#include <string>

#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

namespace {


const ebh::LoadedReplay& inputs(const std::string& scene, const std::string& recording) {
  static std::map<std::string, std::unique_ptr<ebh::LoadedReplay>> cache;
  auto& slot = cache[scene + "/" + recording];
  if (!slot)
    slot = std::make_unique<ebh::LoadedReplay>(
        ebh::load_replay_inputs(scene, recording, {}, std::nullopt, std::nullopt, false));
  return *slot;
}

void BM_Replay(benchmark::State& state, const std::string& scene, const std::string& recording, ebh::Mode mode) {
  const ebh::LoadedReplay& in = inputs(scene, recording);
  ebh::ReplayObserver counter;  // no output: measures the solver, not HDF5
  ebh::ReplayOptions opt;
  opt.mode = mode;
  double virtual_s = 0, wall_s = 0;
  for (auto _ : state) {
    const ebh::ReplaySummary s = ebh::replay(*in.world, in.recording, opt, counter);
    virtual_s += s.virtual_s;
    wall_s += s.wall_s;
  }
  state.counters["realtime_factor"] = wall_s > 0 ? virtual_s / wall_s : 0;
  state.counters["virtual_s"] = virtual_s / static_cast<double>(state.iterations());
}

using ebh::Mode;
BENCHMARK_CAPTURE(BM_Replay, tube_insert, std::string("tube"), std::string("tube_insert"), Mode::Async)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_Replay, gap_insert, std::string("gap"), std::string("gap_insert"), Mode::Async)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_Replay, cholecystectomy_grasp, std::string("cholecystectomy"),
                  std::string("cholecystectomy_grasp"), Mode::Async)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_Replay, gynaecology_press, std::string("gynaecology_hook"), std::string("gynaecology_press"),
                  Mode::Async)
    ->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
