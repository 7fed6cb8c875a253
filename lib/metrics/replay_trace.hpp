#pragma once
// A replay's output (docs/FORMATS.md, "Replay output") held in memory for analysis: the haptic-rate arrays, the
// physical-rate arrays and the timings. Time is the first dimension of every array.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

/// A rigid pose as stored in /haptic/pose_* rows: (px, py, pz, qw, qx, qy, qz), metres.
struct TracePose {
  Vec3d p;
  Quatd q;
};

struct ReplayTrace {
  std::string path;  // the file it was read from (for messages)

  // Root attributes.
  double haptic_hz = 0;    // H: haptic ticks per second
  double physical_hz = 0;  // P: physical steps per second
  std::string mode;        // async, lockstep or realtime ("" when absent)
  std::string scene, recording, backend, version;
  std::string contact;     // the scene's contact model, vertices or surface ("" in an older output)
  double start = 0;        // s into the recording where the replay began (its t = 0; 0 when absent)

  // Haptic rate, N ticks each.
  std::vector<double> t;                   // N, s
  std::vector<Vec3d> force;                // N, N (what the tissue pushes on the tool; rendered to the device)
  std::vector<Vec3d> torque;               // N, N m
  std::vector<std::uint8_t> force_clamped; // N, 1 when the force was clamped at the device limit
  std::vector<TracePose> pose_physical;    // N, the physical tool (device) pose
  std::vector<TracePose> pose_virtual;     // N, the virtual tool pose
  std::vector<double> penetration;         // N, m, deepest virtual-mesh vertex inside the virtual tool
  std::vector<double> penetration_physical;// N or empty (optional dataset), m, same for the physical tool
  std::vector<std::int32_t> contacts;      // N, number of contact constraints
  std::vector<double> active;              // N or empty (optional dataset: solver.active_region), virtual vertices iterated
  std::vector<std::int32_t> grasped;       // N or empty (optional dataset), virtual vertices grasped
  std::vector<double> jaw;                 // N or empty (optional dataset), the device's jaw, 0 closed .. 1 open

  // Physical rate, K steps each; empty when the file has no /physical group.
  std::vector<double> physical_t;           // K, s
  std::vector<double> physical_iterations;  // K
  std::vector<double> physical_residual;    // K
  std::vector<double> physical_inverted;    // K (empty in files written before /physical/inverted)
  std::vector<double> physical_awake;       // K or empty (optional dataset: solver.physical_region), free vertices iterated
  std::vector<double> physical_slept;       // K or empty (optional dataset), 1 where the step was skipped, its state held

  // Timing: /timing/haptic_step_s (N, s) is required, /timing/physical_step_s (K, s) optional.
  std::vector<double> haptic_step_s;
  std::vector<double> physical_step_s;

  std::size_t ticks() const { return t.size(); }
  /// Haptic ticks per physical step: round(H / P), at least 1.
  long frame_ticks() const;
};

/// The largest magnitude of a value a replay output holds (a force in N, a torque in N m, a length
/// in m, a time in s, a count): beyond it the file is corrupt or edited, as no replay writes one (its
/// force is clamped at the device's limit, its tools stay within a few metres of a scene at most 2 m
/// across). The metrics square and multiply pairs of values (norms, RMS, energies): below it these
/// stay finite, where a force of 1.4e154 N gave |F| = inf from finite samples.
inline constexpr double kMaxReplayValue = 1e30;

/// The highest haptic rate of a replay output, Hz: a scene's (time.haptic_hz, scene/scene.hpp
/// kMaxHapticHz). With ticks at least half a period apart it bounds the rates the metrics divide by.
inline constexpr double kMaxReplayHapticHz = 100e3;

/// How far the norm of a pose's quaternion in a replay output may be from 1. The replay writes its
/// poses in double, normalised (the virtual tool's every Newton step, the physical tool's slerped
/// between normalised samples): off by a few 1e-16. 1e-6 still takes a file whose poses went
/// through float32 (a relative 6e-8 a component) or were printed to 7 digits; a quaternion further
/// off was written by no replay (a recording's 1e-3, kQuatNormTolerance, is for 4-digit device logs).
inline constexpr double kPoseQuatNormTolerance = 1e-6;

/// Reads a replay output file. Required: root attributes haptic_hz and physical_hz; datasets
/// /haptic/{t, force, torque, force_clamped, pose_physical, pose_virtual, penetration, contacts}
/// and /timing/haptic_step_s. Optional: /haptic/penetration_physical, /haptic/active,
/// /haptic/grasped, /physical/{t, iterations, residual, inverted, awake}, /timing/physical_step_s. Numeric types are converted to the fields' types.
/// Throws InputError ("FILE: dataset '/haptic/force': ...") for a missing file, a missing
/// dataset or attribute, a wrong shape, a non-numeric dataset, a string attribute that is not one
/// string (the root's `scene`, `mode`, ...; a dataset's `unit`), a `mode` or `contact` no replay
/// writes, a time axis that holds a non-finite time, goes backwards or whose ticks are less than
/// half a haptic period apart, a haptic rate above kMaxReplayHapticHz,
/// a finite value beyond kMaxReplayValue, or a pose whose finite quaternion is no unit quaternion
/// (all zero, which normalises to NaN, or a norm off 1 by more than kPoseQuatNormTolerance)
/// (naming the dataset and the index).
/// Non-finite values other than times are kept: compute_metrics counts them.
ReplayTrace load_replay(const std::string& path);

}  // namespace ebh
