#pragma once
// The schedule tests' capture of a tube_insert replay (the sleeping and region tests): per tick the
// force and contact count, per step whether it slept, its iterations and awake count, and the last
// step's physical positions; and the checks those tests share on tube_insert's scene keys.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "core/error.hpp"
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

/// Two captures of one replay are the same to the bit: forces, each step's sleep and awake count,
/// the last step's positions.
inline void expect_same_bits(const Capture& a, const Capture& b) {
  ASSERT_EQ(b.force.size(), a.force.size());
  EXPECT_EQ(std::memcmp(b.force.data(), a.force.data(), a.force.size() * sizeof(Vec3d)), 0);
  EXPECT_EQ(b.slept, a.slept);
  EXPECT_EQ(b.awake, a.awake);
  ASSERT_EQ(b.x.size(), a.x.size());
  EXPECT_EQ(std::memcmp(b.x.data(), a.x.data(), a.x.size() * sizeof(Vec3d)), 0);
}

/// Loading tube_insert with the overrides `set` fails with an InputError whose message names `key`.
inline void expect_load_error_naming(const std::vector<std::string>& set, const std::string& key) {
  try {
    load_replay_inputs("tube", "tube_insert", set, std::nullopt, std::nullopt, false);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}

/// tube_insert loaded for `backend` with the override `set`.
inline LoadedReplay load_tube_insert(const std::string& set, Backend backend) {
  return load_replay_inputs("tube", "tube_insert", {set}, std::nullopt, std::nullopt, false, backend);
}

/// The replay's one-line warnings that name the scene key `key`.
inline int one_line_warnings_naming(const LoadedReplay& in, const std::string& key) {
  int warned = 0;
  for (const std::string& w : in.world->scene.warnings)
    if (w.find("key '" + key + "'") != std::string::npos && w.find('\n') == std::string::npos) ++warned;
  return warned;
}

}  // namespace ebh::test
