#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "io/synth.hpp"
#include "io_test_util.hpp"

using namespace ebh;

namespace {

SynthPlan hold_plan(double duration) {
  SynthPlan p;
  p.scene = "tube";
  p.tool = "hook";
  PlanWaypoint a;
  a.position = {0.01, 0.02, 0.03};
  a.orientation = quat_from_rotvec(Vec3d{0, 0.3, 0});
  PlanWaypoint b = a;
  b.t = duration;
  p.waypoints = {a, b};
  return p;
}

SynthPlan moving_plan() {
  SynthPlan p = hold_plan(1.0);
  PlanWaypoint c = p.waypoints.back();
  c.t = 2.0;
  c.position = {0.05, -0.01, 0.0};
  c.orientation = quat_from_rotvec(Vec3d{0.4, 0.3, -0.2});
  c.jaw = 0.0;
  p.waypoints.push_back(c);
  PlanWaypoint d = c;
  d.t = 2.5;
  d.position = {0.0, 0.0, 0.0};
  p.waypoints.push_back(d);
  return p;
}

}  // namespace

TEST(MinimumJerk, EndpointsHaveZeroVelocityAndAcceleration) {
  EXPECT_EQ(minimum_jerk(0.0), 0.0);
  EXPECT_EQ(minimum_jerk(1.0), 1.0);
  EXPECT_EQ(minimum_jerk(0.5), 0.5);
  // Finite differences at the ends: s = 10 tau^3 + O(tau^4), so ds ~ 10 h^2 and d2s ~ 60 h; with
  // h = 1e-5 both are below 1e-3 while a non-zero derivative would be O(1).
  const double h = 1e-5;
  for (double e : {0.0, 1.0}) {
    double sm = minimum_jerk(e - h), s0 = minimum_jerk(e), sp = minimum_jerk(e + h);
    // One-sided at the ends (the profile is clamped outside [0, 1]).
    double v = e == 0.0 ? (sp - s0) / h : (s0 - sm) / h;
    double acc = e == 0.0 ? (minimum_jerk(2 * h) - 2 * sp + s0) / (h * h) : (s0 - 2 * sm + minimum_jerk(1 - 2 * h)) / (h * h);
    EXPECT_NEAR(v, 0.0, 1e-3);
    EXPECT_NEAR(acc, 0.0, 1e-3);
  }
}

TEST(Synth, PlanPoseStopsAtEveryWaypoint) {
  SynthPlan p = moving_plan();
  const double h = 1e-5;
  for (const auto& w : p.waypoints) {
    DeviceSample d = plan_pose(p, w.t);
    EXPECT_NEAR(norm(d.position - w.position), 0.0, 1e-15);
    // Central difference of position across the waypoint: zero velocity on both sides, O(h^2).
    Vec3d v = (plan_pose(p, w.t + h).position - plan_pose(p, w.t - h).position) / (2 * h);
    EXPECT_NEAR(norm(v), 0.0, 1e-6);
  }
  // Midway between two waypoints the orientation is the slerp midpoint (s(0.5) = 0.5).
  DeviceSample m = plan_pose(p, 1.5);
  Quatd expect = slerp(p.waypoints[1].orientation, p.waypoints[2].orientation, 0.5);
  EXPECT_NEAR(std::abs(m.orientation.w * expect.w + m.orientation.x * expect.x + m.orientation.y * expect.y +
                       m.orientation.z * expect.z),
              1.0, 1e-14);
  EXPECT_NEAR(m.jaw, 0.5, 1e-15);
}

TEST(Synth, DeterministicForASeedDifferentForAnother) {
  SynthPlan p = moving_plan();
  Recording a = synthesize(p, 7), b = synthesize(p, 7), c = synthesize(p, 8);
  ASSERT_EQ(a.size(), 2501u);
  bool differs = false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.position[i], b.position[i]);  // bitwise
    differs = differs || !(a.position[i] == c.position[i]);
  }
  EXPECT_TRUE(differs);
  EXPECT_EQ(a.t[1000], 1.0);
}

TEST(Synth, QuantisedToTheDeviceResolution) {
  SynthPlan p = moving_plan();
  Recording r = synthesize(p, 3);
  SynthPlan smooth = p;
  smooth.quantum = 0;
  Recording s = synthesize(smooth, 3);
  for (std::size_t i = 0; i < r.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      double steps = r.position[i][k] / p.quantum;
      EXPECT_NEAR(steps, std::round(steps), 1e-6);  // an integer number of 0.055 mm steps
      // Rounding moves a coordinate by at most half a step (plus double round-off).
      EXPECT_LE(std::abs(r.position[i][k] - s.position[i][k]), 0.5 * p.quantum + 1e-12);
    }
}

TEST(Synth, TremorAmplitudeAndBand) {
  SynthPlan p = hold_plan(10.0);
  p.quantum = 0;  // look at the tremor alone
  const double A = p.tremor_amplitude;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    Recording r = synthesize(p, seed);
    const std::size_t n = r.size();
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> x(n);
      double ss = 0, peak = 0;
      for (std::size_t i = 0; i < n; ++i) {
        x[i] = r.position[i][axis] - p.waypoints[0].position[axis];
        ss += x[i] * x[i];
        peak = std::max(peak, std::abs(x[i]));
      }
      double rms = std::sqrt(ss / static_cast<double>(n));
      // Three components of amplitude A/sqrt(3): the peak can never exceed 3 A/sqrt(3) = sqrt(3) A.
      EXPECT_LE(peak, std::sqrt(3.0) * A * (1 + 1e-12));
      // RMS is A/sqrt(2) up to the beat terms between components, which 10 s do not average out
      // when two frequencies lie close (at most sqrt(3) x when all three stay in phase); seeds
      // 1-8 give 0.93..1.21 x A/sqrt(2), so +-35 % is a meaningful bound with room to spare.
      EXPECT_GT(rms, 0.65 * A / std::sqrt(2.0)) << "seed " << seed << " axis " << axis;
      EXPECT_LT(rms, 1.35 * A / std::sqrt(2.0)) << "seed " << seed << " axis " << axis;
      // Band: Hann-windowed DFT power on a 0.1 Hz grid from 0 to 50 Hz. The window's leakage
      // beyond 0.5 Hz from a tone is < 1e-4 of its power, so >= 99 % must lie in [7.5, 12.5] Hz.
      double in_band = 0, total = 0;
      for (int k = 0; k <= 500; ++k) {
        double f = 0.1 * k, re = 0, im = 0;
        for (std::size_t i = 0; i < n; ++i) {
          double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n - 1));
          double ph = 2 * std::numbers::pi * f * r.t[i];
          re += w * x[i] * std::cos(ph);
          im -= w * x[i] * std::sin(ph);
        }
        double pw = re * re + im * im;
        total += pw;
        if (f >= 7.5 && f <= 12.5) in_band += pw;
      }
      EXPECT_GT(in_band / total, 0.99) << "seed " << seed << " axis " << axis;
    }
  }
}

TEST(Plan, ReadsWaypointsInMillimetresAndDegrees) {
  test::ScratchDir tmp;
  const std::string path = tmp / "plan.yaml";
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fputs(
      "scene: gap\ntool: hook\ndescription: d\ntremor: {amplitude_mm: 0.2}\nquantum_mm: 0.1\nwaypoints:\n"
      "  - {t: 0, position_mm: [0, 0, 30], rotvec_deg: [180, 0, 0]}\n"
      "  - {t: 2, position_mm: [0, 0, -18], jaw: 0.5, buttons: 1}\n"
      "  - {t: 3}\n",
      f);
  std::fclose(f);
  SynthPlan p = read_plan(path);
  ASSERT_EQ(p.waypoints.size(), 3u);
  // mm -> m is one multiplication: equal to a few ulps.
  EXPECT_DOUBLE_EQ(p.waypoints[1].position.z, -0.018);
  EXPECT_DOUBLE_EQ(p.tremor_amplitude, 0.2e-3);
  EXPECT_DOUBLE_EQ(p.quantum, 0.1e-3);
  Vec3d down = rotate(p.waypoints[0].orientation, Vec3d{0, 0, 1});
  EXPECT_NEAR(norm(down - Vec3d{0, 0, -1}), 0, 1e-15);  // 180 deg about x: tool +z = world -z
  EXPECT_EQ(p.waypoints[2].position, p.waypoints[1].position);  // carried over
  EXPECT_EQ(p.waypoints[2].jaw, 0.5);
  EXPECT_EQ(p.waypoints[2].buttons, 1);
  EXPECT_EQ(p.waypoints[0].jaw, 1.0);
}

TEST(Plan, ErrorsNameFileLineAndKey) {
  test::ScratchDir tmp;
  const std::string path = tmp / "bad.yaml";
  auto plan = [&](const char* text) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs(text, f);
    std::fclose(f);
  };
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 30], rotvec_deg: [0, 0, 0]}\n"
       "  - {t: 0, position_mm: [0, 0, 0]}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":5", "waypoints[1].t", "strictly increasing");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0], rotvec_deg: [0, 0, 0]}\n  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "waypoints[0].position_mm", "3 numbers");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 30], rotvec_deg: [1e300, 0, 0]}\n  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "waypoints[0].rotvec_deg", "angle is inf degrees; give one of at most 360");
  // Numbers past what a device or a hand makes: a path flattened to a point, a rounding that
  // overflows, a tremor of metres or above the samples' band, a waypoint kilometres away.
  const std::string two = "waypoints:\n  - {t: 0, position_mm: [0, 0, 30], rotvec_deg: [0, 0, 0]}\n  - {t: 1}\n";
  plan(("scene: gap\ntool: hook\nquantum_mm: 1e6\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "quantum_mm", "expected 0 (none) or 1e-06 .. 10 mm");
  plan(("scene: gap\ntool: hook\nquantum_mm: 1e-320\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "quantum_mm", "got 9.99989e-321");
  plan(("scene: gap\ntool: hook\ntremor: {amplitude_mm: 1e6}\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "tremor.amplitude_mm", "expected 0 .. 10 mm");
  plan(("scene: gap\ntool: hook\ntremor: {band_hz: [800, 5000]}\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "tremor.band_hz", "1000 Hz samples cannot carry the tremor's band up to 5000 Hz");
  // the default band (8-12 Hz) against the plan's rate, and a rate given on the command line
  plan(("scene: gap\ntool: hook\nrate_hz: 20\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "rate_hz", "20 Hz samples cannot carry the tremor's band up to 12 Hz");
  EXPECT_NO_THROW(read_plan(path, 100.0));  // --rate 100 carries it
  plan(("scene: gap\ntool: hook\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path, 20.0), "--rate 20: 20 Hz samples cannot carry the tremor's band up to 12 Hz");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [1e300, 0, 30], rotvec_deg: [0, 0, 0]}\n  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "waypoints[0].position_mm", "coordinate 1e+300 mm is beyond 100000 mm");
  plan(("scene: ''\ntool: hook\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":1", "scene", "expected a scene's name or path, got nothing");
  // a NUL would end the recording's attribute there ("tu"); a line break is no scene's name
  plan(("scene: \"tu\\0be\"\ntool: hook\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":1", "scene", "contains a NUL byte (\\0)");
  plan(("scene: \"tube\\nX\"\ntool: hook\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":1", "scene", "'tube\\x0aX' holds a control character");
  plan(("scene: ../recordings/tube_insert.h5\ntool: hook\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":1", "scene", "'../recordings/tube_insert.h5' is no scene file (a scene is YAML");
  plan(("scene: gap\ntool: hook\ndescription: \"a\\0b\"\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "description", "contains a NUL byte (\\0)");
  plan("scene: gap\ntool: scalpel\nwaypoints: []\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":2", "tool", "hook or forceps");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 1], rotvec_deg: [0, 0, 0], jaw: 2}\n  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "jaw", "[0, 1]");
  plan("scene: gap\ntool: hook\nwaypoint: []\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "waypoint", "unknown key (known: scene, tool, description");
  // A key given twice: yaml-cpp keeps both and the reader took the first without a word (a rate
  // of 1000 Hz for the 500 written last; a waypoint's second jaw).
  plan(("scene: gap\ntool: hook\nrate_hz: 1000\nrate_hz: 500\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "rate_hz", "given twice");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, 1], rotvec_deg: [0, 0, 0], jaw: 1, jaw: 0}\n"
       "  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "waypoints[0].jaw", "given twice");
  // A YAML tag, which nothing reads (a rate of 1000 Hz for `!khz 1`): on a value, in a waypoint.
  plan(("scene: gap\ntool: hook\nrate_hz: !khz 1\n" + two).c_str());
  EXPECT_INPUT_ERROR(read_plan(path), path + ":3", "rate_hz", "YAML tag '!khz': ebh reads no tags");
  plan("scene: gap\ntool: hook\nwaypoints:\n  - {t: 0, position_mm: [0, 0, !!float 30], rotvec_deg: [0, 0, 0]}\n  - {t: 1}\n");
  EXPECT_INPUT_ERROR(read_plan(path), path + ":4", "waypoints[0].position_mm[2]", "YAML tag '!!float'");
  plan(("scene: 'gap'\ntool: ! hook\n" + two).c_str());  // quoted, and the non-specific tag: plain text
  EXPECT_NO_THROW(read_plan(path));
  plan("scene: [gap\n");
  EXPECT_INPUT_ERROR(read_plan(path), path, "YAML syntax error");
  plan(("waypoints: " + std::string(100000, '[') + "\n").c_str());  // yaml-cpp's nesting limit, not a stack overflow
  EXPECT_INPUT_ERROR(read_plan(path), path + ":", "nested too deeply (over 500 levels of lists and maps");
}

TEST(Synth, SampleCountIsCheckedBeforeAllocating) {
  // A far waypoint or a high rate asks for more samples than memory holds: refused with the
  // limit, naming the plan, before anything is allocated (it was std::bad_alloc).
  SynthPlan plan;
  plan.file = "far.yaml";
  plan.waypoints.resize(2);
  plan.waypoints[1].t = 1e12;
  EXPECT_INPUT_ERROR(synthesize(plan, 1), "far.yaml: ", "1e+15 samples", "the limit is 10000000 samples");
  plan.waypoints[1].t = 1e-4;  // shorter than one sample interval at 1 kHz
  EXPECT_INPUT_ERROR(synthesize(plan, 1), "far.yaml: ", "a recording needs at least two samples");
}

TEST(Plan, MovesAndTurnsFasterThanAHandAreWarnedByWaypoint) {
  SynthPlan p = moving_plan();  // 51 mm in 1 s: 0.096 m/s at its peak; turns of ~0.5 rad
  p.file = "plan.yaml";
  EXPECT_TRUE(plan_rate_warnings(p).empty());
  // The last segment's 51 mm in 10 ms (its t in ms read as s): 9.6 m/s at its peak, under the
  // limit; in 5 ms, 19 m/s.
  p.waypoints[3].t = p.waypoints[2].t + 0.010;
  EXPECT_TRUE(plan_rate_warnings(p).empty());
  p.waypoints[3].t = p.waypoints[2].t + 0.005;
  auto w = plan_rate_warnings(p);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("plan.yaml: waypoints[2] -> waypoints[3] (t = 2 .. 2.005 s) move the tool 50.99 mm at up to 19.1 m/s"),
            std::string::npos)
      << w[0];
  // A half turn in 50 ms: 116 rad/s at its peak (the limit 50).
  p = moving_plan();
  p.file = "plan.yaml";
  p.waypoints[2].t = p.waypoints[1].t + 0.05;
  p.waypoints[2].position = p.waypoints[1].position;
  p.waypoints[2].orientation = p.waypoints[1].orientation * quat_from_rotvec(Vec3d{0, 0, 3.1});
  w = plan_rate_warnings(p);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("waypoints[1] -> waypoints[2] (t = 1 .. 1.05 s) turn the tool 177.6 degrees at up to 116 rad/s"),
            std::string::npos)
      << w[0];
}
