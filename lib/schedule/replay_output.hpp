#pragma once
// The replay output file (docs/FORMATS.md, "Replay output"): an HDF5 file whose datasets all have
// time as their first dimension, written under a temporary name and renamed when complete.
//   /haptic/{t, force, torque, force_clamped, torque_clamped, pose_physical, pose_virtual,
//            penetration, penetration_physical, contacts, grasped, jaw}
//   /physical/{t, iterations, residual, residual_reduction, recovered}
//   /timing/{haptic_step_s, device_s, physical_sync_s, grasp_s, virtual_mesh_s, virtual_tool_s,
//            output_s, physical_step_s, physical_local_s, physical_global_s}
//   /frames/{t, virtual_positions, physical_positions, tool_poses, jaw}   (with --frames-hz)
//   /mesh/{virtual_rest, virtual_triangles, physical_rest, physical_tets, physical_boundary}
//   root attributes: what makes the run traceable and repeatable (docs/FORMATS.md): the absolute
//   path and SHA-256 of every input file, the resolved scene as YAML (scene_yaml), the --set
//   overrides, the pose transforms, the replayed window, mode, backend, device, version, commit, build type, compiler,
//   threads, every parameter of the scene (stiffness, solver, tool geometry in metres, rates) and
//   the pinned regions.
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "io/h5.hpp"
#include "mesh/quality.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/scheduler.hpp"

namespace ebh {

struct ReplayMetadata {
  std::string recording;          ///< the recording's path (stored absolute, with its SHA-256)
  double start = 0;               ///< ReplayOptions::start, s
  double duration = 0;            ///< ReplayOptions::duration, s (0: the rest of the recording)
  double frames_hz = 0;           ///< ReplayOptions::frames_hz
  std::string mode = "async";
  std::string backend = "cpu";
  std::string device;             ///< e.g. the CPU model
  ThreadSplit threads;            ///< the OpenMP threads per side (split_threads); written for the CPU backend
  std::vector<std::string> overrides;  ///< --set key=value, as given
  ReplayTransformOptions transforms;   ///< --transform, --tool-transform, as given
  PoseTransforms applied;              ///< what the recording's poses got (options or its attributes)
  /// The input files' SHA-256 by path, shared by the writers of one batch (ebh replay --batch) so
  /// that each file is hashed once; null: each writer hashes its inputs. Writers that share it
  /// are made on one thread.
  std::map<std::string, std::string>* digests = nullptr;
};

/// The largest output a replay writes (docs/FORMATS.md, Limits). Mesh snapshots go to the file as
/// they come, so the output's size bounds them; the ticks are bounded by kMaxReplayTicks
/// (scheduler.hpp) because the writer keeps every tick's row in memory until the end.
inline constexpr double kMaxReplayOutputBytes = 256.0 * (1ull << 30);
/// /haptic and /timing: 31 float64, 2 uint8 and 2 int32 values per tick.
inline constexpr double kReplayBytesPerTick = 31 * 8 + 2 * 1 + 2 * 4;

/// What a replay of `duration` seconds with `frames_hz` snapshots per second (0: none) makes.
struct ReplaySize {
  double ticks = 0, frames = 0;
  double memory_bytes = 0;  ///< per-tick and per-step rows the writer holds
  double file_bytes = 0;    ///< rows, snapshots and the rest meshes
};
ReplaySize estimate_replay_size(const World& world, double duration, double frames_hz);

/// Throws InputError before anything is allocated when the replay passes a limit: too many ticks
/// ("RECORDING: replaying 1e+300 s at 1000 Hz makes 1e+303 ticks; the limit is ...") or too large
/// an output ("OUT: ... snapshots ... the limit is 256 GiB"), or an output larger than its
/// folder's file system has free (io/paths.hpp, free_bytes_for).
void check_replay_size(const World& world, double duration, double frames_hz, const std::string& recording,
                       const std::string& output);

/// Collects a replay and writes it. Per-tick and per-step rows are buffered (reserved for the
/// whole replay, so a tick does not allocate); frames are appended to the file as they come.
/// What a step of a fixed iteration count is judged against (mesh weights): the tolerance for
/// solver.method: direct, the default tolerance under physical_tolerance 0 (the paper's fixed K);
/// 0 where the stopping rule decides (an iterative method with a tolerance).
double short_step_yardstick(const PhysicalStepParams& params);

class ReplayWriter : public ReplayObserver {
 public:
  /// Opens OUT under its temporary name. expected_ticks sizes the buffers.
  ReplayWriter(const std::string& out_path, const World& world, const ReplayMetadata& meta,
               std::int64_t expected_ticks, bool frames);

  void on_tick(const World& world, const HapticSide& haptic, double t) override;
  void on_step(const World& world, const PhysicalSide& physical, double t) override;
  void on_frame(const World& world, const HapticSide& haptic, double t) override;
  bool should_stop() override;

  /// Writes the buffered datasets and the summary attributes, then renames the file into place.
  void commit(const ReplaySummary& summary);
  /// commit() in two halves: finish() writes and syncs the file under temp_path(), where it can be
  /// read (the frames of `ebh replay --render` are rendered from it); publish() renames it into place.
  void finish(const ReplaySummary& summary);
  void publish() { out_.publish(); }
  const std::string& temp_path() const { return out_.temp_path(); }

  // What was recorded so far, for the end-of-run summary.
  double peak_force() const { return peak_force_; }
  double peak_torque() const { return peak_torque_; }
  double max_penetration() const { return max_penetration_; }
  std::int64_t clamped_ticks() const { return clamped_; }
  std::int64_t contact_ticks() const { return in_contact_; }  ///< ticks with contacts > 0
  /// Ticks whose force met the limit with no contact (the virtual tool far behind the device), and
  /// the device's longest move in one tick (m).
  std::int64_t free_clamped_ticks() const { return free_clamped_; }
  double max_device_step() const { return max_device_step_; }
  /// Ticks in which the device moved farther than the virtual tool's Newton calls reach in one
  /// (tool.max_step x its steps a tick): the tool lags the device there.
  std::int64_t outpaced_ticks() const { return outpaced_; }
  double tool_reach() const { return reach_; }  ///< m a tick
  /// The same for turns: ticks in which the device turned farther than the Newton calls turn the
  /// virtual tool in one (tool.max_step_rotation_deg x its steps a tick, at most 0.5 rad), the
  /// largest turn of the device in one tick (rad), and that reach (rad a tick).
  std::int64_t outturned_ticks() const { return outturned_; }
  double max_device_turn() const { return max_device_turn_; }
  double tool_turn_reach() const { return turn_reach_; }
  /// Ticks whose torque met tool.torque_limit with no contact: the coupling's twist, not tissue.
  std::int64_t free_torque_clamped_ticks() const { return free_torque_clamped_; }
  std::int64_t recovered_steps() const { return recovered_steps_; }  ///< steps redone with the direct solve
  double recovery_factorize_s() const { return recovery_factorize_s_; }  ///< s the first one's factorisation took
  /// Steps that ran solver.physical_max_iterations and still left more than the tolerance.
  std::int64_t capped_steps() const { return capped_steps_; }
  /// Steps the stopping rule ended on a stall (no 5% gain for 8 iterations) before the cap, with
  /// more than kStalledResidualFactor times the tolerance left (and at most recovery_residual), the
  /// largest such residual and the first one's time.
  std::int64_t stalled_steps() const { return stalled_steps_; }
  double max_stalled() const { return max_stalled_; }
  double first_stalled_t() const { return first_stalled_t_; }
  /// Steps of a fixed iteration count (solver.method: direct, which has no stopping rule, or
  /// solver.physical_tolerance 0) that left more than kStalledResidualFactor times
  /// short_step_yardstick unbalanced (and at most recovery_residual), the largest such residual and
  /// the first one's time.
  std::int64_t short_steps() const { return short_steps_; }
  double max_short() const { return max_short_; }
  double first_short_t() const { return first_short_t_; }
  /// Steps that ended with more than solver.recovery_residual mesh weights unbalanced (a recovered
  /// step's residual is the direct solve's), the largest such residual and the first one's time.
  std::int64_t unbalanced_steps() const { return unbalanced_steps_; }
  double max_unbalanced() const { return max_unbalanced_; }
  double first_unbalanced_t() const { return first_unbalanced_t_; }
  /// Physical steps skipped while the physical mesh slept (solver.sleep).
  std::int64_t slept_steps() const { return slept_steps_; }
  /// Physical vertices iterated per step on average under solver.physical_region (-1: off).
  double awake_mean() const;
  /// Virtual vertices iterated per tick on average under solver.active_region (-1: off).
  double active_mean() const;
  /// The most physical tets inverted (or flat) after one step, and the first step's time with any.
  int max_inverted_tets() const { return inverted_tets_.most; }
  double first_inverted_t() const { return first_inverted_t_; }
  /// The physical tool's depth in the tissue at the first tick (m; 0 before any tick).
  double first_penetration_physical() const { return pen_h_.empty() ? 0.0 : pen_h_.front(); }
  /// The per-tick series as recorded, for the end-of-run checks (metrics/force_metrics.hpp,
  /// find_force_collapse): times, rendered forces, the device's positions, contacts, grasped.
  std::span<const double> tick_times() const { return t_; }
  std::span<const std::uint8_t> force_clamped() const { return fclamp_; }
  Vec3d force_at(std::size_t n) const { return {force_[3 * n], force_[3 * n + 1], force_[3 * n + 2]}; }
  Vec3d device_position_at(std::size_t n) const { return {pose_h_[7 * n], pose_h_[7 * n + 1], pose_h_[7 * n + 2]}; }
  std::span<const std::int32_t> contacts() const { return contacts_; }
  std::span<const std::int32_t> grasped() const { return grasped_; }
  std::span<const double> jaw() const { return jaw_; }
  std::span<const std::uint8_t> torque_clamped() const { return tclamp_; }

 private:
  h5::AtomicFile out_;
  // /haptic and /timing per tick
  std::vector<double> t_, force_, torque_, pose_h_, pose_g_, pen_, pen_h_, jaw_;
  std::vector<std::uint8_t> fclamp_, tclamp_;
  std::vector<std::int32_t> contacts_, grasped_, active_;
  std::vector<double> tm_total_, tm_device_, tm_sync_, tm_grasp_, tm_vmesh_, tm_vtool_, tm_output_;
  // /physical per step
  std::vector<double> pt_, residual_, reduction_, tm_step_, tm_local_, tm_global_;
  std::vector<std::int32_t> iterations_, inverted_, awake_;
  InvertedTets inverted_tets_;  ///< the physical tets inverted after each step, against rest
  double first_inverted_t_ = -1;
  std::vector<std::uint8_t> recovered_, slept_;
  std::int64_t slept_steps_ = 0;
  // /frames
  bool frames_ = false;
  h5::Appender<double> f_t_, f_jaw_;
  h5::Appender<float> f_q_, f_x_;
  h5::Appender<double> f_pose_;
  std::vector<float> scratch_f_;
  double peak_force_ = 0, peak_torque_ = 0, max_penetration_ = 0;
  std::int64_t clamped_ = 0, in_contact_ = 0, recovered_steps_ = 0, capped_steps_ = 0, unbalanced_steps_ = 0;
  double recovery_factorize_s_ = 0;
  double max_unbalanced_ = 0, first_unbalanced_t_ = -1;
  std::int64_t stalled_steps_ = 0, free_clamped_ = 0, outpaced_ = 0, outturned_ = 0, free_torque_clamped_ = 0;
  double reach_ = 0;  // m a tick: the virtual tool's Newton calls' reach (tool.max_step x steps a tick)
  double turn_reach_ = 0, max_device_turn_ = 0;  // rad a tick: the same for turns; the device's largest
  double max_device_step_ = 0;
  double max_stalled_ = 0, first_stalled_t_ = -1;
  std::int64_t short_steps_ = 0;
  double max_short_ = 0, first_short_t_ = -1;
};

/// The CPU's model name (from /proc/cpuinfo), for the `device` attribute.
std::string cpu_description();

}  // namespace ebh
