// Checks of a replay's inputs (schedule/replay_inputs.hpp): the one check of a replay window
// (replay_window, what `ebh replay --start --duration` and `ebh gate`'s cases take), the tool's
// tip inside the tissue, a window that starts in it, a jaw signal that lets go and grasps again.
#include <gtest/gtest.h>

#include <limits>
#include <optional>

#include "../io/io_test_util.hpp"
#include "schedule/replay_inputs.hpp"

using namespace ebh;

constexpr double kTick = 1e-3;  ///< s: a 1 kHz haptic tick

TEST(ReplayWindow, TakesAWindowInsideTheRecordingAndCutsItAtTheEnd) {
  EXPECT_EQ(replay_window(0, std::nullopt, 10, kTick, "rec.h5", "--start", "--duration"), 10);
  EXPECT_EQ(replay_window(2, 3.0, 10, kTick, "rec.h5", "--start", "--duration"), 3);
  EXPECT_EQ(replay_window(8, 5.0, 10, kTick, "rec.h5", "--start", "--duration"), 2);  // cut at the end
  // A window that ends at the recording's end keeps its duration (10 - 9.9 is 0.0999999999999996).
  EXPECT_EQ(replay_window(9.9, 0.1, 10, kTick, "rec.h5", "--start", "--duration"), 0.1);
  EXPECT_EQ(replay_window(9.3, 0.7, 10, kTick, "rec.h5", "--start", "--duration"), 0.7);
}

TEST(ReplayWindow, RefusesAWindowOutsideTheRecordingNamingTheKey) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_INPUT_ERROR(replay_window(-1, 1.0, 10, kTick, "rec.h5", "g.yaml: cases[0] (w): start", "d"),
                     "g.yaml: cases[0] (w): start -1: expected a finite number >= 0");
  EXPECT_INPUT_ERROR(replay_window(nan, 1.0, 10, kTick, "rec.h5", "--start", "--duration"), "--start nan");
  EXPECT_INPUT_ERROR(replay_window(100, 1.0, 10, kTick, "rec.h5", "--start", "--duration"),
                     "--start 100: the recording rec.h5 is 10 s long; start before its end");
  EXPECT_INPUT_ERROR(replay_window(10, 1.0, 10, kTick, "rec.h5", "--start", "--duration"), "start before its end");
  EXPECT_INPUT_ERROR(replay_window(1, -1.0, 10, kTick, "rec.h5", "s", "g.yaml: cases[0] (w): duration"),
                     "g.yaml: cases[0] (w): duration -1: expected a finite number > 0");
  EXPECT_INPUT_ERROR(replay_window(1, 0.0, 10, kTick, "rec.h5", "s", "--duration"), "--duration 0: expected a finite number > 0");
  EXPECT_INPUT_ERROR(replay_window(1, std::numeric_limits<double>::infinity(), 10, kTick, "rec.h5", "s", "--duration"),
                     "--duration inf");
}

// A window shorter than one haptic tick replays the tick at its start alone, with no force step to
// measure (`ebh replay --duration 1e-320` wrote one tick and exited 0): refused, naming the option
// that made it so short and the tick's length; one tick (to round-off) is a window.
TEST(ReplayWindow, RefusesAWindowShorterThanOneHapticTick) {
  EXPECT_EQ(replay_window(2, 1e-3, 10, kTick, "rec.h5", "--start", "--duration"), 1e-3);
  EXPECT_EQ(replay_window(9.999, std::nullopt, 10, kTick, "rec.h5", "--start", "--duration"), 10 - 9.999);
  EXPECT_INPUT_ERROR(replay_window(0, 1e-320, 10, kTick, "rec.h5", "--start", "--duration"),
                     "--duration 1e-320: shorter than one haptic tick (0.001 s at 1000 Hz), which replays a single tick "
                     "with no force step to measure: expected at least 0.001 s");
  EXPECT_INPUT_ERROR(replay_window(2, 0.005, 10, 0.01, "rec.h5", "s", "g.yaml: cases[0] (w): duration"),
                     "g.yaml: cases[0] (w): duration 0.005: shorter than one haptic tick (0.01 s at 100 Hz)");
  // The end of the recording cuts the window under a tick: the start's fault, with or without a duration.
  for (const std::optional<double> duration : {std::optional<double>(), std::optional<double>(1.0)})
    EXPECT_INPUT_ERROR(replay_window(9.9995, duration, 10, kTick, "rec.h5", "--start", "--duration"),
                       "--start 9.9995: leaves 0.0005 s of the recording rec.h5 (10 s long), less than one haptic tick "
                       "(0.001 s at 1000 Hz), which replays a single tick with no force step to measure: start at least "
                       "0.001 s before its end");
  EXPECT_INPUT_ERROR(replay_window(0, std::nullopt, 2e-4, kTick, "rec.h5", "--start", "--duration"),
                     "rec.h5: the recording is 0.0002 s long, less than one haptic tick");
}

namespace {
/// One tet: x, y, z >= 0, x + y + z <= 1 (m).
TetMesh unit_tet() {
  TetMesh one;
  one.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  one.tets = {{0, 1, 2, 3}};
  return one;
}

/// Five samples 0.1 s apart from 10 s (the recording's own clock), straight down through
/// unit_tet at x = y = 0.1: z = 1.5, 1.0, 0.5, 0.3, -0.5, inside at 0.5 and 0.3.
Recording down_through_unit_tet() {
  Recording rec;
  const double z[] = {1.5, 1.0, 0.5, 0.3, -0.5};
  for (int i = 0; i < 5; ++i) {
    rec.t.push_back(10.0 + 0.1 * i);
    rec.position.push_back({0.1, 0.1, z[i]});
    rec.orientation.push_back({1, 0, 0, 0});
    rec.jaw.push_back(1);
    rec.buttons.push_back(0);
  }
  return rec;
}
}  // namespace

// A tool's tip that went inside the tissue: the replay that felt no contact then says the tool
// passed between the virtual vertices (tip_inside_mesh, ebh replay's contact warning).
TEST(TipInsideMesh, TheFirstSampleOfTheWindowInsideTheRestMesh) {
  const TetMesh one = unit_tet();
  Recording rec = down_through_unit_tet();
  EXPECT_EQ(tip_inside_mesh(rec, one, 0, 0), std::optional<double>(10.2));
  EXPECT_EQ(tip_inside_mesh(rec, one, 0.25, 0), std::optional<double>(10.3));  // the window starts later
  EXPECT_EQ(tip_inside_mesh(rec, one, 0, 0.15), std::nullopt);                 // and ends before it
  for (Vec3d& p : rec.position) p.x = 2;  // beside the tet
  EXPECT_EQ(tip_inside_mesh(rec, one, 0, 0), std::nullopt);
}

// A hook whose pose's origin stays 1 mm above the tissue while its tip reaches into it: the tip is
// the tool's colliders' end points, not only the origin.
TEST(TipInsideMesh, TheToolsCollidersReachPastItsOrigin) {
  TetMesh slab;  // a tet whose top face is the plane z = 0 around the tool
  slab.vertices = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}, {0, 0, -1}};
  slab.tets = {{0, 2, 1, 3}};
  Recording rec;
  for (int i = 0; i < 3; ++i) {
    rec.t.push_back(0.1 * i);
    rec.position.push_back({0, -0.2, 0.001});  // the origin, 1 mm above the top face
    rec.orientation.push_back({0, 1, 0, 0});   // tool +z (handle to tip) = world -z
    rec.jaw.push_back(1);
  }
  const ToolModel hook = build_tool(ToolSpec{});  // a 6 mm tip
  EXPECT_EQ(tip_inside_mesh(rec, slab, 0, 0), std::nullopt);  // the origin alone is outside
  EXPECT_EQ(tip_inside_mesh(rec, slab, 0, 0, &hook), std::optional<double>(0.0));
}

// A window that starts with the tool in the tissue (--start inside a press): said, with the last
// time before it at which the tool was clear of the tissue; a tip only grazing it (under
// kStartInTissueDepth) or beside it is not.
TEST(StartInTissue, AWindowThatStartsInsideSaysWhenTheToolWasClear) {
  const TetMesh one = unit_tet();
  Recording rec = down_through_unit_tet();
  const auto in = window_starts_in_tissue(rec, one, 0.25);  // z = 0.4 at 10.25 s
  ASSERT_TRUE(in.has_value());
  EXPECT_DOUBLE_EQ(in->t, 10.25);
  EXPECT_EQ(in->clear_t, std::optional<double>(10.1));  // z = 1.0: 0.1 + 0.1 + 1.0 > 1
  const std::string w = start_in_tissue_warning(*in, 0.25, "--start");
  EXPECT_NE(w.find("--start 0.25: the replay starts with the tool's tip 1 mm or more inside the tissue (at the "
                   "recording's t = 10.25 s)"), std::string::npos) << w;
  EXPECT_NE(w.find("; start at or before 0.1 s into the recording, where the tool was clear of it"), std::string::npos) << w;
  EXPECT_EQ(window_starts_in_tissue(rec, one, 0.05), std::nullopt);  // z = 1.25: above it
  rec.position[0].z = rec.position[1].z = 0.6;  // inside from the recording's first sample
  const auto from_first = window_starts_in_tissue(rec, one, 0.25);
  ASSERT_TRUE(from_first.has_value());
  EXPECT_EQ(from_first->clear_t, std::nullopt);
  for (Vec3d& p : rec.position) p.z = 0.7999;  // 0.1 mm under the slanted face: grazing it
  EXPECT_EQ(window_starts_in_tissue(rec, one, 0.25), std::nullopt);
  for (Vec3d& p : rec.position) p.x = 2;  // beside the tet
  EXPECT_EQ(window_starts_in_tissue(rec, one, 0.25), std::nullopt);
}

// Read as a window (the samples from the file's row 3, and the whole path's outline), the time the
// tool was clear of the tissue comes from the outline's rows, at their own times.
TEST(StartInTissue, ReadAsAWindowTheOutlineSaysWhenTheToolWasClear) {
  const TetMesh one = unit_tet();
  const double z[] = {1.5, 1.0, 0.5, 0.4, 0.3};  // rows 0-4, 0.1 s apart from 10 s; clear at rows 0 and 1
  Recording rec;
  Recording::FileSpan span;
  span.t_first = 10.0;
  span.t_last = 10.4;
  span.first_row = 3;
  for (int i = 0; i < 5; ++i) {
    span.outline.push_back({0.1, 0.1, z[i]});
    span.outline_orientation.push_back({1, 0, 0, 0});
    span.outline_t.push_back(10.0 + 0.1 * i);
    if (i < 3) continue;
    rec.t.push_back(10.0 + 0.1 * i);
    rec.position.push_back({0.1, 0.1, z[i]});
    rec.orientation.push_back({1, 0, 0, 0});
    rec.jaw.push_back(1);
    rec.buttons.push_back(0);
  }
  rec.span = span;
  const auto in = window_starts_in_tissue(rec, one, 0.35);
  ASSERT_TRUE(in.has_value());
  EXPECT_DOUBLE_EQ(in->t, 10.35);
  ASSERT_TRUE(in->clear_t.has_value());
  EXPECT_EQ(*in->clear_t, 10.0 + 0.1 * 1);  // row 1's time
}

// A device whose rate changes (10 Hz while the tool approaches, 1 kHz once it is in the tissue),
// read from its file as a replay of --start 0.45 --duration 0.02 reads it: the time the tool was
// last clear of the tissue is that sample's own, 0.3 s, not one counted back at the window's
// mean rate (51 rows at 1 kHz from 0.45 s: 0.399 s, when the tool was already in it).
TEST(StartInTissue, AnUnevenRecordingReadAsAWindowSaysWhenTheToolWasClear) {
  const test::ScratchDir dir;
  Recording rec;
  rec.tool = "hook";
  auto sample = [&rec](double t, double z) {
    rec.t.push_back(t);
    rec.position.push_back({0.1, 0.1, z});  // in unit_tet where z <= 0.8
    rec.orientation.push_back({1, 0, 0, 0});
    rec.jaw.push_back(1);
    rec.buttons.push_back(0);
  };
  for (int i = 0; i < 4; ++i) sample(0.1 * i, 1.5 - 0.1 * i);  // rows 0-3, clear of the tet
  for (int k = 0; k <= 100; ++k) sample(0.4 + 0.001 * k, 0.7);  // rows 4-104, inside it
  write_recording(dir / "uneven.h5", rec);
  const Recording window = read_recording(dir / "uneven.h5", RecordingWindow{0.45, 0.02});
  ASSERT_TRUE(window.span && window.span->first_row > 4) << "the test needs a window read from the fast part";
  const auto in = window_starts_in_tissue(window, unit_tet(), 0.45);
  ASSERT_TRUE(in.has_value() && in->clear_t.has_value());
  EXPECT_EQ(*in->clear_t, 0.1 * 3);
  EXPECT_NE(start_in_tissue_warning(*in, 0.45, "--start").find("start at or before 0.3 s into the recording"),
            std::string::npos);
}

// A noisy gripper: the jaw wanders across the grasp threshold while the forceps hold tissue, and
// each crossing back lets go and grasps again (said, with how often); a release threshold above the
// noise holds on, and the committed recording's clean signal is not a flicker.
TEST(GraspFlicker, AJawThatLetsGoAndGraspsAgainIsSaid) {
  RecordingFile file = read_replay_recording("tube_grasp");
  auto warned = [](const LoadedReplay& r) {
    for (const std::string& w : r.warnings)
      if (w.find("let go and grasp again") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(warned(load_replay_scene(RecordingFile(file), "tube_forceps", {}, std::nullopt, std::nullopt, false, Backend::Cpu)), "");
  // The jaws stand open at 3 s; 0.1 s of noise across 0.2 every 5 ms from then: closed at 3.000 s,
  // let go at 3.005 s, grasping again at 3.010 s, ..., let go at 3.095 s: 9 grasps again.
  for (std::size_t i = 0; i < file.recording.size(); ++i)
    if (file.recording.t[i] >= 3.0 && file.recording.t[i] < 3.1)
      file.recording.jaw[i] = (i / 5) % 2 == 0 ? 0.1 : 0.25;
  const std::string w = warned(load_replay_scene(RecordingFile(file), "tube_forceps", {}, std::nullopt, std::nullopt, false, Backend::Cpu));
  EXPECT_NE(w.find("the jaws let go and grasp again within 50 ms 9 times, first at the recording's t = 3.010 s"),
            std::string::npos) << w;
  EXPECT_EQ(warned(load_replay_scene(RecordingFile(file), "tube_forceps", {"tool.forceps.release_threshold=0.3"},
                                     std::nullopt, std::nullopt, false, Backend::Cpu)), "");
}

// A forceps log whose jaw is in another range than 0 closed .. 1 open: logged the other way round
// (1 closed) or in radians (0 .. 0.52): said, naming --jaw-range; the committed one is not.
TEST(JawRange, AJawInAnotherRangeIsDoubted) {
  const RecordingFile file = read_replay_recording("tube_grasp");
  auto warned = [](RecordingFile f) {
    for (const std::string& w :
         load_replay_scene(std::move(f), "tube_forceps", {}, std::nullopt, std::nullopt, false, Backend::Cpu).warnings)
      if (w.find("--jaw-range") != std::string::npos || w.find("--jaw-button") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(warned(file), "");
  RecordingFile inverted = file, radians = file;
  for (double& j : inverted.recording.jaw) j = 1 - j;
  for (double& j : radians.recording.jaw) j *= 0.5235987755982988;
  EXPECT_NE(warned(inverted).find("the jaws are closed at the first sample and for 59% of the recording: a jaw logged "
                                  "the other way round (1 closed, 0 open)? `ebh import --jaw-range 1,0` turns it"),
            std::string::npos)
      << warned(inverted);
  EXPECT_NE(warned(radians).find("the jaws never open past 0.524 (1 is fully open)"), std::string::npos) << warned(radians);
  // A device without a gripper: the jaw stands open while a button is pressed, named with the
  // option that makes the jaw follow it.
  RecordingFile button = file;
  for (std::size_t i = 0; i < button.recording.size(); ++i) {
    button.recording.buttons[i] = button.recording.jaw[i] < 0.2 ? 2 : 0;
    button.recording.jaw[i] = 1;
  }
  EXPECT_NE(warned(button).find("the jaws stand at 1 throughout while button 1 is pressed"), std::string::npos)
      << warned(button);
  EXPECT_NE(warned(button).find("`ebh import --jaw-button 1` closes the jaws while it is pressed"), std::string::npos);
  // `ebh replay` reads through a window even without --start or --duration: one that holds the
  // whole file is the whole log; one inside it (which may start inside a grasp) is not judged.
  for (const auto& [window, judged] : {std::pair{RecordingWindow{0, 0}, true}, std::pair{RecordingWindow{0, 20}, true},
                                       std::pair{RecordingWindow{2, 0}, false}}) {
    RecordingFile read = read_replay_recording("tube_grasp", window);
    ASSERT_TRUE(read.recording.span);
    for (double& j : read.recording.jaw) j *= 0.5235987755982988;
    EXPECT_EQ(warned(std::move(read)).empty(), !judged) << window.start << " " << window.duration;
  }
}

// The recording's tool attribute: one that is neither hook nor forceps, or the other kind on its
// own scene, is said (the replay moves the scene's tool); a recording of another scene says so
// once, as the scene mismatch.
TEST(ToolMismatch, TheRecordingsToolAgainstTheScenes) {
  const RecordingFile file = read_replay_recording("tube_insert");
  auto warnings = [&file](const std::string& tool, const std::string& scene) {
    RecordingFile f = file;
    f.recording.tool = tool;
    std::string all;
    for (const std::string& w : load_replay_scene(std::move(f), scene, {}, std::nullopt, std::nullopt, false,
                                                  Backend::Cpu).warnings)
      all += w + "\n";
    return all;
  };
  EXPECT_EQ(warnings("hook", "tube").find("tool"), std::string::npos);
  EXPECT_NE(warnings("banana", "tube").find("attribute tool = 'banana' is neither hook nor forceps: the replay moves "
                                            "the scene's hook"), std::string::npos);
  EXPECT_NE(warnings("forceps", "tube").find("recorded with a forceps (its tool attribute) and replayed with the "
                                             "scene's hook"), std::string::npos);
  const std::string other = warnings("hook", "tube_forceps");
  EXPECT_NE(other.find("recorded for the scene 'tube'"), std::string::npos) << other;
  EXPECT_EQ(other.find("its tool attribute"), std::string::npos) << other;
  // An attribute's text is quoted on one line and clipped: a newline escaped, a megabyte cut.
  EXPECT_NE(warnings("hook\nrm", "tube").find("attribute tool = 'hook\\x0arm' is neither"), std::string::npos);
  EXPECT_LT(warnings(std::string(1 << 20, 'x'), "tube").size(), 400u);
  RecordingFile renamed = file;
  renamed.recording.scene = "gap\nrm";
  const LoadedReplay r = load_replay_scene(std::move(renamed), "tube", {}, std::nullopt, std::nullopt, false, Backend::Cpu);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings[0].find("recorded for the scene 'gap\\x0arm'"), std::string::npos) << r.warnings[0];
}

// Surface contact renders a k_con below its floor (F_limit / (1.5 x the thinnest part)) as the
// floor: a replay says so, naming where the value came from, and the output records what the
// samples got; at or above the floor nothing is said.
TEST(SurfaceContactFloor, AKConBelowTheFloorIsSaid) {
  const RecordingFile file = read_replay_recording("tube_insert");
  auto floor_warning = [&file](const std::vector<std::string>& set) {
    for (const std::string& w : load_replay_scene(RecordingFile(file), "tube", set, std::nullopt, std::nullopt, false,
                                                  Backend::Cpu).warnings)
      if (w.find("below surface contact's floor") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(floor_warning({}), "");  // vertex contact: no floor
  const std::string w = floor_warning({"contact=surface", "stiffness.k_con=200"});
  EXPECT_EQ(w.rfind("--set 'stiffness.k_con=200': stiffness.k_con = 200 N/m is below surface contact's floor, 2200 N/m "
                    "(tool.force_limit 3.3 N over 1.5 x the tool's thinnest part, 1 mm), which it renders with",
                    0),
            0u)
      << w;
  EXPECT_NE(floor_warning({"contact=surface"}).find("stiffness.k_con = 400 N/m"), std::string::npos);
  EXPECT_EQ(floor_warning({"contact=surface", "stiffness.k_con=2200"}), "");
}

// Below a device's 1 kHz the force of a press has not converged in the haptic rate: a replay says
// so, naming the option or the key; at 1 kHz and above nothing is said.
TEST(HapticRate, BelowOneKilohertzIsSaid) {
  const RecordingFile file = read_replay_recording("tube_insert");
  auto rate_warning = [&file](const std::vector<std::string>& set, std::optional<double> haptic_hz) {
    for (const std::string& w : load_replay_scene(RecordingFile(file), "tube", set, haptic_hz, 100.0, false,
                                                  Backend::Cpu).warnings)
      if (w.find("has not converged in the rate") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(rate_warning({}, std::nullopt), "");
  EXPECT_EQ(rate_warning({}, 2000.0), "");
  EXPECT_EQ(rate_warning({}, 500.0).rfind("--haptic-hz 500 Hz: below a haptic device's 1 kHz", 0), 0u) << rate_warning({}, 500.0);
  EXPECT_EQ(rate_warning({"time.haptic_hz=200"}, std::nullopt).rfind("--set 'time.haptic_hz=200': time.haptic_hz 200 Hz", 0), 0u)
      << rate_warning({"time.haptic_hz=200"}, std::nullopt);
}
