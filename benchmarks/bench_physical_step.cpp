// Physical step time (Algorithm 1) per scene and method at 16 local-global iterations, the
// virtual mesh's haptic tick (4 Jacobi iterations with contacts, Algorithm 2's soft part), and the
// rotation-extraction micro-benchmark (Mueller 2016 warm-started vs SVD). The physical state is
// restored before each timed step (outside the timing), so every step is the same step.
// Threads: OMP_NUM_THREADS (the physical step uses the OpenMP team); the virtual tick's argument
// is its team (0: the calling thread).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <map>
#include <memory>
#include <random>
#include <string>

#include "core/error.hpp"
#include "energy/polar_svd.hpp"
#include "energy/rotation.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/degrade.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/virtual_mesh.hpp"

namespace {
using namespace ebh;

struct Loaded {
  Scene scene;
  VirtualModel vm;
  PhysicalModel pm;
  PhysicalState start;
};

/// Loads a scene once ("box8k" is generated: 10 x 10 x 13 cells, 7800 tets; "NAME@Q" is scene
/// NAME with its physical mesh degraded to a worst mean ratio Q, mesh/degrade.hpp). Null if missing.
const Loaded* load(const std::string& name, std::string& error) {
  static std::map<std::string, std::unique_ptr<Loaded>> cache;
  static std::map<std::string, std::string> errors;
  if (auto it = cache.find(name); it != cache.end()) return it->second.get();
  if (auto it = errors.find(name); it != errors.end()) { error = it->second; return nullptr; }
  auto L = std::make_unique<Loaded>();
  try {
    if (name == "box8k") {
      L->scene.spec.file = "box8k";
      L->scene.physical = make_box_tets({0, 0, 0}, {0.05, 0.05, 0.065}, 10, 10, 13);
      for (int i = 0; i < static_cast<int>(L->scene.physical.vertices.size()); ++i)
        if (L->scene.physical.vertices[i].z == 0.0) L->scene.pinned.push_back(i);
    } else {
      const std::size_t at = name.find('@');
      L->scene = load_scene(resolve_scene_path(name.substr(0, at)));
      if (at != std::string::npos) {
        DegradeOptions d;
        d.target_quality = std::stod(name.substr(at + 1));
        degrade_physical_mesh(L->scene, d);
      }
    }
    L->vm = build_virtual_model(L->scene);
    PhysicalModelOptions options = physical_model_options(L->scene.spec);
    options.factorize = true;  // every method is benchmarked on it
    L->pm = build_physical_model(L->scene, &L->vm, options);
  } catch (const std::exception& e) {
    errors[name] = error = e.what();
    return nullptr;
  }
  // A deformed starting state: a few steps from a downward velocity bump on the top half.
  L->start = make_physical_state(L->pm);
  double zmax = -1e9, zmin = 1e9;
  for (const Vec3d& x : L->pm.rest) { zmax = std::max(zmax, x.z); zmin = std::min(zmin, x.z); }
  for (int a = 0; a < L->pm.num_vertices; ++a)
    if (!L->pm.pinned[a] && L->pm.rest[a].z > (zmin + zmax) / 2) L->start.v[a] = Vec3d{0.1, 0, -0.3};
  PhysicalWorkspace ws = make_physical_workspace(L->pm);
  for (int s = 0; s < 3; ++s) physical_step(L->pm, ws, L->start, L->vm.rest, PhysicalStepParams{});
  return (cache[name] = std::move(L)).get();
}

void BM_PhysicalStep(benchmark::State& st, std::string scene, SolverSpec::Method method) {
  std::string error;
  const Loaded* L = load(scene, error);
  if (!L) { st.SkipWithError(error.c_str()); return; }
  PhysicalWorkspace ws = make_physical_workspace(L->pm);
  PhysicalState state = L->start;
  PhysicalStepParams params;
  params.method = method;
  params.iterations = 16;
  double local = 0, global = 0;
  for (auto _ : st) {
    st.PauseTiming();
    state.x = L->start.x;  // same sizes: copies, no allocation
    state.v = L->start.v;
    state.rotation = L->start.rotation;
    st.ResumeTiming();
    const PhysicalStepReport rep = physical_step(L->pm, ws, state, L->vm.rest, params);
    local += rep.local_s;
    global += rep.global_s;
  }
  st.counters["tets"] = L->pm.num_tets;
  st.counters["local_ms"] = 1e3 * local / st.iterations();
  st.counters["global_ms"] = 1e3 * global / st.iterations();
}

/// What the replay adds after every physical step: the health check (physical_state_problem).
void BM_HealthCheck(benchmark::State& st, std::string scene) {
  std::string error;
  const Loaded* L = load(scene, error);
  if (!L) { st.SkipWithError(error.c_str()); return; }
  PhysicalStepReport report;
  for (auto _ : st) benchmark::DoNotOptimize(physical_state_problem(L->pm, L->start.x, report));
  st.counters["vertices"] = L->pm.num_vertices;
}

/// What the recovery (solver.recovery) adds before every CPU step: saving the step's start state.
void BM_RecoverySnapshot(benchmark::State& st, std::string scene) {
  std::string error;
  const Loaded* L = load(scene, error);
  if (!L) { st.SkipWithError(error.c_str()); return; }
  PhysicalState start = L->start;
  for (auto _ : st) {
    start = L->start;
    benchmark::DoNotOptimize(start.x.data());
  }
  st.counters["vertices"] = L->pm.num_vertices;
}

/// Building the physical model: the global matrix, the diagonal (with the bounded one's Lanczos
/// estimates) and, for the direct method, its factorisation.
void BM_PhysicalModelBuild(benchmark::State& st, std::string scene, SolverSpec::Diagonal diagonal, bool factorize) {
  std::string error;
  const Loaded* L = load(scene, error);
  if (!L) { st.SkipWithError(error.c_str()); return; }
  PhysicalModelOptions options = physical_model_options(L->scene.spec);
  options.diagonal = diagonal;
  options.factorize = factorize;
  double theta = 0;
  for (auto _ : st) theta = build_physical_model(L->scene, &L->vm, options).diag_theta;
  st.counters["theta"] = theta;
}

/// One haptic tick of the virtual mesh: begin (E_svc targets, prediction), 4 iterations against
/// contacts pressing the 64 highest vertices 1 mm down, end (velocities). Ticks follow each other
/// (the cost does not depend on the state).
/// The same tick on an OpenMP team of st.range(0) threads (parallel_min_vertices = 0), as the
/// replays' haptic side iterates with more than one thread (schedule/scheduler.cpp).
void BM_VirtualTick(benchmark::State& st, std::string scene) {
  std::string error;
  const Loaded* L = load(scene, error);
  if (!L) { st.SkipWithError(error.c_str()); return; }
  VirtualModel vm = L->vm;
  const int saved_threads = omp_get_max_threads();
  if (st.range(0) > 0) {
    vm.parallel_min_vertices = 0;
    omp_set_num_threads(static_cast<int>(st.range(0)));
  }
  VirtualState vs = make_virtual_state(vm);
  VirtualWorkspace vw = make_virtual_workspace(vm);
  std::vector<int> order(vm.num_vertices);
  for (int j = 0; j < vm.num_vertices; ++j) order[j] = j;
  const int c = std::min(64, vm.num_vertices);
  std::partial_sort(order.begin(), order.begin() + c, order.end(),
                    [&](int a, int b) { return vm.rest[a].z > vm.rest[b].z; });
  std::vector<ContactTarget> contacts;
  for (int i = 0; i < c; ++i) contacts.push_back({order[i], vm.rest[order[i]] - Vec3d{0, 0, 0.001}, 400.0});
  for (auto _ : st) {
    virtual_begin_tick(vm, vw, vs, L->start.x, 0.001);
    for (int i = 0; i < 4; ++i) virtual_iteration(vm, vw, vs, contacts);
    virtual_end_tick(vm, vw, vs);
  }
  omp_set_num_threads(saved_threads);
  st.counters["vertices"] = vm.num_vertices;
  st.counters["edges"] = static_cast<double>(vm.edges.size());
}

/// 4096 deformation gradients near rotations, and their rotations one step earlier (warm start).
struct RotationData {
  std::vector<Mat3d> F;
  std::vector<Quatd> warm;
  RotationData() {
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 4096; ++i) {
      const Quatd q = quat_from_rotvec(Vec3d{3 * u(rng), 3 * u(rng), 3 * u(rng)});
      Mat3d S = Mat3d::identity();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) S.m[r][c] += 0.1 * u(rng);
      F.push_back(to_matrix(q) * S);
      warm.push_back(normalized(quat_from_rotvec(Vec3d{0.02 * u(rng), 0.02 * u(rng), 0.02 * u(rng)}) * q));
    }
  }
};

void BM_RotationMuellerWarm(benchmark::State& st) {
  static const RotationData d;
  const int iters = static_cast<int>(st.range(0));
  for (auto _ : st)
    for (size_t i = 0; i < d.F.size(); ++i) benchmark::DoNotOptimize(extract_rotation(d.F[i], d.warm[i], iters, 0.0));
  st.SetItemsProcessed(st.iterations() * d.F.size());
}

void BM_RotationSvd(benchmark::State& st) {
  static const RotationData d;
  for (auto _ : st)
    for (size_t i = 0; i < d.F.size(); ++i) benchmark::DoNotOptimize(polar_rotation_svd(d.F[i]));
  st.SetItemsProcessed(st.iterations() * d.F.size());
}

}  // namespace

BENCHMARK(BM_RotationMuellerWarm)->Arg(1)->Arg(3)->Arg(10);
BENCHMARK(BM_RotationSvd);

#define EBH_SCENE_BENCH(scene)                                                                            \
  BENCHMARK_CAPTURE(BM_PhysicalStep, scene##_jacobi, #scene, SolverSpec::Method::Jacobi)->Unit(benchmark::kMillisecond);  \
  BENCHMARK_CAPTURE(BM_PhysicalStep, scene##_chebyshev, #scene, SolverSpec::Method::Chebyshev)->Unit(benchmark::kMillisecond); \
  BENCHMARK_CAPTURE(BM_PhysicalStep, scene##_direct, #scene, SolverSpec::Method::Direct)->Unit(benchmark::kMillisecond);
// Argument: the team's threads (0: the calling thread alone, as a 1-thread haptic side runs).
BENCHMARK_CAPTURE(BM_VirtualTick, tube, "tube")->Arg(0)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_VirtualTick, cholecystectomy, "cholecystectomy")->Arg(0)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMicrosecond);

EBH_SCENE_BENCH(box8k)
EBH_SCENE_BENCH(tube)
EBH_SCENE_BENCH(gap)
EBH_SCENE_BENCH(cholecystectomy)
EBH_SCENE_BENCH(gynaecology)

// Meshes with slivers (the bounded diagonal at work; the plain one diverges on them).
BENCHMARK_CAPTURE(BM_PhysicalStep, cholecystectomy_q002_chebyshev, "cholecystectomy@0.02", SolverSpec::Method::Chebyshev)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PhysicalStep, cholecystectomy_q002_direct, "cholecystectomy@0.02", SolverSpec::Method::Direct)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_HealthCheck, tube, "tube")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HealthCheck, cholecystectomy, "cholecystectomy")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_RecoverySnapshot, cholecystectomy, "cholecystectomy")->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_PhysicalModelBuild, cholecystectomy_plain, "cholecystectomy", SolverSpec::Diagonal::Plain, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PhysicalModelBuild, cholecystectomy_bounded, "cholecystectomy", SolverSpec::Diagonal::Bounded, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PhysicalModelBuild, cholecystectomy_q002_bounded, "cholecystectomy@0.02", SolverSpec::Diagonal::Bounded, false)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
