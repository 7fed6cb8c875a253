#pragma once
// Device recordings (docs/FORMATS.md, "Recordings"): one tool trajectory per HDF5 file.
//   /trajectory/t            (N,)   float64  s      strictly increasing
//   /trajectory/position     (N, 3) float64  m      tool frame origin (shaft's distal end), world
//   /trajectory/orientation  (N, 4) float64  1      unit quaternion (w, x, y, z), tool -> world
//   /trajectory/jaw          (N,)   float64  1      0 closed .. 1 open
//   /trajectory/buttons      (N,)   uint8    bitmask  bit i = device button i pressed
//   root attributes: rate_hz, source ("synthetic" | "device"), scene, tool, description
//   (optional: generator — the command that made the file; world_transform, tool_transform —
//    (7,) float64 tx ty tz (m) qw qx qy qz: the poses are still in a device's frames and replay
//    maps them with p' = R_w (p + q t_T) + t_w, q' = q_w q q_T; io/pose_transform.hpp;
//    baked_world_transform, baked_tool_transform — the same layout: already in the poses)
// Every dataset has a `unit` attribute. See docs/FORMATS.md.
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "io/pose_transform.hpp"
#include "math/vec.hpp"

namespace ebh {

struct Recording {
  std::vector<double> t;             ///< N sample times, s, strictly increasing
  std::vector<Vec3d> position;       ///< N tool-frame origins, m
  std::vector<Quatd> orientation;    ///< N unit quaternions (w, x, y, z)
  std::vector<double> jaw;           ///< N jaw openings, 0 closed .. 1 open
  std::vector<std::uint8_t> buttons; ///< N button bitmasks
  double rate_hz = 1000.0;           ///< nominal sample rate
  std::string source = "synthetic";  ///< "synthetic" or "device"
  std::string scene;                 ///< scenario to replay it with (scenarios/NAME.yaml)
  std::string tool;                  ///< "hook" or "forceps"
  std::string description;
  std::string generator;             ///< command and version that produced it (optional)
  /// Transforms stored with the poses (attributes world_transform, tool_transform): the poses are
  /// in a device's frames until replay applies them and clears this (schedule/replay_inputs.hpp),
  /// so no pose is transformed twice. `ebh import` bakes its transforms instead and leaves it empty.
  PoseTransforms transforms;
  /// Transforms already in the poses (attributes baked_world_transform, baked_tool_transform): a
  /// record, never applied; replay refuses an option of the same kind, which would apply a second
  /// one. `ebh import` writes what it baked; applying `transforms` moves them here.
  PoseTransforms baked;
  /// The axis (x, y or z) of a left-handed log that `ebh import --mirror` reversed (attribute
  /// baked_mirror): a record, as `baked` is; "" for a right-handed log.
  std::string baked_mirror;

  /// Where read_recording read a window of the file, not all of it: the file's first and last
  /// sample times (a replay's --start counts from the first; its length is the file's), the file's
  /// row of sample 0 (messages name the file's rows), and the whole file's poses at a stride of at
  /// most kOutlineSamples, with their times, the path whose length unit check_recording_scale
  /// judges (the transforms apply to them too).
  struct FileSpan {
    double t_first = 0, t_last = 0;
    std::size_t first_row = 0;
    std::vector<Vec3d> outline;
    std::vector<Quatd> outline_orientation;
    std::size_t outline_stride = 1;  ///< outline pose i is the file's row i x outline_stride
    std::vector<double> outline_t;   ///< outline pose i's time, s (the file's, as t)
  };
  std::optional<FileSpan> span;

  std::size_t size() const { return t.size(); }
  /// The recording's first and last times: the file's, also where only a window was read.
  double start_time() const { return span ? span->t_first : t.front(); }
  double end_time() const { return span ? span->t_last : t.back(); }
  double duration() const { return t.empty() ? 0.0 : end_time() - start_time(); }
  /// The file's row of sample i.
  std::size_t row(std::size_t i) const { return span ? span->first_row + i : i; }
  /// Whether the samples are the whole file's: read whole, or through a window that holds all of it
  /// (a replay reads through its window even without --start or --duration).
  bool whole_file() const { return !span || (span->first_row == 0 && !t.empty() && t.back() == span->t_last); }
};

/// The most poses of a recording's outline (Recording::FileSpan): 0.1 s apart in 3 hours at 1 kHz.
inline constexpr std::size_t kOutlineSamples = 1 << 17;

/// The part of a recording a replay plays: from `start` s after its first sample, for `duration`
/// s (0: to its end).
struct RecordingWindow {
  double start = 0;
  double duration = 0;
};

/// The device state at one instant.
struct DeviceSample {
  double t = 0;
  Vec3d position;
  Quatd orientation;
  double jaw = 1;
  std::uint8_t buttons = 0;
};

/// Names a defective sample in an error message: where(dataset, index) -> "rec.h5: /trajectory/t[12]"
/// for a file, "log.txt:15" for a text log.
using SampleLocator = std::function<std::string(std::string_view dataset, std::size_t index)>;

/// A device samples at most as fast as a haptic loop ticks (scene/scene.hpp kMaxHapticHz).
inline constexpr double kMaxSampleRateHz = 100e3;
/// The most samples a recording is made with (synth) or read with (read_recording counts the rows
/// a file declares before reading any): 10 million is 2.8 hours at 1 kHz and about 2 GB of memory
/// while it is written (~200 bytes a sample: the samples, a validated copy and the packed
/// datasets; docs/FORMATS.md, Limits).
inline constexpr double kMaxRecordingSamples = 10e6;

/// Checks a recording sample by sample and normalises its quaternions in place (and flips each
/// to the hemisphere of its predecessor so interpolation takes the short arc). Throws InputError
/// "WHERE: what" for: fewer than two samples (a trajectory has a duration), length mismatch,
/// NaN/Inf, time not strictly increasing, a quaternion whose
/// norm is off by more than kQuatNormTolerance, a jaw outside [0, 1] (beyond kJawTolerance).
void validate_recording(Recording& rec, const std::string& file, const SampleLocator& where);
/// What is wrong with a sample at time `t` (s) after one at `previous`: not finite, not after it
/// (and, for equal times far from 0, the rounding that makes them equal). Empty when nothing is.
std::optional<std::string> time_defect(double previous, double t);
inline constexpr double kQuatNormTolerance = 1e-3;  // float32 round trips and 4-digit logs pass
inline constexpr double kJawTolerance = 1e-9;       // jaw in [-tol, 1 + tol] is clamped to [0, 1]

/// Reads and validates a recording (messages name the file, dataset and sample index), a part of
/// its rows at a time (a file written in chunks of a few rows takes no more memory than another).
/// With a window, it keeps only the samples a replay of the window interpolates (from the last at
/// or before its start to the second at or after its end) and an outline of the whole path
/// (Recording::span): every sample is still read and checked, and the window's samples are the
/// ones a whole read gives, bit for bit; a few seconds of a log of hours take a few seconds'
/// memory, and the checks of a replay's path see the part it replays.
Recording read_recording(const std::string& path, std::optional<RecordingWindow> window = std::nullopt);
/// Validates and writes a recording atomically (temporary name, renamed when complete).
void write_recording(const std::string& path, const Recording& rec);

/// Applies the recording's stored transforms (rec.transforms) to its poses and moves them to
/// rec.baked: afterwards the poses are in ebh's frames and nothing is left to apply a second time.
/// The result is validated again (a huge translation overflows), messages naming `file`.
void apply_stored_transforms(Recording& rec, const std::string& file);

/// The device state at time t: linear position and jaw, slerp orientation, buttons of the last
/// sample at or before t; clamped to the first/last sample outside the recording. O(log N).
DeviceSample sample_at(const Recording& rec, double t);

/// How far outside the physical mesh's bounding box (diagonal D) a replay accepts the tool: D, at
/// least 0.1 m (a handle may start well away from the tissue; a unit mistake puts it tens to
/// thousands of scene sizes away). `ebh replay` refuses a recording beyond it (without
/// --allow-outside); `ebh import --scene` warns of one, and never names a unit that lands there.
inline double replay_outside_margin(double diagonal) { return diagonal > 0.1 ? diagonal : 0.1; }

/// A glitch in a path (a corrupt line of a log): the few samples (at most max(2, N/500)) that lie
/// farther from the box of the others than that box's diagonal (at least kGlitchMinDistance),
/// the farthest first; empty when there are none, or more (the path itself), or under 20 samples.
std::vector<std::size_t> glitch_samples(const std::vector<Vec3d>& path);
inline constexpr double kGlitchMinDistance = 0.01;  ///< m

/// A one-line message when the trajectory lies outside the scene's bounding box enlarged by
/// `margin` metres on every side (a recording in mm read as m lands kilometres away), naming the
/// farthest sample; nullopt when it fits.
std::optional<std::string> check_recording_in_scene(const Recording& rec, Vec3d bbox_min, Vec3d bbox_max,
                                                    double margin);

/// Unit sanity (docs/FORMATS.md, "Unit sanity"): a trajectory whose extent (the diagonal of its
/// positions' bounding box) is over kPathExtentMaxRatio or under kPathExtentMinRatio times the
/// diagonal D of a physical mesh's bounding box (lo, hi), or whose every sample lies farther than
/// kPathMaxDistanceDiagonals D from that box, was most likely read in the wrong length unit or
/// not placed at the mesh (a path that never moves is judged by its place alone). Returns one line
/// saying so and naming the likely fix: the unit among m, cm, mm (inches named beside it where they would fit too) under which the path fits and
/// enters the mesh's box, as a tool at work does ("--unit cm" when `log_unit_m`, the metres per
/// unit the log was read with, is known, as at import; "the log is in cm, not mm: ebh import
/// --unit cm" when it is not, as at replay); else, for a path of the right size, a world
/// transform; else the unit that fits it nearest the mesh; else the unit that gives it the mesh's
/// size, and a world transform to place it. nullopt when the path fits. A warning,
/// not an error: a user may have reasons.
std::optional<std::string> check_recording_scale(const Recording& rec, Vec3d lo, Vec3d hi,
                                                 std::optional<double> log_unit_m);

/// A jump in the log (a dropped stretch, a device reset, a glitch): the fastest move between two
/// consecutive samples, when it is over kToolSpeedMax, as one line naming the samples, their times,
/// the distance and the speed; nullopt when every move is slower. A hand moves an instrument at
/// ~0.5 m/s at most (surgical motions ~0.1 m/s); a replay passes through a jump in one tick. A
/// warning, not an error: the jump may be the experiment.
std::optional<std::string> check_recording_speed(const Recording& rec);

/// A replay's line for times that do not go with the recording's rate_hz: their median interval a
/// rate over kMaxSampleRateHz, or more than kRateMismatch times from rate_hz either way (times in
/// ms, which a replay reads as seconds and plays 1000 times slower than the device moved). A file
/// of another program's; nullopt where the two agree (gaps and holds leave the median be).
std::optional<std::string> check_recording_rate(const Recording& rec);
inline constexpr double kRateMismatch = 50;

/// The median interval between consecutive times (at least three; else 0): a device's sampling
/// period, which gaps and holds leave be where the mean takes them in.
double median_interval(const std::vector<double>& t);

/// Gaps in a log's times (times increasing, at least three): intervals over kLogGapFactor times the
/// median one and over two intervals of the slowest device (kDeviceRateLowHz, io/import.hpp): how
/// many, the longest's index i (between samples i and i + 1) and the median interval; nullopt
/// without one. `ebh import` and a replay (check_recording_gaps) say them. An interval whose end
/// sample `still(i + 1)` holds the pose of its start is no gap (nothing moved across it).
struct LogGaps {
  std::size_t count = 0, longest = 0;
  double median = 0;
};
std::optional<LogGaps> find_log_gaps(const std::vector<double>& t,
                                     const std::function<bool(std::size_t)>& still = nullptr);

/// A replay's line for gaps in a recording's times (find_log_gaps), naming its samples: a recording
/// written by another program, which `ebh import` did not check; nullopt without one. A hold the
/// device kept still across (two samples alike: `ebh import --drop-repeats` keeps a hold's first
/// and last) is no gap: the replay holds the tool there as the device did.
std::optional<std::string> check_recording_gaps(const Recording& rec);

/// A log of a device slower than its logger: the samples repeat between the device's updates, so
/// the pose (position, orientation, jaw, buttons) changes only every `period`-th sample, at regular
/// intervals (a 100 Hz device logged at 1 kHz: every 10th). Found when, of at least
/// kStaleMinChanges changes, kStaleRegularFraction or more lie `period` >= 2 samples after the
/// one before: an encoder-quantised device repeats samples too (30-60% of the committed
/// recordings'), but changes after 1, 2, 3 ... samples as the motion crosses its steps. nullopt
/// otherwise. `ebh import` and a replay say it: a replay holds the tool and jumps it every period,
/// a ripple at the device's rate in the force.
/// Whether sample i (>= 1) repeats sample i - 1 exactly: position, orientation, `jaw` (the
/// recording's, or a log's own values before --jaw-range maps them) and buttons. A jaw or buttons
/// shorter than the samples (a recording made in code without them) count as repeating. The one
/// definition of a repeat: import's stale samples and holds, find_stale_samples' changes.
bool repeats_previous(const Recording& rec, std::size_t i, std::span<const double> jaw);

/// The times button `bit` goes down in `buttons` (pressed at the first sample counts once): a
/// grasp each where a device without a gripper grasps with it (import --jaw-button).
std::size_t button_presses(std::span<const std::uint8_t> buttons, int bit);

struct StaleSamples {
  std::size_t period = 0;   ///< samples between changes
  std::size_t changes = 0;  ///< samples that differ from the one before
  double regular = 0;       ///< fraction of the intervals between changes that are `period`
};
inline constexpr std::size_t kStaleMinChanges = 50;
inline constexpr double kStaleRegularFraction = 0.8;
std::optional<StaleSamples> find_stale_samples(const Recording& rec);
/// One line for find_stale_samples' finding (the device's rate from the recording's times).
std::optional<std::string> check_recording_stale(const Recording& rec);

/// The same for the tool's orientation: the fastest turn between two consecutive samples, when it
/// is over kToolTurnRateMax, as one line naming the samples, their times, the angle and the rate.
/// A hand turns an instrument at a few rad/s; the virtual tool follows a faster turn at
/// tool.max_step_rotation_deg a Newton step and renders its lag as torque meanwhile (a half turn
/// between two samples is also the shorter arc either way: the direction is a guess).
std::optional<std::string> check_recording_turn(const Recording& rec);

/// The seconds a replay of a recording `length` s long runs from `start` for `duration` s (nullopt:
/// to its end; a window past the end is cut there): start a finite number >= 0 before the end,
/// duration a finite number > 0, and the window at least one haptic tick of `h_haptic` s (the
/// world's World::h_haptic, or 1 / the scene's haptic_hz under its overrides: a shorter one
/// replays a single tick, tick_count's, with no force step to measure). The one check of a replay
/// window, for `ebh replay --start --duration`, `ebh gate`'s cases, `ebh bench sizes` and a sweep
/// plan's window: throws InputError "START_LABEL VALUE: ..." or "DURATION_LABEL VALUE: ..." naming
/// `recording` (a duration under one tick names the duration; a window cut under one tick by the
/// recording's end, the start).
double replay_window(double start, std::optional<double> duration, double length, double h_haptic,
                     const std::string& recording, const std::string& start_label, const std::string& duration_label);
inline constexpr double kToolSpeedMax = 10;  ///< m/s
inline constexpr double kToolTurnRateMax = 50;  ///< rad/s (8 turns a second)
inline constexpr double kPathExtentMaxRatio = 20;
inline constexpr double kPathExtentMinRatio = 1.0 / 50;
inline constexpr double kPathMaxDistanceDiagonals = 2;

}  // namespace ebh
