// The CUDA backend (docs/CUDA.md):
//   BM_CudaPhysicalStep     one physical step (Algorithm 1, 16 iterations) of a scene on the device:
//                           q in, one graph launch, x out; median and p99 of single steps
//   BM_CudaPhysicalStepDevice  the same step as the replay's device haptic tick runs it: q read from
//                           and x left in device memory (launch, then wait for the step)
//   BM_CudaPhysicalStepRegion  the step with the physical mesh's awake region (solver.physical_region)
//                           under a local press: its cost against the share of the mesh it iterates
//   BM_VirtualTick          the virtual mesh's part of a haptic tick (begin, 4 iterations with
//                           contacts, end) on the CPU and on the device (q back after each iteration)
//   BM_DeviceTicks          the device haptic tick alone (no physical steps): cholecystectomy_grasp's
//                           ticks from t = 1.2 s (contact and a grasp) or 0 s (approach, no contact);
//                           *_stages: also the mean time of each stage per step (DeviceTickProfile);
//                           *_unpipelined: every step waits for the virtual tool (the pipeline's gain);
//                           *_surface: with `contact: surface` (every step unpipelined);
//                           *_runs_of_100: 100 ticks per launch (what a launch costs);
//                           *_with_physical: the physical steps beside the ticks (the replay's workload),
//                           a launch per physical period; *_in_launch: the steps inside launches of
//                           100 ticks (run_ticks_with_steps), as the async replay runs them;
//                           physical_step_us: the steps' mean device time beside the ticks;
//                           *_16_blocks: a batch's share of the device's tick blocks;
//                           *_region: solver.active_region=0.0003 (awake_share: chunk-ticks awake)
//   BM_ReplayGrasp          a virtual-time (async) replay of cholecystectomy_grasp on each backend:
//                           real-time factor and the mean time of each stage of the haptic tick;
//                           cuda_host_tool: the virtual tool on the host (ReplayOptions::device_tick
//                           off); cuda_launch_per_period: a launch per physical period
//                           (ReplayOptions::steps_in_launches off)
// Needs a CUDA device; without one (or without the CUDA backend) every benchmark reports why.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "io/recording.hpp"
#include "scene/scene.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"
#include "schedule/simulation.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/virtual_mesh.hpp"
#if EBH_HAVE_CUDA
#include "solver/device_cuda.hpp"
#include "solver/physical_mesh_cuda.hpp"
#include "solver/virtual_mesh_cuda.hpp"
#endif

namespace {
using namespace ebh;
using Clock = std::chrono::steady_clock;

bool device_ready(benchmark::State& st) {
#if EBH_HAVE_CUDA
  std::string why;
  if (cuda_device_available(&why)) return true;
  st.SkipWithError(why.c_str());
#else
  st.SkipWithError("this build has no CUDA backend (configure with -DEBH_WITH_CUDA=ON where nvcc is installed)");
#endif
  return false;
}

struct Loaded {
  Scene scene;
  VirtualModel vm;
  PhysicalModel pm;
};

const Loaded& load(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Loaded>> cache;
  auto& slot = cache[name];
  if (!slot) {
    slot = std::make_unique<Loaded>();
    slot->scene = load_scene(resolve_scene_path(name));
    slot->vm = build_virtual_model(slot->scene);
    PhysicalModelOptions opt;
    opt.h = 1.0 / slot->scene.spec.physical_hz;
    opt.factorize = false;
    slot->pm = build_physical_model(slot->scene, &slot->vm, opt);
  }
  return *slot;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

/// 50 warm-up calls of tick(), then one timed call per benchmark iteration (into `times`).
template <class Tick>
void time_ticks(benchmark::State& st, Tick&& tick, std::vector<double>& times) {
  for (int i = 0; i < 50; ++i) tick();
  for (auto _ : st) {
    const auto t0 = Clock::now();
    tick();
    times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    st.SetIterationTime(times.back());
  }
}

#if EBH_HAVE_CUDA
/// One physical step per benchmark iteration, `step()` timed from its launch to its report (the
/// manual time); counters: the median and p99 of that wall time and the median device time of the
/// step's graph (CudaPhysicalSolver::last_device_seconds).
template <class Step>
void time_steps(benchmark::State& st, const CudaPhysicalSolver& solver, Step&& step) {
  std::vector<double> times, device;
  times.reserve(1 << 16);
  device.reserve(1 << 16);
  for (auto _ : st) {
    const auto t0 = Clock::now();
    step();
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    st.SetIterationTime(dt);
    times.push_back(dt);
    device.push_back(solver.last_device_seconds());
  }
  st.counters["median_us"] = 1e6 * percentile(times, 0.5);
  st.counters["p99_us"] = 1e6 * percentile(times, 0.99);
  st.counters["graph_median_us"] = 1e6 * percentile(device, 0.5);
}

/// Gravity sag from rest, stepped repeatedly: the device cost of a step does not depend on the
/// state (fixed iteration counts), so no reset is needed between steps.
void BM_CudaPhysicalStep(benchmark::State& st, std::string scene) {
  if (!device_ready(st)) return;
  const Loaded& L = load(scene);
  PhysicalStepParams params = physical_params(L.scene.spec.solver, L.pm);
  params.iterations = st.range(0);
  params.tolerance = 0;  // exactly K iterations
  CudaPhysicalOptions options;
  options.programmatic_launch = st.range(1) != 0;  // 0: plain graph kernel nodes
  CudaPhysicalSolver solver(L.pm, params, options);
  PhysicalState state = make_physical_state(L.pm);
  const std::vector<Vec3d> q = L.vm.rest;
  for (int i = 0; i < 20; ++i) solver.step(state, q);  // warm-up: module load, graph upload
  time_steps(st, solver, [&] { solver.step(state, q); });
  st.counters["pdl"] = solver.programmatic_launch();
  st.counters["tet_evals"] = solver.tet_evaluations_per_tet();
  st.counters["tets"] = L.pm.num_tets;
  st.counters["vertices"] = L.pm.num_vertices;
  st.counters["virtual"] = L.pm.num_virtual;
  st.SetLabel(cuda_device_description());
}
// Arguments: the iteration count K (16 is the scenes'; 0, 1 and 2 split the fixed cost of a step
// from the cost of one local-global iteration) and whether programmatic dependent launch may be
// used in the graph (CudaPhysicalOptions::programmatic_launch).
BENCHMARK_CAPTURE(BM_CudaPhysicalStep, cholecystectomy, std::string("cholecystectomy"))
    ->ArgNames({"K", "pdl"})
    ->Args({16, 1})->Args({16, 0})->Args({0, 1})->Args({1, 1})->Args({2, 1})
    ->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
/// The device-resident step: wall time of launch + wait (the host's share is the launch and the
/// wait; no conversions or copies of q and x).
void BM_CudaPhysicalStepDevice(benchmark::State& st, std::string scene) {
  if (!device_ready(st)) return;
  const Loaded& L = load(scene);
  PhysicalStepParams params = physical_params(L.scene.spec.solver, L.pm);
  params.iterations = st.range(0);
  params.tolerance = 0;  // exactly K iterations
  CudaPhysicalSolver solver(L.pm, params);
  PhysicalState state = make_physical_state(L.pm);
  solver.step(state, L.vm.rest);  // q on the device: the rest shape
  for (int i = 0; i < 20; ++i) {  // warm-up: module load, graph upload
    solver.launch_device_step();
    solver.device_step_report();
  }
  time_steps(st, solver, [&] {  // device_step_report sets last_device_seconds (its time_s)
    solver.launch_device_step();
    solver.device_step_report();
  });
  st.counters["tets"] = L.pm.num_tets;
  st.SetLabel(cuda_device_description());
}
BENCHMARK_CAPTURE(BM_CudaPhysicalStepDevice, cholecystectomy, std::string("cholecystectomy"))
    ->ArgNames({"K"})->Args({16})->Args({0})
    ->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
/// The step with the awake region (CudaPhysicalOptions::region) at a tolerance of `tol_nm` nm
/// (0: the region off) under a local press: the virtual vertices within 10 mm of the highest one
/// move by 0.1 mm up and down, step to step, the rest of the virtual mesh at rest. Exactly the
/// scene's K iterations (no stopping rule), the copying step (q in, x out); awake_share: the free
/// vertices iterated per step over all free vertices, on average.
void BM_CudaPhysicalStepRegion(benchmark::State& st, std::string scene) {
  if (!device_ready(st)) return;
  const Loaded& L = load(scene);
  PhysicalStepParams params = physical_params(L.scene.spec.solver, L.pm);
  params.tolerance = 0;  // exactly K iterations
  CudaPhysicalOptions options;
  options.region = 1e-9 * static_cast<double>(st.range(0));
  CudaPhysicalSolver solver(L.pm, params, options);
  PhysicalState state = make_physical_state(L.pm);
  int top = 0;
  for (int j = 0; j < L.pm.num_virtual; ++j)
    if (L.vm.rest[j].z > L.vm.rest[top].z) top = j;
  std::vector<Vec3d> up = L.vm.rest, down = L.vm.rest;
  for (int j = 0; j < L.pm.num_virtual; ++j)
    if (norm(L.vm.rest[j] - L.vm.rest[top]) < 0.01) {
      up[j].z += 1e-4;
      down[j].z -= 1e-4;
    }
  long k = 0;
  for (; k < 20; ++k) solver.step(state, k % 2 ? up : down);  // warm-up: module load, graph upload
  double awake = 0;
  long steps = 0;
  time_steps(st, solver, [&] {
    const PhysicalStepReport r = solver.step(state, k++ % 2 ? up : down);
    awake += r.awake >= 0 ? r.awake : L.pm.num_free;
    ++steps;
  });
  st.counters["awake_share"] = steps > 0 ? awake / (static_cast<double>(steps) * L.pm.num_free) : 0.0;
  st.counters["tets"] = L.pm.num_tets;
  st.SetLabel(cuda_device_description());
}
BENCHMARK_CAPTURE(BM_CudaPhysicalStepRegion, cholecystectomy, std::string("cholecystectomy"))
    ->ArgNames({"tol_nm"})->Args({0})->Args({300})->Args({1000})->Args({3000})->Args({100000})
    ->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_CudaPhysicalStep, gynaecology, std::string("gynaecology"))->ArgNames({"K", "pdl"})->Args({16, 1})->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_CudaPhysicalStep, tube, std::string("tube"))->ArgNames({"K", "pdl"})->Args({16, 1})->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
#endif

/// Contacts of a pressing tool: the ~1% of virtual vertices nearest the mesh's lowest point.
std::vector<ContactTarget> sample_contacts(const VirtualModel& vm) {
  std::vector<int> order(vm.num_vertices);
  for (int j = 0; j < vm.num_vertices; ++j) order[j] = j;
  const int count = std::max(1, vm.num_vertices / 100);
  std::partial_sort(order.begin(), order.begin() + count, order.end(),
                    [&](int a, int b) { return vm.rest[a].z < vm.rest[b].z; });
  std::vector<ContactTarget> c;
  for (int i = 0; i < count; ++i) c.push_back({order[i], vm.rest[order[i]] + Vec3d{0, 0, 1e-3}, 400.0});
  return c;
}

void BM_VirtualTick(benchmark::State& st, std::string scene, bool cuda) {
  const Loaded& L = load(scene);
  const VirtualModel& vm = L.vm;
  const std::vector<ContactTarget> contacts = sample_contacts(vm);
  const int iterations = L.scene.spec.solver.virtual_iterations;
  const double h = 1.0 / L.scene.spec.haptic_hz;
  const std::vector<Vec3d> x = L.pm.rest;
  VirtualState state = make_virtual_state(vm);
  VirtualWorkspace ws = make_virtual_workspace(vm);
  std::vector<double> times;
  times.reserve(1 << 16);
  if (cuda) {
#if EBH_HAVE_CUDA
    if (!device_ready(st)) return;
    CudaVirtualSolver solver(vm);
    auto tick = [&] {
      solver.begin_tick(x, 0, h, state.q);
      for (int i = 0; i < iterations; ++i) solver.iteration(contacts, state.q);
      solver.end_tick();
    };
    time_ticks(st, tick, times);
#else
    device_ready(st);
    return;
#endif
  } else {
    auto tick = [&] {
      virtual_begin_tick(vm, ws, state, x, h);
      for (int i = 0; i < iterations; ++i) virtual_iteration(vm, ws, state, contacts);
      virtual_end_tick(vm, ws, state);
    };
    time_ticks(st, tick, times);
  }
  st.counters["median_us"] = 1e6 * percentile(times, 0.5);
  st.counters["p99_us"] = 1e6 * percentile(times, 0.99);
  st.counters["virtual"] = vm.num_vertices;
  st.counters["contacts"] = static_cast<double>(contacts.size());
  st.counters["iterations"] = iterations;
}
BENCHMARK_CAPTURE(BM_VirtualTick, cholecystectomy_cpu, std::string("cholecystectomy"), false)->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_VirtualTick, cholecystectomy_cuda, std::string("cholecystectomy"), true)->UseManualTime()->MinTime(1.0)->Unit(benchmark::kMicrosecond);

#if EBH_HAVE_CUDA
/// `run`: ticks per launch (0: the physical step's). `physical`: each run with the physical step
/// beside it, in the async replay's order (replay_device), without the observer: the replay's own
/// workload (the organ deforms), not the ticks against a still organ. `in_launch` (with physical):
/// the physical steps inside launches of `run` ticks (run_ticks_with_steps), as the replay runs them.
void BM_DeviceTicks(benchmark::State& st, double from, bool profile, bool pipeline, int run = 0, bool physical = false,
                    bool in_launch = false, bool surface = false, const char* scene = "cholecystectomy",
                    const char* recording = "cholecystectomy_grasp", int max_blocks = 0, const char* region = nullptr) {
  if (!device_ready(st)) return;
  std::vector<std::string> overrides;
  if (surface) overrides.push_back("contact=surface");
  if (region) overrides.push_back(std::string("solver.active_region=") + region);
  LoadedReplay in = load_replay_inputs(scene, recording, overrides, std::nullopt,
                                       std::nullopt, false, Backend::Cuda);
  const World& w = *in.world;
  const int N = run > 0 ? run : w.ticks_per_step, runs = 2000 / N;
  const DeviceReplayInputs inputs =
      device_replay_inputs(w, in.recording, in.recording.t.front() + from, std::int64_t(runs) * N, Mode::Async);
  std::vector<DeviceTickOutput> rows(N);
  int contacts = 0;
  double wall = 0, step_device_s = 0;
  long timed_ticks = 0, timed_steps = 0;
  DeviceHapticSetup setup = inputs.setup;
  setup.profile_stages = profile;
  setup.pipeline = pipeline;
  setup.max_blocks = max_blocks;
  DeviceTickProfile stages;
  double awake = 1;
  for (auto _ : st) {
    st.PauseTiming();
    CudaPhysicalSolver solver(w.physical_mesh, w.physical_params);
    CudaHapticTicks ticks(setup, inputs.ticks, solver);
    std::vector<Vec3d> x;
    ticks.collect(in_launch ? ticks.run_ticks_with_steps(N) : ticks.run_ticks(N), rows);  // warm-up: graph instantiation
    while (ticks.steps_in_flight() > 0) ticks.finish_step(x);
    st.ResumeTiming();
    const auto t0 = Clock::now();
    std::vector<int> handles;
    bool in_flight = false;
    auto timed = [&](const PhysicalStepReport& r) {  // the physical step's device time
      step_device_s += r.time_s;
      ++timed_steps;
    };
    for (int r = 1; r < runs; ++r) {
      if (physical && !in_launch) {
        if (in_flight) {
          ticks.deliver_physical_step();
          timed(ticks.finish_physical_step(x));
        }
        ticks.start_physical_step();
        in_flight = true;
      }
      handles.push_back(in_launch ? ticks.run_ticks_with_steps(N) : ticks.run_ticks(N));
      if (handles.size() > 2) {
        ticks.collect(handles.front(), rows);
        handles.erase(handles.begin());
        for (const auto& o : rows) contacts = std::max(contacts, o.contacts);
        // The steps of the collected launch's periods, as replay_device finishes them.
        while (ticks.steps_in_flight() > 2 * N / w.ticks_per_step + 1) timed(ticks.finish_step(x));
      }
    }
    for (const int h : handles) ticks.collect(h, rows);
    if (in_flight) timed(ticks.finish_physical_step(x));
    while (ticks.steps_in_flight() > 0) timed(ticks.finish_step(x));
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    st.SetIterationTime(dt);
    wall += dt;
    timed_ticks += (runs - 1) * N;
    stages = ticks.profile();
    awake = ticks.awake_share();
  }
  st.counters["tick_us"] = timed_ticks ? 1e6 * wall / static_cast<double>(timed_ticks) : 0;
  if (physical) st.counters["physical_step_us"] = timed_steps ? 1e6 * step_device_s / static_cast<double>(timed_steps) : 0;
  for (int k = 0; k < DeviceTickProfile::kStages && profile; ++k)
    st.counters[std::string(DeviceTickProfile::kNames[k]) + "_us"] = stages.mean_us[k];
  if (profile) {
    st.counters["tail_clock_ghz"] = stages.tail_clock_ghz;
    st.counters["clamp_sweeps"] = stages.clamp_sweeps;
    st.counters["clamp_definite"] = stages.definite;
    st.counters["candidates"] = stages.candidates;
    st.counters["updated"] = stages.updated;
    st.counters["unpipelined"] = stages.unpipelined;
    st.counters["listed"] = stages.listed;
  }
  st.counters["max_contacts"] = contacts;
  if (region) st.counters["awake_share"] = awake;
  st.SetLabel(cuda_device_description());
}
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s, 1.2, false, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, approach_from_0s, 0.0, false, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
// With the physical steps beside the ticks, as the async replay runs them: the replay's workload.
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical, 1.2, false, true, 0, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_stages, 1.2, true, true, 0, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
// The physical steps inside launches of 100 ticks (run_ticks_with_steps), as the async replay runs them.
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_in_launch, 1.2, false, true, 100, true, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, approach_from_0s_with_physical, 0.0, false, true, 0, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, approach_from_0s_with_physical_in_launch, 0.0, false, true, 100, true, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_in_launch_stages, 1.2, true, true, 100, true, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
// Runs of 100 ticks instead of the physical step's 10: what a launch (and its unpipelined first step) costs.
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_runs_of_100, 1.2, false, true, 100)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
// Every step waiting for the virtual tool (DeviceHapticSetup::pipeline off): what the pipeline gains.
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_unpipelined, 1.2, false, false)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
// The same with the stage timestamps (per step, microseconds; their reads cost a little).
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_stages, 1.2, true, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, approach_from_0s_stages, 0.0, true, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_unpipelined_stages, 1.2, true, false)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
// Surface contact (`contact: surface`, surface_ticks_kernel; every step unpipelined).
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_surface, 1.2, false, true, 0, false, false, true)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_surface_stages, 1.2, true, true, 0, false, false, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, approach_from_0s_surface_stages, 0.0, true, true, 0, false, false, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
// The hook into the gap's block (gap_insert from 3 s): large triangles (up to ~30 sample rows).
BENCHMARK_CAPTURE(BM_DeviceTicks, gap_insert_from_3s_stages, 3.0, true, true, 0, false, false, false, "gap", "gap_insert")->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
// A batch's share of the device (16 tick blocks: 8 replays at once on an H100/H200, each block
// several chunks), with and without the active region (0.0003 mm): where a replay's tick goes
// when it shares the device ("Many replays on one GPU").
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_in_launch_16_blocks_stages, 1.2, true, true, 100, true, true, false, "cholecystectomy", "cholecystectomy_grasp", 16)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_in_launch_16_blocks_region_stages, 1.2, true, true, 100, true, true, false, "cholecystectomy", "cholecystectomy_grasp", 16, "0.0003")->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, contact_from_1_2s_with_physical_in_launch_region_stages, 1.2, true, true, 100, true, true, false, "cholecystectomy", "cholecystectomy_grasp", 0, "0.0003")->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DeviceTicks, gap_insert_from_3s_surface_stages, 3.0, true, true, 0, false, false, true, "gap", "gap_insert")->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
#endif

/// Sums the haptic tick's stage times and the physical steps' times.
class StageTimes : public ReplayObserver {
 public:
  HapticTiming sum;
  std::vector<double> tick_total;
  double step_sum = 0;
  long steps = 0;
  void on_tick(const World&, const HapticSide& h, double) override {
    const HapticTiming& t = h.timing;
    sum.device += t.device;
    sum.physical_sync += t.physical_sync;
    sum.grasp += t.grasp;
    sum.virtual_mesh += t.virtual_mesh;
    sum.virtual_tool += t.virtual_tool;
    sum.output += t.output;
    sum.total += t.total;
    tick_total.push_back(t.total);
  }
  void on_step(const World&, const PhysicalSide& p, double) override {
    step_sum += p.report.time_s;
    ++steps;
  }
};

/// EBH_BENCH_REPLAY_S (default 10): seconds of the recording to replay. host_tool: the virtual
/// tool on the host (ReplayOptions::device_tick off); per_period: a launch per physical period
/// (ReplayOptions::steps_in_launches off).
void BM_ReplayGrasp(benchmark::State& st, Backend backend, bool host_tool = false, bool per_period = false) {
  if (backend == Backend::Cuda && !device_ready(st)) return;
  const char* env = std::getenv("EBH_BENCH_REPLAY_S");
  const double duration = env ? std::atof(env) : 10.0;
  LoadedReplay in = load_replay_inputs("cholecystectomy", "cholecystectomy_grasp", {}, std::nullopt, std::nullopt,
                                       false, backend);
  ReplayOptions opt;
  opt.mode = Mode::Async;
  opt.duration = duration;
  opt.device_tick = !host_tool;
  opt.steps_in_launches = !per_period;
  StageTimes times;
  ReplaySummary s;
  for (auto _ : st) {
    times = StageTimes{};
    s = replay(*in.world, in.recording, opt, times);
    st.SetIterationTime(s.wall_s);
  }
  const double n = static_cast<double>(std::max<std::int64_t>(s.ticks, 1));
  st.counters["realtime_x"] = s.wall_s > 0 ? s.virtual_s / s.wall_s : 0;
  st.counters["ticks"] = static_cast<double>(s.ticks);
  st.counters["tick_mean_us"] = 1e6 * times.sum.total / n;
  st.counters["tick_median_us"] = 1e6 * percentile(times.tick_total, 0.5);
  st.counters["tick_p99_us"] = 1e6 * percentile(times.tick_total, 0.99);
  st.counters["sync_us"] = 1e6 * times.sum.physical_sync / n;
  st.counters["grasp_us"] = 1e6 * times.sum.grasp / n;
  st.counters["vmesh_us"] = 1e6 * times.sum.virtual_mesh / n;
  st.counters["vtool_us"] = 1e6 * times.sum.virtual_tool / n;
  st.counters["output_us"] = 1e6 * times.sum.output / n;
  st.counters["step_mean_us"] = times.steps ? 1e6 * times.step_sum / static_cast<double>(times.steps) : 0;
}
BENCHMARK_CAPTURE(BM_ReplayGrasp, cpu, Backend::Cpu)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReplayGrasp, cuda, Backend::Cuda)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReplayGrasp, cuda_host_tool, Backend::Cuda, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReplayGrasp, cuda_launch_per_period, Backend::Cuda, false, true)->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
