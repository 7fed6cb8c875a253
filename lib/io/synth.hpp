#pragma once
// Synthetic device recordings from a plan of timed waypoints (`ebh synth`, docs/FORMATS.md):
//   minimum-jerk motion between consecutive waypoints (position, orientation by slerp with the
//   same minimum-jerk timing, jaw), plus physiological tremor (a sum of sinusoids in 8-12 Hz with
//   seeded random frequencies and phases) and the device's position quantisation, sampled at
//   rate_hz. Deterministic: the same plan and seed give bitwise the same recording everywhere
//   (the generator is a hand-written splitmix64, not std:: distributions whose output differs
//   between standard libraries).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "io/recording.hpp"
#include "math/vec.hpp"

namespace ebh {

struct PlanWaypoint {
  double t = 0;              ///< s
  Vec3d position;            ///< m (the plan file gives mm)
  Quatd orientation;         ///< the plan file gives a rotation vector in degrees
  double jaw = 1;            ///< 0 closed .. 1 open
  std::uint8_t buttons = 0;  ///< held from this waypoint until the next
};

struct SynthPlan {
  std::string file;  ///< the plan file (messages name it)
  /// The recording's scene: a name as given, or a scene file's path as given (relative to the
  /// plan's folder; `ebh synth` stores it relative to the recording's, scene_attribute_for).
  std::string scene, description;
  std::string tool;    ///< hook or forceps; "" where the plan leaves it to the scene (`ebh synth` takes the scene's)
  int scene_line = 0;  ///< the plan's line of `scene` (1 based; 0: unknown), for messages
  int tool_line = 0;   ///< the plan's line of `tool`, likewise
  double rate_hz = 1000;
  double tremor_amplitude = 0.1e-3;         ///< m, per axis, amplitude of the equivalent single sinusoid
  double tremor_band_lo = 8, tremor_band_hi = 12;  ///< Hz
  int tremor_components = 3;                ///< sinusoids per axis
  double quantum = 0.055e-3;                ///< m, position resolution of the device (0 = off)
  std::vector<PlanWaypoint> waypoints;      ///< t strictly increasing, the first at t >= 0
};

/// Reads a YAML plan; errors are "FILE:LINE: key 'KEY': what" (yaml_key_error). `rate_hz` (`ebh synth --rate`) replaces
/// the plan's rate_hz before the checks that depend on it.
SynthPlan read_plan(const std::string& path, std::optional<double> rate_hz = std::nullopt);

/// The plan's fastest move and fastest turn, when over a hand's (kToolSpeedMax, kToolTurnRateMax):
/// one line each naming the two waypoints, their times and the segment's peak rate (a minimum-jerk
/// segment peaks at 1.875 times its mean: 15/8). Most likely a waypoint in the wrong unit (t in
/// ms, a position in m read as mm); warnings, not errors: the plan may mean it.
std::vector<std::string> plan_rate_warnings(const SynthPlan& plan);

/// Minimum-jerk profile s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 on [0, 1] (clamped outside):
/// s, ds/dtau and d2s/dtau2 vanish appropriately at both ends (Flash & Hogan 1985).
double minimum_jerk(double tau);

/// The smooth planned pose at time t (no tremor, no quantisation), clamped at the ends.
DeviceSample plan_pose(const SynthPlan& plan, double t);

/// Tremor: per axis a sum of `components` sinusoids of amplitude A / sqrt(components) (so its
/// RMS is A / sqrt(2), that of one sinusoid of amplitude A), frequencies uniform in the band,
/// phases uniform in [0, 2 pi), drawn from `seed`.
class Tremor {
 public:
  Tremor(const SynthPlan& plan, std::uint64_t seed);
  Vec3d operator()(double t) const;

 private:
  struct Component { double amplitude, omega, phase; };
  std::vector<Component> axes_[3];
};

/// Samples at t_i = i / rate_hz for i = 0 .. floor(t_last * rate_hz): plan pose + tremor,
/// position rounded to multiples of plan.quantum. source = "synthetic". Throws InputError naming
/// the plan when that is fewer than two samples or more than kMaxRecordingSamples (counted before
/// anything is allocated).
Recording synthesize(const SynthPlan& plan, std::uint64_t seed);

}  // namespace ebh
