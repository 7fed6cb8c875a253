#pragma once
// Force-quality metrics of a replay (docs/METRICS.md defines each one and says why it matters):
// smoothness (peak force, dF/dt, per-tick force change, jumps at physical-frame boundaries,
// high-frequency force power), passivity (Hannaford & Ryu 2002 passivity observer), coupling
// stretch, penetration, force-limit clamping and haptic-tick timing.
//
// NaN policy: every metric that reads a non-finite sample is NaN itself (null in JSON);
// nonfinite_count says how many samples were non-finite and finite == false flags the run.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/json.hpp"
#include "metrics/replay_trace.hpp"

namespace ebh {

/// The most contact episodes whose metrics a run keeps (ForceMetrics::episodes; episode_count
/// counts them all): a contact that flickers every other tick, with --merge-gap-ms 0, made a
/// million episodes of 10 million ticks, whose JSON took 5.8 GB of memory.
inline constexpr std::size_t kMaxListedEpisodes = 10000;

struct MetricsOptions {
  /// Contact episodes separated by fewer contact-free seconds than this are one episode
  /// (a tool sliding over a surface drops and regains contact for a tick or two). 5 ms.
  double episode_merge_gap_s = 0.005;
  /// Metrics of the first this many episodes are kept (kMaxListedEpisodes), the rest counted.
  std::size_t max_episodes = kMaxListedEpisodes;
  /// FFT window length in ticks (a power of two); 0: by the output's haptic rate, kFftWindowS of
  /// ticks (fft_window_ticks: 256 ticks and 3.9 Hz bins at 1 kHz, 2048 at 10 kHz). And the shortest
  /// window used, in ticks (shorter segments get NaN spectral fractions); 0: kFftMinWindowS of
  /// ticks (64 at 1 kHz). A window of fixed ticks at 10 kHz had 39 Hz bins: every bin but the
  /// mean's lay above 30 Hz.
  std::size_t fft_window = 0;
  std::size_t fft_min_window = 0;
  /// Haptic-tick budget for the over-budget count, s; 0: one tick at the replay's haptic rate
  /// (1 ms at 1 kHz), the deadline a real-time run must meet.
  double tick_budget_s = 0;
};

/// Metrics over one run of ticks [first, last] (the whole replay or one contact episode).
struct SegmentMetrics {
  std::size_t first = 0, last = 0;  // tick indices, inclusive
  double t_begin = 0, t_end = 0;    // s
  std::size_t ticks = 0;

  double peak_force = 0;       // max |F_n|, N
  double peak_torque = 0;      // max |T_n|, N m
  double max_force_rate = 0;   // max |F_n - F_{n-1}| / (t_n - t_{n-1}), N/s
  double rms_force_step = 0;   // sqrt(mean |F_n - F_{n-1}|^2), N
  // Physical-frame boundaries: ticks n with tick number round(t_n H) % (H/P) == 0, where a new
  // physical result became visible. Means of |F_n - F_{n-1}| on those and on the other ticks.
  double boundary_step_mean = 0;  // N
  double interior_step_mean = 0;  // N
  double boundary_step_ratio = 0; // boundary / interior; NaN if both 0, +inf if only interior is 0
  std::size_t boundary_ticks = 0, interior_ticks = 0;
  // Fraction of force fluctuation power above 30 and 100 Hz (signal::power_spectrum).
  double power_above_30hz = 0;
  double power_above_100hz = 0;
  std::size_t fft_window = 0;  // ticks per window the spectrum used (the option's, or the segment's power of two)
  // Passivity observer (Hannaford & Ryu 2002), energy the device puts into the environment:
  // E(n) = -sum_{m=first+1..n} F_{m-1} . (x_m - x_{m-1}), x the physical tool position and
  // F_{m-1} the force displayed (zero-order hold) while it moved. Rotational part likewise with
  // the torque and the physical tool's rotation vector. J.
  double passivity_energy_final = 0;
  double passivity_energy_min = 0;
  double passivity_time_negative_s = 0;  // sum of tick periods with E(n) < 0, s
  double passivity_energy_rot_final = 0;
  double passivity_energy_rot_min = 0;
  // Coupling stretch between the virtual tool (g) and the physical tool (h).
  double stretch_max = 0, stretch_mean = 0;              // |P_g - P_h|, m
  double stretch_angle_max = 0, stretch_angle_mean = 0;  // theta(R_g, R_h), rad
  // Penetration (m): virtual tool, and physical tool when the file has it (else NaN).
  double penetration_max = 0, penetration_p99 = 0;
  double penetration_physical_max = 0, penetration_physical_p99 = 0;
  double clamped_fraction = 0;  // ticks with force_clamped != 0 / ticks
};

struct TimingMetrics {
  std::size_t ticks = 0;
  double p50 = 0, p99 = 0, p999 = 0, max = 0, mean = 0;  // haptic tick time, s
  std::size_t over_budget = 0;                           // ticks with time > tick_budget_s
  double budget_s = 0;
  // Physical step, over the steps that ran (NaN when the file has no /timing/physical_step_s).
  double physical_p50 = 0, physical_p99 = 0, physical_max = 0;
  // Physical solver (NaN when absent): mean and max iterations over the steps that ran, max residual.
  double physical_iterations_mean = 0, physical_iterations_max = 0, physical_residual_max = 0;
  /// Steps skipped with their state held (/physical/slept: solver.sleep, solver.physical_region),
  /// left out of the step's time and iterations.
  std::size_t physical_steps_skipped = 0;
  /// The most physical tets inverted after a step (/physical/inverted; NaN when absent).
  double physical_inverted_max = 0;
};

/// The default FFT window, s, and the shortest one: bins of 3.9 and 15.6 Hz, the latter the coarsest
/// that places 30 Hz.
inline constexpr double kFftWindowS = 0.256, kFftMinWindowS = 0.064;

/// The FFT window in ticks for an output at haptic_hz: opt.fft_window, or the power of two at or
/// below kFftWindowS of ticks.
std::size_t fft_window_ticks(const MetricsOptions& opt, double haptic_hz);

/// The shortest FFT window in ticks for an output at haptic_hz: opt.fft_min_window, or
/// kFftMinWindowS of ticks, rounded up.
std::size_t fft_min_window_ticks(const MetricsOptions& opt, double haptic_hz);

/// Force fluctuations (RMS about the segment's mean) below this are round-off, not rendering (a
/// run without contact leaves |F| ~ 1e-15 N): the spectral fractions of such a segment are 0 and
/// its frame-boundary ratio NaN, where they scored noise as vibration (0.88 above 30 Hz). N.
inline constexpr double kNegligibleForce = 1e-9;

/// A tool that passed through the tissue: the rendered force fell below kCollapseFraction of the
/// largest it had been in the kCollapseWindowS before, which was at least kCollapseMinForceN with
/// contacts, and stayed under half of that for kCollapseWindowS after, with contacts in most of
/// those ticks, while the tool kept its contacts, nothing
/// was grasped (from kCollapseWindowS before the largest force) and the device did not draw back
/// along that force (a release, a retreat and a slide
/// off an edge lose their contacts or draw back). With vertex contact the vertices under a thin
/// tip part and let it through (docs/MODEL.md, "Contact against the surface"); with surface
/// contact the tissue gave way.
/// A slower fall counts too (a slow press parts the vertices over ~0.1 s, and a sideways remainder
/// keeps |F| above the fraction): the force against the device's motion over the last
/// kPressedWindowS fell below kCollapseFraction of its largest in that window (at least
/// kCollapseMinForceN, in contact), the device having pressed on by kPressedOnM since that largest,
/// in contact in most ticks since, and stayed under half of it for kCollapseWindowS, in contact,
/// nothing grasped.
struct ForceCollapse {
  double peak_t = 0, t = 0;         ///< s: the largest force's tick, the first tick under the fraction
  double peak_N = 0, force_N = 0;   ///< |F| at those ticks; a slower fall: the force against the device's motion
  double pressed_on_m = 0;          ///< a slower fall: how far the device pressed on between them (0: a fast one)
  std::size_t count = 0;            ///< collapses in the run (the first is described)
};
/// "t = 0.420 s" for a time of a replay (its /haptic/t counts from the window's start), and where
/// that is in the recording when the replay began `start_s` s into it ("t = 0.420 s, 3.420 s into
/// the recording"): the warnings' one way to name a time.
std::string replay_time_text(double t, double start_s);

inline constexpr double kCollapseFraction = 0.2;
inline constexpr double kCollapseMinForceN = 0.1;
inline constexpr double kCollapseWindowS = 0.02;
inline constexpr double kPressedWindowS = 0.5;
inline constexpr double kPressedOnM = 0.5e-3;

/// The first collapse of a run's force (ForceCollapse) and how many there were; nullopt when none.
/// Per tick n of N: time t[n], the rendered force, the device's position, the contacts, the
/// grasped vertices (empty: none grasped) and the jaw (empty: none). A fall while the jaws moved
/// by more than kCollapseJawMove is the tool's own shape changing (forceps closed in the tissue and
/// opened there), not the tissue giving way: not a collapse.
std::optional<ForceCollapse> find_force_collapse(std::span<const double> t, const std::function<Vec3d(std::size_t)>& force,
                                                 const std::function<Vec3d(std::size_t)>& device,
                                                 std::span<const std::int32_t> contacts,
                                                 std::span<const std::int32_t> grasped, std::span<const double> jaw,
                                                 double haptic_hz);
/// A twentieth of the jaw's range: the committed grasps' jaws close and open by up to 0.12 in
/// 20 ms, in steps of ~3e-3 a sample, and a fall within such a move is the jaws'.
inline constexpr double kCollapseJawMove = 0.05;
/// One line for a collapse: what fell, when, and what it means (`vertex_contact`: the scene's
/// contact model where known).
std::string collapse_warning(const ForceCollapse& c, std::optional<bool> vertex_contact, double start_s = 0);

/// The force held at the device's limit (force_clamped) for kSaturatedRunS or more in a row: the
/// model's force was larger, and what the user feels and the metrics measure is the limit (a
/// 2 m/s flick through an own block held it 1.3 s, the virtual tool caught 14 mm below the device;
/// the committed grasps reach it for at most 0.41 s at a time).
inline constexpr double kSaturatedRunS = 1.0;
/// ... or at it in more than this fraction of the ticks, in runs shorter than that, over a window
/// of at least kSaturatedMinWindowS: a replay shorter than kSaturatedRunS has no such run (tube_insert
/// with k_con 1e5 over 0.9 s: 69% of the ticks at the limit, 0.62 s in a row at most).
inline constexpr double kSaturatedFraction = 0.5;
inline constexpr double kSaturatedMinWindowS = 0.2;
struct ForceSaturation {
  double start_t = 0, seconds = 0;  ///< the longest run: its first tick's time and its length
  double fraction = 0;              ///< of all ticks at the limit
};
std::optional<ForceSaturation> find_force_saturation(std::span<const double> t, std::span<const std::uint8_t> clamped,
                                                     double haptic_hz);
std::string saturation_warning(const ForceSaturation& s, double start_s = 0);

/// A force that fell while the device held still in contact (or grasping): in ebh not the tissue
/// relaxing but the coupled meshes settling, a mode at a time, at a rate set by k_svc and the
/// physical rate (docs/MODEL.md, "Held loads": a hook held 178 s in the tube fell from 0.073 to
/// 0.030 N, a held grasp from 1.07 to 0.36 N, still falling), which a user reads as stress
/// relaxation of the tissue. A hold: the device within kHeldStillM of where it began, in contact
/// or grasping every tick, for kHeldMinS or more; its force over a second from kHeldSettleS after it
/// began (the dent's own settling left out) against its last second's, a fall of more than
/// kHeldFallFraction from at least kHeldMinForceN. The largest such fall, and how many holds fell.
inline constexpr double kHeldStillM = 0.5e-3;
inline constexpr double kHeldMinS = 5.0;
inline constexpr double kHeldSettleS = 0.5;
inline constexpr double kHeldFallFraction = 0.2;
inline constexpr double kHeldMinForceN = 0.05;
struct HeldRelaxation {
  double start_t = 0, seconds = 0;  ///< the hold: its first tick's time and its length
  double from_N = 0, to_N = 0;      ///< mean |F| over its second from kHeldSettleS and over its last second
  std::size_t count = 0;            ///< holds whose force fell so
};
std::optional<HeldRelaxation> find_held_relaxation(std::span<const double> t,
                                                   const std::function<Vec3d(std::size_t)>& force,
                                                   const std::function<Vec3d(std::size_t)>& device,
                                                   std::span<const std::int32_t> contacts,
                                                   std::span<const std::int32_t> grasped);
/// One line for it (times as replay_time_text gives them).
std::string held_relaxation_warning(const HeldRelaxation& h, double start_s = 0);

/// The translational passivity observer (Hannaford & Ryu 2002) over ticks [first, last]: E(n) =
/// -sum of F(k-1) . (x(k) - x(k-1)), the energy into the environment through the device port with a
/// zero-order hold; its last value, its least, and the seconds it spent below 0.
struct PassivityEnergy {
  double final = 0, min = 0, time_negative_s = 0;
};
PassivityEnergy passivity_energy(std::span<const double> t, const std::function<Vec3d(std::size_t)>& force,
                                 const std::function<Vec3d(std::size_t)>& device, std::size_t first, std::size_t last);

/// Energy the rendering fed the user beyond which a replay and `ebh metrics` say so: the committed
/// recordings' observers stay at 0 (round-off, 1e-22 J); a hook vibrated at 40 Hz, +-3 mm, in the
/// gynaecology_hook uterus went to -0.028 J (below 0 for 2.6 s).
inline constexpr double kActiveEnergyJ = 1e-3;

/// "" or the line for an observer that went below -kActiveEnergyJ: the rendering fed energy to the
/// user, a precursor of oscillation on a device.
std::string passivity_warning(const PassivityEnergy& e, std::optional<bool> vertex_contact);

struct ForceMetrics {
  std::string path, scene, recording, mode, backend;
  /// whether the replay's contact was the paper's vertex contact (its contact attribute); nullopt
  /// for an older output without one: the warnings then name both
  std::optional<bool> vertex_contact;
  double haptic_hz = 0, physical_hz = 0;
  double start_s = 0;    // s into the recording where the replay began (its times count from there)
  long frame_ticks = 0;  // N = H/P
  double duration_s = 0;
  MetricsOptions options;  ///< as used: fft_window and fft_min_window in this output's ticks

  SegmentMetrics whole;
  std::vector<SegmentMetrics> episodes;  // contact episodes in time order, the first options.max_episodes
  std::size_t episode_count = 0;         // contact episodes in all
  double contact_fraction = 0;           // ticks with contacts > 0 / ticks
  std::string contact_warning;           // contact_warning(): empty when the tool touched enough
  std::optional<ForceCollapse> collapse; // find_force_collapse(): the tool passed through the tissue
  std::optional<ForceSaturation> saturation;  // find_force_saturation(): the force held at the limit
  std::optional<HeldRelaxation> held;         // find_held_relaxation(): a held force that fell
  TimingMetrics timing;

  std::size_t nonfinite_count = 0;               // non-finite samples over all datasets
  std::vector<std::string> nonfinite_datasets;   // "/haptic/force: 3", one per dataset with any
  bool finite = true;
};

/// Under this fraction of ticks in contact a run says so: the force metrics of a replay where the
/// tool (almost) never touched the tissue describe free motion, not haptic rendering, and a
/// trajectory that misses the tissue is most often a frame or unit mistake.
inline constexpr double kLowContactFraction = 0.01;

/// "the tool never touched the tissue (no tick with contacts > 0)" when contact_ticks is 0,
/// "the tool touched the tissue in only K of N ticks (P%)" when under kLowContactFraction of
/// them, empty otherwise (and for a run of no ticks). `ebh replay` and `ebh metrics` say it.
std::string contact_warning(std::size_t contact_ticks, std::size_t ticks);

/// A replay from a recording's first sample whose physical tool starts inside the tissue (its
/// depth at the first tick, penetration_physical, m, > 0): "the physical tool starts inside the
/// tissue (1.3 mm deep at the first tick): ..." naming the likely fixes, a tool transform (a device
/// log starts with the tool free; a tool frame left flipped puts the shaft through the tissue), or
/// the log's unit or world transform (a cm log read in mm lands 10x nearer the origin).
/// Forceps whose jaws hold vertices at the first tick (`first_tick_grasped` > 0: closed on the
/// tissue from the first sample, which penetration does not count) start inside it too. Empty when
/// it starts free. With `surface_contact` (the scene's `contact: surface`) a tool started inside
/// holds the surface from inside and drags it out as it leaves: said too. `ebh replay` says it.
std::string start_warning(double first_tick_penetration_physical, int first_tick_grasped = 0,
                          bool surface_contact = false);

/// Contact episodes: maximal runs of ticks with contacts > 0, two runs merged when the
/// contact-free gap between them lasts less than merge_gap_s (gap ticks / H). Pairs of tick
/// indices [first, last], inclusive.
std::vector<std::pair<std::size_t, std::size_t>> contact_episodes(const std::vector<std::int32_t>& contacts,
                                                                  double haptic_hz, double merge_gap_s);

/// Metrics of ticks [first, last] of a trace (first <= last < ticks).
SegmentMetrics segment_metrics(const ReplayTrace& tr, std::size_t first, std::size_t last,
                               const MetricsOptions& opt = {});

ForceMetrics compute_metrics(const ReplayTrace& tr, const MetricsOptions& opt = {});

/// The non-finite samples of a trace, as compute_metrics counts them (its nonfinite_count and
/// nonfinite_datasets), without the metrics: what a caller that only refuses them needs.
struct NonfiniteSamples {
  std::size_t count = 0;              ///< over all datasets
  std::vector<std::string> datasets;  ///< "/haptic/force: 3", one per dataset with any
};
NonfiniteSamples nonfinite_samples(const ReplayTrace& tr);

/// JSON (SI units; key names carry the unit suffix where there is one). NaN and inf print null.
/// With episodes: "episodes" (those kept) and "episodes_listed" (how many: below "episode_count"
/// where more than options.max_episodes).
Json to_json(const ForceMetrics& m, bool with_episodes = true);

/// "" when every contact episode is kept, else "1000000 contact episodes; the metrics of the first
/// 10000 are listed (...)": what the table and `ebh metrics --episodes` say.
std::string episodes_not_listed(const ForceMetrics& m);

/// A readable table for the terminal; episodes listed one a line when with_episodes (those kept,
/// and a line saying how many more there were).
std::string format_table(const ForceMetrics& m, bool with_episodes);

}  // namespace ebh
