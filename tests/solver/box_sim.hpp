#pragma once
// The solver tests' fixture: a structured box of tets (bottom face pinned) with its virtual mesh,
// the physical and virtual models and state built from it; and a bitwise check across OpenMP
// thread counts.
#include <gtest/gtest.h>
#include <omp.h>

#include <atomic>
#include <cstring>
#include <span>
#include <thread>
#include <vector>

#include "mesh/box_mesh.hpp"
#include "mesh/degrade.hpp"
#include "scene/scene.hpp"
#include "solver/physical_mesh.hpp"
#include "solver/shared_loops.hpp"
#include "solver/virtual_mesh.hpp"

namespace ebh::test {

using Method = SolverSpec::Method;

/// A 12 x 12 x 24 mm block of tets, bottom face pinned, with virtual mesh = boundary (refine r).
inline Scene box_scene(int nx, int ny, int nz, int refine = 0) {
  Scene scene;
  scene.spec.file = "box (in code)";
  scene.spec.virtual_refine = refine;
  scene.physical = make_box_tets({0, 0, 0}, {0.012, 0.012, 0.024}, nx, ny, nz);
  for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i)
    if (scene.physical.vertices[i].z == 0.0) scene.pinned.push_back(i);
  return scene;
}

/// A 24 x 24 x 48 mm block (6 x 6 x 12 cells, 2160 tets), bottom pinned, k_vol 5 kPa; with
/// `quality` < 1 some of its interior tets degraded to that mean ratio.
inline Scene degraded_block(double quality) {
  Scene scene;
  scene.spec.file = "block (in code)";
  scene.spec.stiffness.k_vol = 5000;
  scene.physical = make_box_tets({0, 0, 0}, {0.024, 0.024, 0.048}, 6, 6, 12);
  for (int i = 0; i < static_cast<int>(scene.physical.vertices.size()); ++i)
    if (scene.physical.vertices[i].z == 0.0) scene.pinned.push_back(i);
  if (quality < 1) {
    DegradeOptions o;
    o.target_quality = quality;
    o.tets = 12;
    degrade_physical_mesh(scene, o);
  }
  return scene;
}

struct Sim {
  Scene scene;
  VirtualModel vm;
  PhysicalModel pm;
  PhysicalState ps;
  PhysicalWorkspace pw;
  explicit Sim(Scene s, bool coupled = true) : scene(std::move(s)) {
    vm = build_virtual_model(scene);
    pm = build_physical_model(scene, coupled ? &vm : nullptr, {});
    ps = make_physical_state(pm);
    pw = make_physical_workspace(pm);
  }
  /// A sideways and downward velocity field growing with height: a swaying block.
  void perturb() {
    for (int a = 0; a < pm.num_vertices; ++a)
      if (!pm.pinned[a]) ps.v[a] = Vec3d{2.0, -1.0, -0.5} * (pm.rest[a].z / 0.024);
  }
  std::span<const Vec3d> q() const { return pm.num_virtual ? std::span<const Vec3d>(vm.rest) : std::span<const Vec3d>(); }
};

inline double max_diff(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, norm(a[i] - b[i]));
  return d;
}

/// run() twice, with one and with two OpenMP threads: the two results must be bitwise equal.
template <class Run>
void expect_bitwise_equal_across_threads(Run run) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::vector<Vec3d> one = run();
  omp_set_num_threads(2);
  const std::vector<Vec3d> two = run();
  omp_set_num_threads(saved);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(Vec3d)), 0);
}

/// run(&shared) with a thread helping with `shared`'s loops (SharedLoops::help_until, as a replay's
/// other side does), the first chunk of every loop left to the helper so that both threads take
/// part however a loaded machine schedules them; then run(nullptr): the two results must be
/// bitwise equal.
template <class Run>
void expect_bitwise_equal_with_a_helper(Run run) {
  SharedLoops shared;
  std::atomic<bool> done{false};
  shared.leave_first_chunk_to_helper(true);
  std::thread helper([&] { shared.help_until([&] { return done.load(); }); });
  const std::vector<Vec3d> helped = run(&shared);
  done = true;
  helper.join();
  EXPECT_GT(shared.helped_chunks(), 0u) << "the helper never took a chunk";
  const std::vector<Vec3d> alone = run(nullptr);
  ASSERT_EQ(helped.size(), alone.size());
  EXPECT_EQ(std::memcmp(helped.data(), alone.data(), alone.size() * sizeof(Vec3d)), 0);
}

}  // namespace ebh::test
