// Force-quality metrics of a replay. Definitions: force_metrics.hpp and docs/METRICS.md.
#include "metrics/force_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <sstream>

#include "core/error.hpp"
#include "metrics/signal.hpp"

namespace ebh {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Running maximum that turns NaN once it sees a NaN (the NaN policy of force_metrics.hpp).
struct NanMax {
  double v;
  explicit NanMax(double start = 0) : v(start) {}
  void add(double x) { v = (std::isnan(x) || std::isnan(v)) ? kNaN : std::max(v, x); }
};
struct NanMin {
  double v;
  explicit NanMin(double start = 0) : v(start) {}
  void add(double x) { v = (std::isnan(x) || std::isnan(v)) ? kNaN : std::min(v, x); }
};

double mean_or_nan(double sum, std::size_t n) { return n ? sum / static_cast<double>(n) : kNaN; }

/// Angle of the rotation taking R_h to R_g, in [0, pi].
double rotation_angle(Quatd g, Quatd h) { return norm(rotvec_from_quat(normalized(g * conjugate(h)))); }

template <class T>
std::vector<T> slice(const std::vector<T>& v, std::size_t a, std::size_t b) {
  return std::vector<T>(v.begin() + static_cast<long>(a), v.begin() + static_cast<long>(b) + 1);
}

std::size_t count_nonfinite(const double* p, std::size_t n) {
  std::size_t c = 0;
  for (std::size_t i = 0; i < n; ++i) c += !std::isfinite(p[i]);
  return c;
}

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> contact_episodes(const std::vector<std::int32_t>& contacts,
                                                                  double haptic_hz, double merge_gap_s) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    if (contacts[i] <= 0) continue;
    std::size_t j = i;
    while (j + 1 < contacts.size() && contacts[j + 1] > 0) ++j;
    if (!runs.empty()) {
      const double gap_s = static_cast<double>(i - runs.back().second - 1) / haptic_hz;
      if (gap_s < merge_gap_s) {
        runs.back().second = j;
        i = j;
        continue;
      }
    }
    runs.emplace_back(i, j);
    i = j;
  }
  return runs;
}

SegmentMetrics segment_metrics(const ReplayTrace& tr, std::size_t a, std::size_t b, const MetricsOptions& opt) {
  SegmentMetrics s;
  s.first = a;
  s.last = b;
  s.t_begin = tr.t[a];
  s.t_end = tr.t[b];
  s.ticks = b - a + 1;
  const double H = tr.haptic_hz;
  const long N = tr.frame_ticks();

  // Peak force and torque.
  NanMax peak_f, peak_t;
  for (std::size_t n = a; n <= b; ++n) {
    peak_f.add(norm(tr.force[n]));
    peak_t.add(norm(tr.torque[n]));
  }
  s.peak_force = peak_f.v;
  s.peak_torque = peak_t.v;

  // Per-tick force change, its rate, and the split at physical-frame boundaries. The first
  // tick's change (from the tick before the segment) is included: a contact onset jump belongs
  // to the episode it starts.
  NanMax rate;
  double sumsq = 0, sum_bnd = 0, sum_int = 0;
  std::size_t steps = 0;
  for (std::size_t n = std::max<std::size_t>(a, 1); n <= b; ++n) {
    const double df = norm(tr.force[n] - tr.force[n - 1]);
    rate.add(df / (tr.t[n] - tr.t[n - 1]));
    sumsq += df * df;
    ++steps;
    const long long tick = std::isfinite(tr.t[n]) ? std::llround(tr.t[n] * H) : static_cast<long long>(n);
    if (tick % N == 0) {
      sum_bnd += df;
      ++s.boundary_ticks;
    } else {
      sum_int += df;
      ++s.interior_ticks;
    }
  }
  s.max_force_rate = steps ? rate.v : kNaN;
  s.rms_force_step = steps ? std::sqrt(sumsq / static_cast<double>(steps)) : kNaN;
  s.boundary_step_mean = mean_or_nan(sum_bnd, s.boundary_ticks);
  s.interior_step_mean = mean_or_nan(sum_int, s.interior_ticks);
  // In realtime mode a physical result arrives when its step ends on the wall clock, not at the
  // ticks kN: the split at kN would measure nothing (98 steps in 1 s at 100 Hz).
  if (tr.mode == "realtime") {
    s.boundary_step_mean = s.interior_step_mean = kNaN;
    s.boundary_ticks = s.interior_ticks = 0;
  }
  if (std::isnan(s.boundary_step_mean) || std::isnan(s.interior_step_mean) ||
      std::max(s.boundary_step_mean, s.interior_step_mean) < kNegligibleForce)  // round-off against round-off
    s.boundary_step_ratio = kNaN;
  else if (s.interior_step_mean > 0)
    s.boundary_step_ratio = s.boundary_step_mean / s.interior_step_mean;
  else
    s.boundary_step_ratio = s.boundary_step_mean > 0 ? std::numeric_limits<double>::infinity() : kNaN;

  // High-frequency force power.
  std::vector<std::vector<double>> ch(3, std::vector<double>(s.ticks));
  for (std::size_t n = a; n <= b; ++n)
    for (int c = 0; c < 3; ++c) ch[c][n - a] = tr.force[n][c];
  const PowerSpectrum spec = power_spectrum(ch, H, opt.fft_window, opt.fft_min_window);
  s.fft_window = spec.window;
  s.power_above_30hz = power_fraction_above(spec, 30.0);
  s.power_above_100hz = power_fraction_above(spec, 100.0);
  double fluctuation = 0;  // sum over ticks of |F - mean F|^2
  for (int c = 0; c < 3; ++c) {
    double mean = 0;
    for (const double f : ch[c]) mean += f;
    mean /= static_cast<double>(s.ticks);
    for (const double f : ch[c]) fluctuation += (f - mean) * (f - mean);
  }
  if (std::sqrt(fluctuation / static_cast<double>(s.ticks)) < kNegligibleForce && !spec.power.empty())
    for (double* p : {&s.power_above_30hz, &s.power_above_100hz})
      if (!std::isnan(*p)) *p = 0.0;  // round-off; a band above the Nyquist frequency stays unmeasured

  // Passivity observer: energy into the environment through the device port, zero-order hold.
  const PassivityEnergy pe = passivity_energy(
      tr.t, [&tr](std::size_t n) { return tr.force[n]; }, [&tr](std::size_t n) { return tr.pose_physical[n].p; }, a, b);
  s.passivity_energy_final = pe.final;
  s.passivity_energy_min = pe.min;
  s.passivity_time_negative_s = pe.time_negative_s;
  double e_rot = 0;
  NanMin e_rot_min;
  for (std::size_t n = a + 1; n <= b; ++n) {
    const TracePose& p0 = tr.pose_physical[n - 1];
    const TracePose& p1 = tr.pose_physical[n];
    e_rot -= dot(tr.torque[n - 1], rotvec_from_quat(normalized(p1.q * conjugate(p0.q))));
    e_rot_min.add(e_rot);
  }
  s.passivity_energy_rot_final = e_rot;
  s.passivity_energy_rot_min = e_rot_min.v;

  // Coupling stretch.
  NanMax st_max, ang_max;
  double st_sum = 0, ang_sum = 0;
  for (std::size_t n = a; n <= b; ++n) {
    const double d = norm(tr.pose_virtual[n].p - tr.pose_physical[n].p);
    const double ang = rotation_angle(tr.pose_virtual[n].q, tr.pose_physical[n].q);
    st_max.add(d);
    ang_max.add(ang);
    st_sum += d;
    ang_sum += ang;
  }
  s.stretch_max = st_max.v;
  s.stretch_mean = st_sum / static_cast<double>(s.ticks);
  s.stretch_angle_max = ang_max.v;
  s.stretch_angle_mean = ang_sum / static_cast<double>(s.ticks);

  // Penetration.
  const auto pen = slice(tr.penetration, a, b);
  NanMax pen_max(-std::numeric_limits<double>::infinity());
  for (double x : pen) pen_max.add(x);
  s.penetration_max = pen_max.v;
  s.penetration_p99 = percentile(pen, 99.0);
  if (tr.penetration_physical.size() == tr.ticks()) {
    const auto pp = slice(tr.penetration_physical, a, b);
    NanMax pp_max(-std::numeric_limits<double>::infinity());
    for (double x : pp) pp_max.add(x);
    s.penetration_physical_max = pp_max.v;
    s.penetration_physical_p99 = percentile(pp, 99.0);
  } else {
    s.penetration_physical_max = s.penetration_physical_p99 = kNaN;
  }

  // Force limit.
  std::size_t clamped = 0;
  for (std::size_t n = a; n <= b; ++n) clamped += tr.force_clamped[n] != 0;
  s.clamped_fraction = static_cast<double>(clamped) / static_cast<double>(s.ticks);
  return s;
}

std::string contact_warning(std::size_t contact_ticks, std::size_t ticks) {
  if (ticks == 0) return "";
  if (contact_ticks == 0) return "the tool never touched the tissue (no tick with contacts > 0)";
  const double fraction = static_cast<double>(contact_ticks) / static_cast<double>(ticks);
  if (fraction >= kLowContactFraction) return "";
  char b[160];
  std::snprintf(b, sizeof b, "the tool touched the tissue in only %zu of %zu ticks (%.2g%%)", contact_ticks, ticks,
                100 * fraction);
  return b;
}

std::string start_warning(double depth, int grasped, bool surface_contact) {
  if (!(depth > 0) && grasped <= 0) return "";
  char where[160];
  if (depth > 0)
    std::snprintf(where, sizeof where, "a virtual vertex %.3g mm inside its colliders at the first tick: at most a "
                  "collider's radius, however deep the tool is", 1e3 * depth);
  else
    std::snprintf(where, sizeof where, "its closed jaws hold %d virtual vertices at the first tick", grasped);
  char b[480];
  std::snprintf(b, sizeof b,
                "the physical tool starts inside the tissue (%s); a device log starts "
                "with the tool free of it: is the tool frame flipped or the tip offset wrong (--tool-transform), or "
                "the log's unit or its place in the scene (ebh import --unit, --transform)? (docs/OWN_DATA.md)",
                where);
  // Contact against the surface pushes each sample out of the tool by the shortest way: a tool
  // inside the tissue holds the surface from inside and lifts it as it leaves, pulling back.
  return std::string(b) + (surface_contact && depth > 0
                               ? "; with contact: surface a tool inside holds the surface from inside, and drags it "
                                 "out as it leaves, with a force into the tissue (docs/MODEL.md, \"Contact against the "
                                 "surface\")"
                               : "");
}

namespace {

/// Whether the force along `against` stays under `level` for the window from tick i on (w ticks
/// after it), in contact in most of those ticks.
bool stays_under(std::size_t i, std::size_t w, std::size_t n, const std::function<double(std::size_t)>& along,
                 double level, std::span<const std::int32_t> contacts) {
  std::size_t touching = 0, after = 0;
  for (std::size_t k = i; k < std::min(n, i + w + 1); ++k, ++after) {
    if (!(along(k) < level)) return false;
    touching += contacts[k] > 0;
  }
  return 2 * touching > after;
}

}  // namespace

std::optional<ForceCollapse> find_force_collapse(std::span<const double> t, const std::function<Vec3d(std::size_t)>& force,
                                                 const std::function<Vec3d(std::size_t)>& device,
                                                 std::span<const std::int32_t> contacts,
                                                 std::span<const std::int32_t> grasped, std::span<const double> jaw,
                                                 double haptic_hz) {
  const std::size_t n = t.size();
  const auto w = static_cast<std::size_t>(std::max(1.0, std::round(kCollapseWindowS * haptic_hz)));
  const auto w_pressed = static_cast<std::size_t>(std::max(1.0, std::round(kPressedWindowS * haptic_hz)));
  std::vector<double> f(n);
  for (std::size_t i = 0; i < n; ++i) f[i] = norm(force(i));
  std::vector<std::size_t> held(n + 1, 0);  // ticks with a grasp before tick i
  for (std::size_t i = 0; i < n; ++i) held[i + 1] = held[i] + (i < grasped.size() && grasped[i] > 0);
  // Whether the jaws moved between ticks a and b (the window before the largest force to the fall).
  const auto jaws_moved = [&jaw](std::size_t a, std::size_t b) {
    if (jaw.empty()) return false;
    const auto [lo, hi] = std::minmax_element(jaw.begin() + static_cast<std::ptrdiff_t>(a),
                                              jaw.begin() + static_cast<std::ptrdiff_t>(b) + 1);
    return *hi - *lo > kCollapseJawMove;
  };
  std::optional<ForceCollapse> found;
  auto record = [&found](ForceCollapse c) {
    if (!found) found = c;
    ++found->count;
  };
  // The windows' ticks by falling |F|, the largest at the front: the last kCollapseWindowS, and
  // the last kPressedWindowS.
  std::deque<std::size_t> top, top_pressed;
  for (std::size_t i = 0; i < n; ++i) {
    while (!top.empty() && top.front() + w < i) top.pop_front();
    while (!top_pressed.empty() && top_pressed.front() + w_pressed < i) top_pressed.pop_front();
    bool collapsed = false;
    if (!top.empty() && std::isfinite(f[i]) && contacts[i] > 0) {
      const std::size_t m = top.front();
      const Vec3d fm = force(m);
      // From a force in contact (not the coupling's stretch after a jump in the log, contacts 0).
      const bool fell = f[m] >= kCollapseMinForceN && f[i] < kCollapseFraction * f[m] && contacts[m] > 0;
      // Pressed on: the device did not move along the force that pushed it back.
      // Nothing grasped from a window before the largest force (a grasp let go falls for a few ticks).
      const bool grasp = held[i + 1] != held[m > w ? m - w : 0];
      // Low, and in contact, after: a tool slid off an edge loses its contacts within a few ticks.
      if (fell && !grasp && dot(device(i) - device(m), fm) <= 0 && !jaws_moved(m > w ? m - w : 0, i) &&
          stays_under(i, w, n, [&f](std::size_t k) { return f[k]; }, 0.5 * f[m], contacts)) {
        record(ForceCollapse{t[m], t[i], f[m], f[i], 0, 0});
        collapsed = true;
      }
    }
    if (!collapsed && !top_pressed.empty() && std::isfinite(f[i]) && contacts[i] > 0 &&
        f[top_pressed.front()] >= kCollapseMinForceN) {
      // Slower: the device pressed on (its motion over the window) against a force that gave way.
      const std::size_t a = i > w_pressed ? i - w_pressed : 0;
      const Vec3d moved = device(i) - device(a);
      const double distance = norm(moved);
      const Vec3d into = distance > 0 ? moved / distance : Vec3d{};
      const auto against = [&force, into](std::size_t k) { return -dot(force(k), into); };
      const double now = against(i);
      // The push against that motion can only have fallen so far where |F| was that large.
      if (distance >= kPressedOnM && now < kCollapseFraction * f[top_pressed.front()]) {
        std::size_t m = i;
        double peak = -INFINITY;
        // The largest push over the window, contacts or none: a largest one without contacts is the
        // coupling's stretch (a jump in the log), not tissue, and is not taken (contacts[m] below).
        for (std::size_t k = a; k < i; ++k)
          if (std::isfinite(f[k]) && against(k) > peak) {
            peak = against(k);
            m = k;
          }
        const double pressed_on = dot(device(i) - device(m), into);
        const bool grasp = held[i + 1] != held[m > w ? m - w : 0];
        // In contact from the largest push to the fall (not a force the coupling's stretch carried).
        std::size_t touching = 0;
        for (std::size_t k = m; k <= i; ++k) touching += contacts[k] > 0;
        if (m < i && contacts[m] > 0 && peak >= kCollapseMinForceN && now < kCollapseFraction * peak &&
            pressed_on >= kPressedOnM && !grasp && 2 * touching > i - m + 1 && !jaws_moved(m > w ? m - w : 0, i) &&
            stays_under(i, w, n, against, 0.5 * peak, contacts)) {
          record(ForceCollapse{t[m], t[i], peak, now + 0.0, pressed_on, 0});  // + 0.0: no "-0 N"
          collapsed = true;
        }
      }
    }
    if (collapsed) {
      top.clear();  // one collapse counted once: the windows start again after it
      top_pressed.clear();
      i += w;
      continue;
    }
    if (!std::isfinite(f[i])) continue;
    while (!top.empty() && f[top.back()] <= f[i]) top.pop_back();
    top.push_back(i);
    while (!top_pressed.empty() && f[top_pressed.back()] <= f[i]) top_pressed.pop_back();
    top_pressed.push_back(i);
  }
  return found;
}

PassivityEnergy passivity_energy(std::span<const double> t, const std::function<Vec3d(std::size_t)>& force,
                                 const std::function<Vec3d(std::size_t)>& device, std::size_t first, std::size_t last) {
  double e = 0, t_neg = 0;
  NanMin e_min;
  for (std::size_t n = first + 1; n <= last; ++n) {
    e -= dot(force(n - 1), device(n) - device(n - 1));
    e_min.add(e);
    if (e < 0) t_neg += t[n] - t[n - 1];
  }
  return {e, e_min.v, std::isnan(e) ? kNaN : t_neg};
}

std::string passivity_warning(const PassivityEnergy& e, std::optional<bool> vertex_contact) {
  if (!(e.min < -kActiveEnergyJ)) return "";
  // What was measured to stay passive: a 40 Hz vibration in contact fed energy with vertex
  // contact in async mode, not with surface contact or in lockstep mode.
  const char* cause = !vertex_contact ? "the physical mesh's one-step delay does it, with vertex contact most (a 40 Hz "
                                        "vibration in contact: `--set contact=surface` and --mode lockstep stayed passive)"
                      : *vertex_contact ? "the physical mesh's one-step delay with vertex contact does it (a 40 Hz "
                                          "vibration in contact: `--set contact=surface` and --mode lockstep stayed "
                                          "passive)"
                                        : "the physical mesh's one-step delay does it (--mode lockstep removes it)";
  char b[480];
  std::snprintf(b, sizeof b,
                "the rendering fed energy to the user: the passivity observer went to %.3g J (below 0 for %.3g s), "
                "a precursor of oscillation on a device (docs/METRICS.md, passivity); %s",
                e.min, e.time_negative_s, cause);
  return b;
}

std::optional<ForceSaturation> find_force_saturation(std::span<const double> t, std::span<const std::uint8_t> clamped,
                                                     double haptic_hz) {
  const std::size_t n = std::min(t.size(), clamped.size());
  std::size_t run = 0, longest = 0, longest_end = 0, at_limit = 0;
  for (std::size_t i = 0; i < n; ++i) {
    run = clamped[i] ? run + 1 : 0;
    at_limit += clamped[i] != 0;
    if (run > longest) longest = run, longest_end = i;
  }
  const double seconds = static_cast<double>(longest) / haptic_hz;
  const double fraction = n ? static_cast<double>(at_limit) / static_cast<double>(n) : 0;
  const bool mostly = fraction > kSaturatedFraction && static_cast<double>(n) / haptic_hz >= kSaturatedMinWindowS;
  if (longest == 0 || (seconds < kSaturatedRunS && !mostly)) return std::nullopt;
  return ForceSaturation{t[longest_end + 1 - longest], seconds, fraction};
}

std::string replay_time_text(double t, double start_s) {
  char text[96];
  // To the millisecond, in %g past 1e9 s (a start of 1e300 s printed 300 digits, cut off).
  const char* into = std::fabs(start_s + t) < 1e9 ? "t = %.3f s, %.3f s into the recording" : "t = %.3f s, %.6g s into the recording";
  if (start_s > 0) std::snprintf(text, sizeof text, into, t, start_s + t);
  else std::snprintf(text, sizeof text, "t = %.3f s", t);
  return text;
}

std::string saturation_warning(const ForceSaturation& s, double start_s) {
  char held[200];
  const std::string from = replay_time_text(s.start_t, start_s);
  if (s.seconds >= kSaturatedRunS)
    std::snprintf(held, sizeof held, "stayed at the device's limit for %.3g s in a row (from %s; %.0f%% of the "
                  "ticks at it)", s.seconds, from.c_str(), 100 * s.fraction);
  else
    std::snprintf(held, sizeof held, "was at the device's limit in %.0f%% of the ticks (at most %.3g s in a row, from "
                  "%s)", 100 * s.fraction, s.seconds, from.c_str());
  return std::string("the force ") + held +
         ": the model's force was larger there, and what the user feels and the metrics measure is the limit "
         "(tool.force_limit): a tool caught in the tissue or far behind the device, or a tissue too stiff for it";
}

std::optional<HeldRelaxation> find_held_relaxation(std::span<const double> t,
                                                   const std::function<Vec3d(std::size_t)>& force,
                                                   const std::function<Vec3d(std::size_t)>& device,
                                                   std::span<const std::int32_t> contacts,
                                                   std::span<const std::int32_t> grasped) {
  const std::size_t n = std::min(t.size(), contacts.size());
  const auto touching = [&](std::size_t i) { return contacts[i] > 0 || (i < grasped.size() && grasped[i] > 0); };
  // Mean |F| over the ticks with t in [from, to).
  const auto mean_force = [&](std::size_t first, std::size_t last, double from, double to) {
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t k = first; k <= last; ++k)
      if (t[k] >= from && t[k] < to) sum += norm(force(k)), ++count;
    return count ? sum / static_cast<double>(count) : kNaN;
  };
  std::optional<HeldRelaxation> found;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n;) {
    if (!touching(i)) {
      ++i;
      continue;
    }
    const Vec3d at = device(i);
    std::size_t j = i;
    while (j + 1 < n && touching(j + 1) && norm(device(j + 1) - at) <= kHeldStillM) ++j;
    if (t[j] - t[i] >= kHeldMinS) {
      const double from = mean_force(i, j, t[i] + kHeldSettleS, t[i] + kHeldSettleS + 1.0);
      const double to = mean_force(i, j, t[j] - 1.0, INFINITY);
      if (from >= kHeldMinForceN && to < (1 - kHeldFallFraction) * from) {
        ++count;
        if (!found || (from - to) / from > (found->from_N - found->to_N) / found->from_N)
          found = HeldRelaxation{t[i], t[j] - t[i], from, to, 0};
      }
    }
    i = j + 1;
  }
  if (found) found->count = count;
  return found;
}

std::string held_relaxation_warning(const HeldRelaxation& h, double start_s) {
  char b[560];
  std::snprintf(b, sizeof b,
                "the force fell from %.3g to %.3g N (%.0f%%) over the %.3g s the device held still on the tissue (from %s%s): "
                "not the tissue relaxing but the coupled meshes settling, at a rate set by stiffness.k_svc and the "
                "physical rate (docs/MODEL.md, \"Held loads\"); compare forces at the same time after a load",
                h.from_N, h.to_N, 100 * (h.from_N - h.to_N) / h.from_N, h.seconds, replay_time_text(h.start_t, start_s).c_str(),
                h.count > 1 ? ("; " + std::to_string(h.count) + " such holds").c_str() : "");
  return b;
}

std::string collapse_warning(const ForceCollapse& c, std::optional<bool> vertex_contact, double start_s) {
  const std::string more = c.count > 1 ? " (" + std::to_string(c.count) + " such falls)" : "";
  const char* parted = "the vertices under a thin tip part and let it through (`--set contact=surface` holds it; "
                       "docs/MODEL.md, \"Contact against the surface\")";
  // An output that does not record its contact model (older ones): the vertices' case, as a condition.
  const std::string why = !vertex_contact ? std::string("the tool went through the tissue or slipped off it (if it "
                                                        "ran with contact: vertices, which this output does not "
                                                        "record: ") + parted + ")"
                          : *vertex_contact ? std::string("the tool went through the tissue or slipped off it: with "
                                                          "contact: vertices, ") + parted
                                            : std::string("the tool slipped off the tissue or the tissue gave way under it");
  char b[320];
  const std::string from = replay_time_text(c.peak_t, start_s), to = replay_time_text(c.t, start_s);
  if (c.pressed_on_m > 0)
    std::snprintf(b, sizeof b, "the force against the device's motion fell from %.3g N (%s) to %.3g N (%s) while the "
                  "device pressed on %.2g mm and the tool stayed in contact", c.peak_N, from.c_str(), c.force_N,
                  to.c_str(), c.pressed_on_m * 1e3);
  else
    std::snprintf(b, sizeof b, "the force fell from %.3g N (%s) to %.3g N (%s) while the tool stayed in contact and the "
                  "device did not draw back", c.peak_N, from.c_str(), c.force_N, to.c_str());
  return b + more + ": " + why;
}

std::size_t fft_window_ticks(const MetricsOptions& opt, double haptic_hz) {
  if (opt.fft_window > 0) return opt.fft_window;
  return floor_pow2(std::max<std::size_t>(2, static_cast<std::size_t>(std::llround(kFftWindowS * haptic_hz))));
}

std::size_t fft_min_window_ticks(const MetricsOptions& opt, double haptic_hz) {
  if (opt.fft_min_window > 0) return opt.fft_min_window;
  return std::max<std::size_t>(2, static_cast<std::size_t>(std::ceil(kFftMinWindowS * haptic_hz - 1e-9)));
}

NonfiniteSamples nonfinite_samples(const ReplayTrace& tr) {
  NonfiniteSamples out;
  auto check = [&](const char* name, const double* p, std::size_t n) {
    if (const std::size_t c = count_nonfinite(p, n)) {
      out.count += c;
      out.datasets.push_back(std::string(name) + ": " + std::to_string(c));
    }
  };
  check("/haptic/t", tr.t.data(), tr.t.size());
  {
    std::vector<double> flat;
    for (const auto* vs : {&tr.force, &tr.torque}) {
      flat.clear();
      for (const Vec3d& v : *vs) flat.insert(flat.end(), {v.x, v.y, v.z});
      check(vs == &tr.force ? "/haptic/force" : "/haptic/torque", flat.data(), flat.size());
    }
    for (const auto* poses : {&tr.pose_physical, &tr.pose_virtual}) {
      flat.clear();
      for (const TracePose& p : *poses) flat.insert(flat.end(), {p.p.x, p.p.y, p.p.z, p.q.w, p.q.x, p.q.y, p.q.z});
      check(poses == &tr.pose_physical ? "/haptic/pose_physical" : "/haptic/pose_virtual", flat.data(), flat.size());
    }
  }
  check("/haptic/penetration", tr.penetration.data(), tr.penetration.size());
  check("/haptic/penetration_physical", tr.penetration_physical.data(), tr.penetration_physical.size());
  check("/physical/t", tr.physical_t.data(), tr.physical_t.size());
  check("/physical/iterations", tr.physical_iterations.data(), tr.physical_iterations.size());
  check("/physical/residual", tr.physical_residual.data(), tr.physical_residual.size());
  check("/timing/haptic_step_s", tr.haptic_step_s.data(), tr.haptic_step_s.size());
  check("/timing/physical_step_s", tr.physical_step_s.data(), tr.physical_step_s.size());
  return out;
}

ForceMetrics compute_metrics(const ReplayTrace& tr, const MetricsOptions& given) {
  MetricsOptions opt = given;  // the windows in this output's ticks
  opt.fft_window = fft_window_ticks(given, tr.haptic_hz);
  opt.fft_min_window = fft_min_window_ticks(given, tr.haptic_hz);
  ForceMetrics m;
  m.path = tr.path;
  m.scene = tr.scene;
  if (!tr.contact.empty()) m.vertex_contact = tr.contact == "vertices";
  m.recording = tr.recording;
  m.mode = tr.mode;
  m.backend = tr.backend;
  m.haptic_hz = tr.haptic_hz;
  m.physical_hz = tr.physical_hz;
  m.start_s = std::isfinite(tr.start) ? tr.start : 0;
  m.frame_ticks = tr.frame_ticks();
  m.options = opt;

  NonfiniteSamples bad = nonfinite_samples(tr);
  m.nonfinite_count = bad.count;
  m.nonfinite_datasets = std::move(bad.datasets);
  m.finite = m.nonfinite_count == 0;

  const std::size_t n = tr.ticks();
  if (n == 0) return m;
  m.duration_s = tr.t.back() - tr.t.front();
  m.whole = segment_metrics(tr, 0, n - 1, opt);
  std::size_t in_contact = 0;
  for (std::int32_t c : tr.contacts) in_contact += c > 0;
  m.contact_fraction = static_cast<double>(in_contact) / static_cast<double>(n);
  m.contact_warning = contact_warning(in_contact, n);
  m.collapse = find_force_collapse(
      tr.t, [&tr](std::size_t i) { return tr.force[i]; }, [&tr](std::size_t i) { return tr.pose_physical[i].p; },
      tr.contacts, tr.grasped, tr.jaw, tr.haptic_hz);
  m.saturation = find_force_saturation(tr.t, tr.force_clamped, tr.haptic_hz);
  m.held = find_held_relaxation(
      tr.t, [&tr](std::size_t i) { return tr.force[i]; }, [&tr](std::size_t i) { return tr.pose_physical[i].p; },
      tr.contacts, tr.grasped);
  const auto runs = contact_episodes(tr.contacts, tr.haptic_hz, opt.episode_merge_gap_s);
  m.episode_count = runs.size();
  for (std::size_t e = 0; e < runs.size() && e < opt.max_episodes; ++e)
    m.episodes.push_back(segment_metrics(tr, runs[e].first, runs[e].second, opt));

  // Timing.
  TimingMetrics& tm = m.timing;
  tm.ticks = n;
  tm.budget_s = opt.tick_budget_s > 0 ? opt.tick_budget_s : 1.0 / tr.haptic_hz;
  m.options.tick_budget_s = tm.budget_s;  // the budget in effect (0 given: the haptic period)
  tm.p50 = percentile(tr.haptic_step_s, 50);
  tm.p99 = percentile(tr.haptic_step_s, 99);
  tm.p999 = percentile(tr.haptic_step_s, 99.9);
  NanMax tmax;
  double tsum = 0;
  for (double x : tr.haptic_step_s) {
    tmax.add(x);
    tsum += x;
    tm.over_budget += x > tm.budget_s;
  }
  tm.max = tmax.v;
  tm.mean = tsum / static_cast<double>(n);
  // A skipped step (0 s, 0 iterations) is no step's cost: with most steps asleep the median was 0.
  auto ran = [&tr](const std::vector<double>& v) {
    std::vector<double> out;
    for (std::size_t i = 0; i < v.size(); ++i)
      if (tr.physical_slept.empty() || tr.physical_slept[i] == 0) out.push_back(v[i]);
    return out;
  };
  for (double s : tr.physical_slept) tm.physical_steps_skipped += s != 0;
  const std::vector<double> step_s = ran(tr.physical_step_s), iterations = ran(tr.physical_iterations);
  tm.physical_p50 = percentile(step_s, 50);
  tm.physical_p99 = percentile(step_s, 99);
  tm.physical_max = percentile(step_s, 100);
  if (iterations.empty()) {
    tm.physical_iterations_mean = tm.physical_iterations_max = kNaN;
  } else {
    double s = 0;
    for (double x : iterations) s += x;
    tm.physical_iterations_mean = s / static_cast<double>(iterations.size());
    tm.physical_iterations_max = percentile(iterations, 100);
  }
  tm.physical_residual_max = percentile(tr.physical_residual, 100);
  tm.physical_inverted_max = tr.physical_inverted.empty() ? kNaN : percentile(tr.physical_inverted, 100);
  return m;
}

namespace {

Json segment_json(const SegmentMetrics& s) {
  Json j = Json::object();
  j.set("first_tick", s.first);
  j.set("last_tick", s.last);
  j.set("t_begin_s", s.t_begin);
  j.set("t_end_s", s.t_end);
  j.set("ticks", s.ticks);
  j.set("peak_force_N", s.peak_force);
  j.set("peak_torque_Nm", s.peak_torque);
  j.set("max_force_rate_N_per_s", s.max_force_rate);
  j.set("rms_force_step_N", s.rms_force_step);
  j.set("boundary_step_mean_N", s.boundary_step_mean);
  j.set("interior_step_mean_N", s.interior_step_mean);
  j.set("boundary_step_ratio", s.boundary_step_ratio);
  j.set("boundary_ticks", s.boundary_ticks);
  j.set("interior_ticks", s.interior_ticks);
  // NaN (null in the text) rather than a missing key: the sweep summary's columns are the keys.
  j.set("fft_window", s.fft_window > 0 ? static_cast<double>(s.fft_window) : kNaN);
  j.set("power_above_30hz", s.power_above_30hz);
  j.set("power_above_100hz", s.power_above_100hz);
  j.set("passivity_energy_final_J", s.passivity_energy_final);
  j.set("passivity_energy_min_J", s.passivity_energy_min);
  j.set("passivity_time_negative_s", s.passivity_time_negative_s);
  j.set("passivity_energy_rot_final_J", s.passivity_energy_rot_final);
  j.set("passivity_energy_rot_min_J", s.passivity_energy_rot_min);
  j.set("stretch_max_m", s.stretch_max);
  j.set("stretch_mean_m", s.stretch_mean);
  j.set("stretch_angle_max_rad", s.stretch_angle_max);
  j.set("stretch_angle_mean_rad", s.stretch_angle_mean);
  j.set("penetration_max_m", s.penetration_max);
  j.set("penetration_p99_m", s.penetration_p99);
  j.set("penetration_physical_max_m", s.penetration_physical_max);
  j.set("penetration_physical_p99_m", s.penetration_physical_p99);
  j.set("clamped_fraction", s.clamped_fraction);
  return j;
}

}  // namespace

Json to_json(const ForceMetrics& m, bool with_episodes) {
  Json j = Json::object();
  j.set("file", m.path);
  j.set("scene", m.scene);
  j.set("recording", m.recording);
  j.set("mode", m.mode);
  j.set("backend", m.backend);
  j.set("haptic_hz", m.haptic_hz);
  j.set("start_s", m.start_s);
  j.set("physical_hz", m.physical_hz);
  j.set("frame_ticks", m.frame_ticks);
  j.set("ticks", m.timing.ticks);
  j.set("duration_s", m.duration_s);
  j.set("finite", m.finite);
  j.set("nonfinite_count", m.nonfinite_count);
  j.set("nonfinite_datasets", Json::array_of(m.nonfinite_datasets));
  Json opt = Json::object();
  opt.set("episode_merge_gap_s", m.options.episode_merge_gap_s);
  opt.set("fft_window", m.options.fft_window);
  opt.set("fft_min_window", m.options.fft_min_window);
  opt.set("tick_budget_s", m.options.tick_budget_s);
  j.set("options", std::move(opt));
  j.set("whole", segment_json(m.whole));
  j.set("contact_fraction", m.contact_fraction);
  j.set("contact_warning", m.contact_warning.empty() ? Json(nullptr) : Json(m.contact_warning));
  // The first collapse's numbers, NaN without one (the sweep summary's columns are the keys).
  Json collapse = Json::object();
  collapse.set("count", m.collapse ? m.collapse->count : 0);
  collapse.set("peak_t_s", m.collapse ? m.collapse->peak_t : kNaN);
  collapse.set("t_s", m.collapse ? m.collapse->t : kNaN);
  collapse.set("peak_force_N", m.collapse ? m.collapse->peak_N : kNaN);
  collapse.set("force_N", m.collapse ? m.collapse->force_N : kNaN);
  collapse.set("pressed_on_mm", m.collapse ? 1e3 * m.collapse->pressed_on_m : kNaN);
  collapse.set("warning", m.collapse ? Json(collapse_warning(*m.collapse, m.vertex_contact, m.start_s)) : Json(nullptr));
  j.set("force_collapse", std::move(collapse));
  j.set("saturation_warning", m.saturation ? Json(saturation_warning(*m.saturation, m.start_s)) : Json(nullptr));
  j.set("held_relaxation_warning", m.held ? Json(held_relaxation_warning(*m.held, m.start_s)) : Json(nullptr));
  j.set("episode_count", m.episode_count);
  if (with_episodes) {
    Json eps = Json::array();
    for (const SegmentMetrics& s : m.episodes) eps.push(segment_json(s));
    j.set("episodes", std::move(eps));
    j.set("episodes_listed", m.episodes.size());
  }
  const TimingMetrics& t = m.timing;
  Json tj = Json::object();
  tj.set("haptic_step_p50_s", t.p50);
  tj.set("haptic_step_p99_s", t.p99);
  tj.set("haptic_step_p999_s", t.p999);
  tj.set("haptic_step_max_s", t.max);
  tj.set("haptic_step_mean_s", t.mean);
  tj.set("haptic_over_budget_ticks", t.over_budget);
  tj.set("haptic_budget_s", t.budget_s);
  tj.set("physical_step_p50_s", t.physical_p50);
  tj.set("physical_step_p99_s", t.physical_p99);
  tj.set("physical_step_max_s", t.physical_max);
  tj.set("physical_iterations_mean", t.physical_iterations_mean);
  tj.set("physical_steps_skipped", static_cast<long long>(t.physical_steps_skipped));
  tj.set("physical_iterations_max", t.physical_iterations_max);
  tj.set("physical_residual_max", t.physical_residual_max);
  tj.set("physical_inverted_max", t.physical_inverted_max);
  j.set("timing", std::move(tj));
  return j;
}

namespace {

/// v with printf format f; "-" for NaN; past 1e6 in magnitude (a force no device renders, which
/// a fixed format prints as 21 digits) with %.4g.
std::string fmt(const char* f, double v) {
  if (std::isnan(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, std::fabs(v) < 1e6 ? f : "%.4g", v);
  return buf;
}

}  // namespace

std::string episodes_not_listed(const ForceMetrics& m) {
  if (m.episodes.size() >= m.episode_count) return "";
  return std::to_string(m.episode_count) + " contact episodes; the metrics of the first " + std::to_string(m.episodes.size()) +
         " are listed (a contact that flickers: a longer --merge-gap-ms merges its episodes)";
}

std::string format_table(const ForceMetrics& m, bool with_episodes) {
  std::ostringstream o;
  const SegmentMetrics& s = m.whole;
  auto row = [&](const char* name, const std::string& value, const char* unit) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "  %-34s %14s %s\n", name, value.c_str(), unit);
    o << buf;
  };
  // The file's own text (another program's attributes may hold a line break or an escape
  // sequence): escaped, so that the table keeps its lines and the terminal its colours.
  const auto text = [](const std::string& v) { return v.empty() ? std::string("-") : escape_unprintable(v); };
  o << escape_unprintable(m.path) << "\n";
  o << "  scene " << text(m.scene) << ", recording " << text(m.recording) << ", mode " << text(m.mode) << ", backend "
    << text(m.backend) << "\n";
  o << "  " << m.timing.ticks << " ticks, " << fmt("%.3f", m.duration_s) << " s";
  if (m.start_s > 0) o << " from " << fmt("%g", m.start_s) << " s into the recording (the times below count from there)";
  o << ", haptic " << fmt("%g", m.haptic_hz) << " Hz, physical " << fmt("%g", m.physical_hz) << " Hz (N = "
    << m.frame_ticks << ")\n";
  if (!m.finite) {
    o << "  NON-FINITE: " << m.nonfinite_count << " samples (";
    for (std::size_t i = 0; i < m.nonfinite_datasets.size(); ++i) o << (i ? ", " : "") << m.nonfinite_datasets[i];
    o << ")\n";
  }
  if (!m.contact_warning.empty()) o << "  warning: " << m.contact_warning << "\n";
  if (m.collapse) o << "  warning: " << collapse_warning(*m.collapse, m.vertex_contact, m.start_s) << "\n";
  if (m.saturation) o << "  warning: " << saturation_warning(*m.saturation, m.start_s) << "\n";
  if (m.held) o << "  warning: " << held_relaxation_warning(*m.held, m.start_s) << "\n";
  const PassivityEnergy whole{m.whole.passivity_energy_final, m.whole.passivity_energy_min,
                              m.whole.passivity_time_negative_s};
  if (const std::string w = passivity_warning(whole, m.vertex_contact); !w.empty()) o << "  warning: " << w << "\n";
  o << "force\n";
  row("peak |F|", fmt("%.4f", s.peak_force), "N");
  row("peak |T|", fmt("%.5f", s.peak_torque), "N m");
  row("max |dF/dt|", fmt("%.3f", s.max_force_rate), "N/s");
  row("RMS |F_n - F_n-1|", fmt("%.3e", s.rms_force_step), "N");
  row("mean |dF| at physical frames", fmt("%.3e", s.boundary_step_mean), "N");
  row("mean |dF| other ticks", fmt("%.3e", s.interior_step_mean), "N");
  row("frame-boundary jump ratio", fmt("%.3f", s.boundary_step_ratio),
      m.mode == "realtime" ? "not measured in realtime mode (results arrive on the wall clock)" : "");
  row("power above 30 Hz", fmt("%.4f", s.power_above_30hz), "of force power");
  row("power above 100 Hz", fmt("%.4f", s.power_above_100hz), "of force power");
  row("ticks at force limit", fmt("%.4f", s.clamped_fraction), "fraction");
  o << "passivity (energy into the environment)\n";
  row("E_obs final", fmt("%.4e", s.passivity_energy_final), "J");
  row("E_obs min", fmt("%.4e", s.passivity_energy_min), "J");
  row("time with E_obs < 0", fmt("%.4f", s.passivity_time_negative_s), "s");
  row("E_obs rotational final / min",
      fmt("%.3e", s.passivity_energy_rot_final) + " / " + fmt("%.3e", s.passivity_energy_rot_min), "J");
  o << "coupling and contact\n";
  row("stretch |P_g - P_h| max / mean", fmt("%.3e", s.stretch_max) + " / " + fmt("%.3e", s.stretch_mean), "m");
  row("stretch angle max / mean",
      fmt("%.3e", s.stretch_angle_max) + " / " + fmt("%.3e", s.stretch_angle_mean), "rad");
  row("penetration virtual max / p99", fmt("%.3e", s.penetration_max) + " / " + fmt("%.3e", s.penetration_p99), "m");
  row("penetration physical max / p99",
      fmt("%.3e", s.penetration_physical_max) + " / " + fmt("%.3e", s.penetration_physical_p99), "m");
  row("ticks in contact", fmt("%.4f", m.contact_fraction), "fraction");
  row("contact episodes", std::to_string(m.episode_count), "");
  const TimingMetrics& t = m.timing;
  o << "timing\n";
  row("haptic tick p50 / p99 / p99.9",
      fmt("%.1f", t.p50 * 1e6) + " / " + fmt("%.1f", t.p99 * 1e6) + " / " + fmt("%.1f", t.p999 * 1e6), "us");
  row("haptic tick max", fmt("%.1f", t.max * 1e6), "us");
  row("haptic ticks over budget", std::to_string(t.over_budget) + " > " + fmt("%g", t.budget_s * 1e3), "ms");
  row("physical step p50 / p99",
      fmt("%.2f", t.physical_p50 * 1e3) + " / " + fmt("%.2f", t.physical_p99 * 1e3), "ms");
  row("physical iterations mean / max",
      fmt("%.1f", t.physical_iterations_mean) + " / " + fmt("%.0f", t.physical_iterations_max), "");
  if (t.physical_steps_skipped > 0)
    row("physical steps skipped (not above)", std::to_string(t.physical_steps_skipped), "");
  row("physical tets inverted, most", fmt("%.0f", t.physical_inverted_max), "");
  if (with_episodes && !m.episodes.empty()) {
    o << "episodes (contacts > 0, gaps < " << fmt("%g", m.options.episode_merge_gap_s * 1e3) << " ms merged)\n";
    o << "     #   t_begin     t_end   peak|F|   max|dF/dt|  jump ratio  >30Hz    E_obs min  pen max\n";
    o << "             s         s       N        N/s                                J         m\n";
    for (std::size_t i = 0; i < m.episodes.size(); ++i) {
      const SegmentMetrics& e = m.episodes[i];
      char buf[200];
      std::snprintf(buf, sizeof buf, "  %4zu %9s %9s %9s %12s %11s %7s %12s %9s\n", i + 1,
                    fmt("%.3f", e.t_begin).c_str(), fmt("%.3f", e.t_end).c_str(), fmt("%.4f", e.peak_force).c_str(),
                    fmt("%.2f", e.max_force_rate).c_str(), fmt("%.3f", e.boundary_step_ratio).c_str(),
                    fmt("%.4f", e.power_above_30hz).c_str(), fmt("%.3e", e.passivity_energy_min).c_str(),
                    fmt("%.2e", e.penetration_max).c_str());
      o << buf;
    }
    if (m.episodes.size() < m.episode_count)
      o << "  ... " << episodes_not_listed(m) << "\n";
  }
  return o.str();
}

}  // namespace ebh
