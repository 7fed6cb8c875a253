#pragma once
// The schedule tests' capture of a tube_insert replay (the sleeping and awake-region tests): per
// tick the force and contact count, per step whether it slept, its iterations and awake count,
// and the last step's physical positions.
#include <omp.h>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

namespace ebh::test {

struct Capture : ReplayObserver {
  std::vector<Vec3d> force;
  std::vector<int> contacts;                  // per tick
  std::vector<int> slept, iterations, awake;  // per step
  std::vector<Vec3d> x;                       // the last step's
  int free = 0;                               // the physical mesh's free vertices
  void on_tick(const World&, const HapticSide& h, double) override {
    force.push_back(h.output.force);
    contacts.push_back(h.contact_count);
  }
  void on_step(const World& w, const PhysicalSide& p, double) override {
    slept.push_back(p.slept ? 1 : 0);
    iterations.push_back(p.report.iterations);
    awake.push_back(p.report.awake);
    x = p.mesh.x;
    free = w.physical_mesh.num_free;
  }
  int slept_steps() const {
    int n = 0;
    for (const int s : slept) n += s;
    return n;
  }
};

/// tube_insert from `start` for `duration` s, async, with the scene override `set` ("key=value");
/// `threads` > 0: that many OpenMP threads.
inline Capture run_tube_insert(const std::string& set, double start, double duration, int threads = 0) {
  const LoadedReplay in = load_replay_inputs("tube", "tube_insert", {set}, std::nullopt, std::nullopt, false);
  ReplayOptions opt;
  opt.start = start;
  opt.duration = duration;
  const int saved = omp_get_max_threads();
  if (threads > 0) omp_set_num_threads(threads);
  Capture c;
  replay(*in.world, in.recording, opt, c);
  omp_set_num_threads(saved);
  return c;
}

inline double max_force_difference(const Capture& a, const Capture& b) {
  double m = 0;
  for (std::size_t n = 0; n < a.force.size() && n < b.force.size(); ++n) m = std::max(m, norm(a.force[n] - b.force[n]));
  return m;
}

}  // namespace ebh::test
