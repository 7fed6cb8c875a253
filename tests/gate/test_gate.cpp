// The gate's judgement of a measured case against its baseline (judge_gate_case) and the
// baselines file's checks (read_gate_baselines), on numbers made up here: no replay.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "gate/gate.hpp"

namespace ebh {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A baseline like the committed tube_grasp case's.
GateCase baseline() {
  GateCase b;
  b.name = std::string(1, 'c');  // (assigning the literal trips GCC 12's -Wrestrict false positive)
  b.rms_force_step = 0.03;
  b.max_force_rate = 600;
  b.peak_force = 3.3;
  b.power_above_30hz = 0.0025;
  b.penetration_max = 7e-4;
  b.boundary_step_ratio = 1.2;
  b.force_collapse = false;
  return b;
}

GateResult judged(const GateCase& measured, const GateCase& base = baseline(), const GateBands& bands = {}) {
  GateResult r;
  r.measured = measured;
  judge_gate_case(base, bands, r);
  return r;
}

bool mentions(const GateResult& r, const std::string& what) {
  for (const std::string& f : r.failures)
    if (f.find(what) != std::string::npos) return true;
  return false;
}

TEST(Gate, TheBaselineItselfPasses) {
  const GateResult r = judged(baseline());
  EXPECT_TRUE(r.passed) << (r.failures.empty() ? "" : r.failures.front());
  EXPECT_TRUE(r.unchecked.empty());
}

// A buzz four times the baseline's power above 30 Hz fails; the band was baseline + 0.05, which
// passed 20x the committed baselines' buzz.
TEST(Gate, PowerAbove30HzIsARelativeBand) {
  GateCase m = baseline();
  m.power_above_30hz = 4 * baseline().power_above_30hz;
  EXPECT_TRUE(mentions(judged(m), "power_above_30hz"));
  m.power_above_30hz = 1.4 * baseline().power_above_30hz;  // inside 1.5 b + 0.005
  EXPECT_TRUE(judged(m).passed);
}

// The paper's design goal: the physical frames do not show in the force. A ratio of 2 on a
// baseline of 1.2 is a ripple at the physical rate.
TEST(Gate, FrameBoundaryRatioIsGated) {
  GateCase m = baseline();
  m.boundary_step_ratio = 2.0;
  EXPECT_TRUE(mentions(judged(m), "boundary_step_ratio"));
  m.boundary_step_ratio = std::numeric_limits<double>::infinity();  // steps only at frame boundaries
  EXPECT_TRUE(mentions(judged(m), "boundary_step_ratio"));
  m.boundary_step_ratio = 1.3;
  EXPECT_TRUE(judged(m).passed);
  m.boundary_step_ratio = kNaN;  // a force that never changed: nothing to compare
  EXPECT_FALSE(mentions(judged(m), "boundary_step_ratio"));
}

TEST(Gate, ANewCollapseFailsAKnownOneDoesNot) {
  GateCase m = baseline();
  m.force_collapse = true;
  EXPECT_TRUE(mentions(judged(m), "force_collapse"));
  GateCase known = baseline();
  known.force_collapse = true;
  EXPECT_TRUE(judged(m, known).passed);
  m.force_collapse = false;  // a collapse mended: no failure
  EXPECT_TRUE(judged(m, known).passed);
}

TEST(Gate, BaselinesWithoutTheNewMetricsNameThemUnchecked) {
  GateCase old = baseline();
  old.boundary_step_ratio = kNaN;
  old.force_collapse.reset();
  GateCase m = baseline();
  m.force_collapse = true;
  m.boundary_step_ratio = 5;
  const GateResult r = judged(m, old);
  EXPECT_TRUE(r.passed);
  EXPECT_EQ(r.unchecked, (std::vector<std::string>{"boundary_step_ratio", "force_collapse"}));
}

// The JSON report lists the unchecked metrics under the keys its "measured" and "baseline" give
// them, unit and all (penetration_max_m, not penetration_max), and a value a case lacks (a
// baseline left out, a measured NaN: a window too short for a spectrum) is null, never nan; the
// text output names them with their unit as its failures do.
TEST(Gate, TheJsonReportNamesUncheckedMetricsByTheirKeysAndMissingValuesAreNull) {
  GateCase old = baseline();
  old.max_force_rate = kNaN;
  old.penetration_max = kNaN;
  old.force_collapse.reset();
  GateCase m = baseline();
  m.power_above_30hz = kNaN;
  m.boundary_step_ratio = kNaN;
  const GateResult r = judged(m, old);
  ASSERT_TRUE(r.passed) << r.failures.front();
  const std::string text = to_json(r, old).dump(-1);
  EXPECT_NE(text.find("\"unchecked\": [\"max_force_rate_N_per_s\", \"penetration_max_m\", \"force_collapse\"]"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("\"measured\": {\"rms_force_step_N\": 0.03, \"max_force_rate_N_per_s\": 600, \"peak_force_N\": "
                      "3.3, \"power_above_30hz\": null, \"penetration_max_m\": 0.0007, \"boundary_step_ratio\": null"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("\"baseline\": {\"rms_force_step_N\": 0.03, \"max_force_rate_N_per_s\": null"), std::string::npos)
      << text;
  EXPECT_EQ(text.find("nan"), std::string::npos) << text;
  EXPECT_EQ(gate_metric_label("max_force_rate"), "max_force_rate [N/s]");
  EXPECT_EQ(gate_metric_label("penetration_max"), "penetration_max [m]");
  EXPECT_EQ(gate_metric_label("force_collapse"), "force_collapse");
}

std::string baselines_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("ebh_test_gate_" + name + ".yaml")).string();
}

std::string baselines_file(const std::string& name, const std::string& text) {
  const std::string p = baselines_path(name);
  std::ofstream(p) << text;
  return p;
}

constexpr const char* kCase = "cases:\n  - {name: c, scene: tube, recording: tube_insert, start: 2, duration: 1";

TEST(Gate, BaselinesRoundTripTheNewMetrics) {
  const std::string path = baselines_file("round_trip", std::string(kCase) + "}\n");
  GateBaselines b = read_gate_baselines(path);
  b.cases[0].text.clear();  // values of its own, as a case measured anew (run_gate_case)
  b.cases[0].boundary_step_ratio = 1.25;
  b.cases[0].force_collapse = true;
  write_gate_baselines(path, b);
  const GateBaselines again = read_gate_baselines(path);
  EXPECT_EQ(again.cases[0].boundary_step_ratio, 1.25);
  EXPECT_EQ(again.cases[0].force_collapse, std::optional<bool>(true));
  EXPECT_EQ(again.bands.abs_boundary_ratio, GateBands{}.abs_boundary_ratio);
  std::filesystem::remove(path);
}

// A lab's own file keeps its header through a rewrite (it had the committed file's, naming a
// script of this repository); comments below it are counted for --update's warning; a file
// without a header gets one saying how to regenerate it.
TEST(Gate, ARewriteKeepsTheFilesHeader) {
  const std::string path = baselines_file("header", std::string("# Our lab's liver cases.\n#  Ask Ann before updating.\n\n") +
                                                        kCase + "}\n  # the second case is next week's\n");
  GateBaselines b = read_gate_baselines(path);
  EXPECT_EQ(b.header, "# Our lab's liver cases.\n#  Ask Ann before updating.\n");
  EXPECT_EQ(b.body_comments, 1u);
  write_gate_baselines(path, b);
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.rfind("# Our lab's liver cases.\n#  Ask Ann before updating.\ngenerated_by:", 0), 0u) << text;
  EXPECT_EQ(read_gate_baselines(path).body_comments, 0u);

  const std::string bare = baselines_file("no_header", std::string(kCase) + "}\n");
  GateBaselines c = read_gate_baselines(bare);
  EXPECT_EQ(c.header, "");
  write_gate_baselines(bare, c);
  std::ifstream again(bare);
  std::string first;
  std::getline(again, first);
  EXPECT_EQ(first, "# Force-smoothness gate baselines (ebh gate). Regenerate with");
  std::filesystem::remove(path);
  std::filesystem::remove(bare);
}

TEST(Gate, BandsThatPassEveryBuzzAreRefused) {
  const auto refused = [](const std::string& name, const std::string& bands, const std::string& what) {
    const std::string path = baselines_file(name, "bands: {" + bands + "}\n" + kCase + "}\n");
    try {
      read_gate_baselines(path);
      ADD_FAILURE() << bands << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
    std::filesystem::remove(path);
  };
  refused("power", "abs_power: 0.99", "key 'bands.abs_power': 0.99 passes every run (at most 0.1");
  refused("ratio", "abs_boundary_ratio: 5", "key 'bands.abs_boundary_ratio': 5 passes every run (at most 1");
  // Every band at the ceilings it had: passed a stiffness of 1e7 N/m with the force at its limit.
  refused("peak", "abs_peak_force: 10", "key 'bands.abs_peak_force': 10 passes every run (at most 1 N");
  refused("step", "abs_force_step: 10", "key 'bands.abs_force_step': 10 passes every run (at most 0.1 N a tick");
  refused("rate", "abs_force_rate: 10000", "key 'bands.abs_force_rate': 10000 passes every run (at most 1000 N/s");
  refused("depth", "abs_penetration: 0.01", "key 'bands.abs_penetration': 0.01 passes every run (at most 0.002 m");
}

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The message of the InputError that reading `text` as a baselines file throws ("" for none).
std::string read_error(const std::string& name, const std::string& text) {
  const std::string path = baselines_file(name, text);
  std::string message;
  try {
    read_gate_baselines(path);
  } catch (const InputError& e) {
    message = e.what();
  }
  std::filesystem::remove(path);
  return message;
}

// --update of one case writes that case anew and the others as they were: a case with no ratio
// or power gains no `.nan` key, a duration of 0.3 stays 0.3, a hand-written layout and its
// comment stay; the comment lines between cases go, as --update says. The case measured anew is
// written in the shortest text that reads back as its numbers (0.3, not 0.29999999999999999).
TEST(Gate, ARewriteKeepsTheCasesItDidNotMeasure) {
  const std::string others =
      "  - {name: b, scene: gap, recording: gap_insert, start: 2, duration: 0.3, peak_force: 1.5}\n"
      "  - name: c  # by hand\n"
      "    scene: gap\n"
      "    recording: gap_insert\n"
      "    start: 2\n"
      "    duration: 0.3\n";
  const std::string path = baselines_file(
      "keeps_cases", "cases:\n  - {name: a, scene: tube, recording: tube_insert, start: 4, duration: 0.3}\n"
                     "  # the next two are older\n" + others + "\n# end\n");
  GateBaselines b = read_gate_baselines(path);
  GateCase& a = b.cases[0];
  a.text.clear();  // measured anew
  a.rms_force_step = 0.003;
  a.max_force_rate = 19;
  a.peak_force = 0.09;
  a.power_above_30hz = kNaN;  // none in the window: left out
  a.penetration_max = 1e-4;
  a.boundary_step_ratio = 0.55;
  a.force_collapse = false;
  write_gate_baselines(path, b);
  const std::string text = file_text(path);
  EXPECT_NE(text.find("\ncases:\n  - {name: a, scene: tube, recording: tube_insert, start: 4, duration: 0.3, "
                      "rms_force_step: 0.003, max_force_rate: 19, peak_force: 0.09, "
                      "penetration_max: 0.0001, boundary_step_ratio: 0.55, force_collapse: false}\n" + others),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("nan"), std::string::npos) << text;
  const GateBaselines again = read_gate_baselines(path);
  ASSERT_EQ(again.cases.size(), 3u);
  EXPECT_EQ(again.cases[0].rms_force_step, 0.003);
  EXPECT_TRUE(std::isnan(again.cases[1].boundary_step_ratio));
  EXPECT_EQ(again.cases[2].text, others.substr(others.find("  - name: c")));
  std::filesystem::remove(path);
}

// Cases in a flow list share their lines: all are written from their values, and still a case
// gains no key it lacked.
TEST(Gate, ARewriteOfAFlowListAddsNoKeys) {
  const std::string path = baselines_file(
      "flow_list", "cases: [{name: a, scene: tube, recording: tube_insert, start: 4, duration: 1},\n"
                   "        {name: b, scene: gap, recording: gap_insert, start: 2, duration: 1, peak_force: 1.5}]\n");
  GateBaselines b = read_gate_baselines(path);
  EXPECT_EQ(b.cases[1].text, "");
  write_gate_baselines(path, b);
  const std::string text = file_text(path);
  EXPECT_NE(text.find("  - {name: b, scene: gap, recording: gap_insert, start: 2, duration: 1, peak_force: 1.5}\n"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("nan"), std::string::npos) << text;
  std::filesystem::remove(path);
}

// A kept case that names an anchor of a case written anew would no longer read: then all are
// written from their values.
TEST(Gate, ARewriteKeepsNoCaseThatNamesAnAnchorItDrops) {
  const std::string path = baselines_file(
      "anchor", "cases:\n  - {name: a, scene: &s tube, recording: tube_insert, start: 4, duration: 1}\n"
                "  - {name: b, scene: *s, recording: tube_insert, start: 2, duration: 1}\n");
  GateBaselines b = read_gate_baselines(path);
  b.cases[0].text.clear();
  write_gate_baselines(path, b);
  const GateBaselines again = read_gate_baselines(path);
  EXPECT_EQ(again.cases[1].scene, "tube");
  EXPECT_EQ(file_text(path).find('*'), std::string::npos) << file_text(path);
  std::filesystem::remove(path);
}

// Every message about the file names it, the line of the value (of the map, for a key left out)
// and the key.
TEST(Gate, ErrorsNameTheFileLineAndKey) {
  const std::string block = "# ours\ncases:\n  - name: a\n    scene: tube\n    recording: tube_insert\n";
  EXPECT_EQ(read_error("line_metric", block + "    start: 2\n    duration: 1\n    peak_force: abc\n"),
            baselines_path("line_metric") + ":8: key 'cases[0].peak_force': expected a number, got 'abc'");
  EXPECT_EQ(read_error("line_missing", block + "    duration: 1\n"),
            baselines_path("line_missing") + ":3: key 'cases[0].start': missing (a case gives name, scene, recording, start and duration)");
  EXPECT_EQ(read_error("line_duration", block + "    start: 2\n    duration: 0\n"),
            baselines_path("line_duration") + ":7: key 'cases[0].duration': expected a finite number of seconds > 0 (at least one "
                  "haptic tick), got '0'");
  EXPECT_EQ(read_error("line_band", "bands:\n  relative: 0.5\n  abs_power: 0.5\n" + std::string(kCase) + "}\n"),
            baselines_path("line_band") + ":3: key 'bands.abs_power': 0.5 passes every run (at most 0.1 of the force's power above 30 Hz)");
  EXPECT_EQ(read_error("line_twice", std::string(kCase) + "}\n  - {name: c, scene: gap, recording: gap_insert, start: 2, duration: 1}\n"),
            baselines_path("line_twice") + ":3: key 'cases[1].name': 'c' names two cases");
  EXPECT_EQ(read_error("line_unknown", std::string(kCase) + ", peek: 1}\n"),
            baselines_path("line_unknown") + ":2: key 'cases[0].peek': unknown key (known: name, scene, recording, start, duration, "
                  "rms_force_step, max_force_rate, peak_force, power_above_30hz, penetration_max, boundary_step_ratio, "
                  "force_collapse)");
  EXPECT_EQ(read_error("line_cases", "generated_by: x\ncases: 3\n"),
            baselines_path("line_cases") + ":2: key 'cases': expected a list, got '3'");
  // The case's own messages (a missing scene, its window) start at its line.
  const std::string path = baselines_file("line_where", "\n\ncases:\n  - name: w\n    scene: tube\n    recording: tube_insert\n"
                                                        "    start: 2\n    duration: 1\n");
  EXPECT_EQ(read_gate_baselines(path).cases[0].where, path + ":4: cases[0] (w)");
  std::filesystem::remove(path);
}

// A name of bytes that are not UTF-8 (a Latin-1 editor's) passed the printable-characters check,
// went into --json as they were (invalid JSON) and back into the file by --update (invalid YAML).
// Every text of the file is refused so, with its line and key; UTF-8 names read.
TEST(Gate, TextThatIsNotUtf8IsRefusedWithItsLineAndKey) {
  EXPECT_EQ(read_error("latin1_name", "cases:\n  - {name: c\xff" "1, scene: tube, recording: tube_insert, start: 2, duration: 1}\n"),
            baselines_path("latin1_name") + ":2: key 'cases[0].name': 'c\\xff1' holds byte 0xff, which is not UTF-8 text: "
                                            "save the file as UTF-8");
  EXPECT_EQ(read_error("latin1_scene", "cases:\n  - name: c\n    scene: tub\xe9\n    recording: tube_insert\n"
                                       "    start: 2\n    duration: 1\n"),
            baselines_path("latin1_scene") + ":3: key 'cases[0].scene': 'tub\\xe9' holds byte 0xe9, which is not UTF-8 "
                                             "text: save the file as UTF-8");
  const std::string path = baselines_file("utf8_name", "cases:\n  - {name: \"caf\xc3\xa9 \xe2\x86\x92 1\", scene: tube, "
                                                       "recording: tube_insert, start: 2, duration: 1}\n");
  EXPECT_EQ(read_gate_baselines(path).cases[0].name, "caf\xc3\xa9 \xe2\x86\x92 1");
  std::filesystem::remove(path);
}

// Every number --update writes, the bands' too, is the shortest text that reads back as the same
// double: 0.1 + 0.2 (0.30000000000000004) keeps its 17 digits, 0.1 is 0.1.
TEST(Gate, ARewriteWritesTheShortestNumbersThatReadBack) {
  const std::string path = baselines_file("shortest", std::string(kCase) + "}\n");
  GateBaselines b = read_gate_baselines(path);
  b.cases[0].text.clear();
  b.cases[0].duration = 0.1 + 0.2;
  b.cases[0].peak_force = 0.57253570313821978;
  b.cases[0].max_force_rate = 1e-300;
  write_gate_baselines(path, b);
  const std::string text = file_text(path);
  EXPECT_NE(text.find("bands: {relative: 0.5, abs_force_step: 0.002, abs_force_rate: 5, abs_peak_force: 0.1, abs_power: "
                      "0.005, abs_penetration: 0.0002, abs_boundary_ratio: 0.1}\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("start: 2, duration: 0.30000000000000004, max_force_rate: 1e-300, peak_force: 0.5725357031382198}"),
            std::string::npos)
      << text;
  const GateBaselines again = read_gate_baselines(path);
  EXPECT_EQ(again.cases[0].duration, 0.1 + 0.2);
  EXPECT_EQ(again.cases[0].peak_force, 0.57253570313821978);
  EXPECT_EQ(again.cases[0].max_force_rate, 1e-300);
  EXPECT_EQ(again.bands.abs_peak_force, GateBands{}.abs_peak_force);
  std::filesystem::remove(path);
}

// A YAML tag is read by no key (`start: !ms 2000` read as 2000 s): refused with its line and key,
// as the scene, plan and synth readers refuse one.
TEST(Gate, YamlTagsAreRefused) {
  EXPECT_EQ(read_error("tag_start", "cases:\n  - {name: a, scene: tube, recording: tube_insert, start: !ms 2, duration: 1}\n"),
            baselines_path("tag_start") + ":2: key 'cases[0].start': YAML tag '!ms': ebh reads no tags (each key says what "
                                          "its value is): remove it");
  EXPECT_EQ(read_error("tag_band", "bands: {relative: !!float 0.5}\n" + std::string(kCase) + "}\n"),
            baselines_path("tag_band") + ":1: key 'bands.relative': YAML tag '!!float': ebh reads no tags (each key says "
                                         "what its value is): remove it");
  EXPECT_EQ(read_error("tag_case", "cases:\n  - !case {name: a, scene: tube, recording: tube_insert, start: 2, duration: 1}\n"),
            baselines_path("tag_case") + ":2: key 'cases[0]': YAML tag '!case': ebh reads no tags (each key says what its "
                                         "value is): remove it");
}

// Every case's window is checked against its recording and its scene's haptic tick before any case
// runs (check_gate_case): a start past the recording's end in the second case failed the gate after
// the first case had replayed.
TEST(Gate, ACasesWindowIsCheckedAgainstItsRecordingBeforeItRuns) {
  const std::string path = baselines_file(
      "window", "cases:\n  - {name: a, scene: tube, recording: tube_insert, start: 99, duration: 1}\n"
                "  - {name: b, scene: tube, recording: tube_insert, start: 9.9995, duration: 1}\n"
                "  - {name: c, scene: tube, recording: tube_insert, start: 2, duration: 0.005}\n"
                "  - {name: d, scene: tube, recording: tube_insert, start: 9.9, duration: 1}\n");
  const GateBaselines b = read_gate_baselines(path);
  const auto refused = [&b](std::size_t i, const std::vector<std::string>& set) {
    try {
      check_gate_case(b.cases[i], set);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refused(0, {}).find(path + ":2: cases[0] (a): start 99: the recording "), std::string::npos) << refused(0, {});
  EXPECT_NE(refused(0, {}).find("tube_insert.h5 is 10 s long; start before its end"), std::string::npos) << refused(0, {});
  EXPECT_NE(refused(1, {}).find(path + ":3: cases[1] (b): start 9.9995: leaves 0.0005 s of the recording "),
            std::string::npos)
      << refused(1, {});
  // One tick of the scene under the gate's --set: 5 ms holds a 1 kHz tick, not a 100 Hz one.
  EXPECT_EQ(refused(2, {}), "");
  EXPECT_NE(refused(2, {"time.haptic_hz=100", "time.physical_hz=100"})
                .find(path + ":4: cases[2] (c): duration 0.005: shorter than one haptic tick (0.01 s at 100 Hz)"),
            std::string::npos)
      << refused(2, {"time.haptic_hz=100", "time.physical_hz=100"});
  EXPECT_EQ(refused(3, {}), "");  // cut at the recording's end, as a replay cuts it (run_gate_case warns)
  std::filesystem::remove(path);
}

TEST(Gate, ForceCollapseIsTrueOrFalse) {
  const std::string path = baselines_file("collapse", std::string(kCase) + ", force_collapse: 1}\n");
  try {
    read_gate_baselines(path);
    ADD_FAILURE() << "force_collapse: 1 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'cases[0].force_collapse': expected true or false, got '1'"),
              std::string::npos)
        << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace ebh
