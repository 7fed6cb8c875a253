// Sweeps (lib/sweep): plans read and checked, run ids, the force error against a reference, the
// summary's CSV and the report's Pareto front. The replays themselves run in tests/sweep/*.sh.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <thread>

#include "../io/io_test_util.hpp"
#include "core/error.hpp"
#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "io/sha256.hpp"
#include "scene/scene.hpp"
#include "io/recording.hpp"
#include "sweep/plan.hpp"
#include "sweep/report.hpp"
#include "sweep/runner.hpp"
#include "sweep/summary.hpp"

namespace ebh {
namespace {
namespace fs = std::filesystem;

fs::path scratch() {
  const fs::path d = fs::path(EBH_BINARY_DIR) / "test_sweep";
  fs::create_directories(d);
  return d;
}

/// Writes a plan with `text` and returns its path.
fs::path plan_file(const std::string& name, const std::string& text) {
  const fs::path p = scratch() / name;
  std::ofstream(p) << text;
  return p;
}

/// A stand-in for `ebh replay` in tests/sweep/ (a shell script that behaves as one case needs).
std::string test_replay(const std::string& script) { return std::string(EBH_TEST_DATA_DIR) + "/../sweep/" + script; }

/// The hand-made summary (tests/data/sweep/front) and its text.
std::string front_file() { return std::string(EBH_TEST_DATA_DIR) + "/sweep/front/summary.csv"; }
std::string front_text() {
  std::ifstream in(front_file());
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

const char* kPlan = R"(# two scenes' worth of keys on the tube
scenes:
  - scene: tube
    recordings: [tube_insert]
    reference: {solver.method: direct, solver.virtual_iterations: 32}
grid:
  solver.virtual_iterations: [1, 2, 4]
  stiffness.k_con: [400, 800]
set: {gravity: [0, 0, -9.81]}
backends: [cpu, cuda]
repetitions: 2
start: 4
duration: 0.5
)";

TEST(SweepPlan, GridExpandsToEveryCombinationLastKeyFastest) {
  const SweepPlan p = read_sweep_plan(plan_file("grid.yaml", kPlan));
  ASSERT_EQ(p.scenes.size(), 1u);
  EXPECT_EQ(p.scenes[0].name, "tube");
  ASSERT_EQ(p.scenes[0].recordings.size(), 1u);
  EXPECT_EQ(p.scenes[0].recordings[0].filename(), "tube_insert.h5");
  EXPECT_TRUE(p.scenes[0].recordings[0].is_absolute());
  ASSERT_EQ(p.configurations.size(), 6u);
  EXPECT_EQ(p.configurations[0], (Overrides{{"solver.virtual_iterations", "1"}, {"stiffness.k_con", "400"}}));
  EXPECT_EQ(p.configurations[1], (Overrides{{"solver.virtual_iterations", "1"}, {"stiffness.k_con", "800"}}));
  EXPECT_EQ(p.configurations[5], (Overrides{{"solver.virtual_iterations", "4"}, {"stiffness.k_con", "800"}}));
  EXPECT_EQ(p.set.at("gravity"), "[0, 0, -9.81]");
  EXPECT_EQ(p.repetitions, 2);
  EXPECT_EQ(p.duration, 0.5);
  const std::vector<SweepRun> runs = expand_plan(p);
  // 1 reference + 6 configurations x 2 backends x 2 repetitions.
  ASSERT_EQ(runs.size(), 25u);
  EXPECT_TRUE(runs[0].reference);
  EXPECT_EQ(runs[0].backend, "cpu");
  EXPECT_EQ(runs[0].effective.at("gravity"), "[0, 0, -9.81]");
  for (const SweepRun& r : runs) EXPECT_EQ(r.reference_id, runs[0].id);
  EXPECT_EQ(runs[1].set_arguments(),
            (std::vector<std::string>{"gravity=[0, 0, -9.81]", "solver.virtual_iterations=1", "stiffness.k_con=400"}));
}

TEST(SweepPlan, ListDefaultsAndTheReferenceConfigurationIsOneRun) {
  const SweepPlan p = read_sweep_plan(plan_file("list.yaml", R"(
scenes:
  - {scene: tube, recordings: all, reference: {solver.virtual_iterations: 8}}
runs:
  - {solver.virtual_iterations: 8}
  - {}
)"));
  EXPECT_EQ(p.backends, std::vector<std::string>{"cpu"});
  EXPECT_EQ(p.reference_backend, "cpu");
  EXPECT_EQ(p.repetitions, 1);
  EXPECT_EQ(p.mode, "async");
  EXPECT_EQ(p.duration, 0.0);
  // `all`: the recordings whose scene attribute is tube.
  bool insert = false;
  for (const fs::path& r : p.scenes[0].recordings) insert |= r.filename() == "tube_insert.h5";
  EXPECT_TRUE(insert);
  const std::vector<SweepRun> runs = expand_plan(p);
  // Per recording: the reference (= the first entry on the CPU) and the scene as it is.
  EXPECT_EQ(runs.size(), 2 * p.scenes[0].recordings.size());
  EXPECT_EQ(runs[0].overrides_text(), "solver.virtual_iterations=8");
  const auto plain = std::find_if(runs.begin(), runs.end(), [](const SweepRun& r) { return r.overrides.empty(); });
  ASSERT_NE(plain, runs.end());
  EXPECT_EQ(plain->overrides_text(), "-");
}

// `set` is the default of a key some list entries give their own value (the others replay it).
TEST(SweepPlan, ASetKeyThatSomeRunsOverrideIsTheOthersValue) {
  const SweepPlan p = read_sweep_plan(plan_file("set_default.yaml", R"(
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {solver.method: direct}}
set: {solver.virtual_iterations: 3}
runs:
  - {solver.virtual_iterations: 8}
  - {}
)"));
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[1].effective.at("solver.virtual_iterations"), "8");
  EXPECT_EQ(runs[2].effective.at("solver.virtual_iterations"), "3");
}

TEST(SweepPlan, ANumberWrittenTwoWaysIsOneConfiguration) {
  const SweepPlan p = read_sweep_plan(plan_file("forms.yaml", R"(
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {stiffness.k_con: 1000.0}}
grid:
  stiffness.k_con: [1e3, 1000, 2E3, 0.5e4]
set: {gravity: [0, 0.0, -9.810]}
baseline: {set: {stiffness.k_con: 2000}}
)"));
  ASSERT_EQ(p.configurations.size(), 3u);
  EXPECT_EQ(p.configurations[0], (Overrides{{"stiffness.k_con", "1000"}}));
  EXPECT_EQ(p.configurations[1], (Overrides{{"stiffness.k_con", "2000"}}));
  EXPECT_EQ(p.configurations[2], (Overrides{{"stiffness.k_con", "5000"}}));
  EXPECT_EQ(p.set.at("gravity"), "[0, 0, -9.81]");
  // The reference is the grid's first configuration, the baseline its second: no runs of their own.
  EXPECT_EQ(expand_plan(p).size(), 3u);
}

// A leading + is the number's sign and -0 is 0 (YAML reads them so): 500, +500 and +5e2 are one
// configuration, and so are 0 and -0, in a value and in a list.
TEST(SweepPlan, ASignedNumberIsOneConfiguration) {
  const SweepPlan p = read_sweep_plan(plan_file("signs.yaml", R"(
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {stiffness.k_con: 500}}
runs:
  - {stiffness.k_con: +500}
  - {stiffness.k_con: +5e2}
  - {stiffness.k_con: 500, gravity: [-0, +0.0, -9.81]}
  - {stiffness.k_con: 500, gravity: [0, 0, -9.81]}
set: {solver.active_region: -0}
)"));
  ASSERT_EQ(p.configurations.size(), 2u);
  EXPECT_EQ(p.configurations[0], (Overrides{{"stiffness.k_con", "500"}}));
  EXPECT_EQ(p.configurations[1].at("gravity"), "[0, 0, -9.81]");
  EXPECT_EQ(p.set.at("solver.active_region"), "0");
  // The first configuration is the reference's: one run of its own, the gravity one.
  EXPECT_EQ(expand_plan(p).size(), 2u);
}

// A value is passed on as `--set` text that reads back as the plan's value: a text holding " #"
// as it is (the replay's --set keeps it: once YAML took the rest for a comment), one that --set
// would read as a list, a map or nothing quoted; the resolved plan reads back to the same runs.
TEST(SweepPlan, AValueReachesTheReplayAsTheTextItIs) {
  const SweepPlan p = read_sweep_plan(plan_file("texts.yaml", R"(
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {}}
runs:
  - {description: 'a #b'}
  - {description: '[1, 2]'}
  - {description: 'x: y'}
  - {description: '~'}
  - {description: "#1", gravity: [0, 0, -9.81], stages.settle: false}
)"));
  ASSERT_EQ(p.configurations.size(), 5u);
  EXPECT_EQ(p.configurations[0].at("description"), "a #b");
  EXPECT_EQ(p.configurations[1].at("description"), "\"[1, 2]\"");
  EXPECT_EQ(p.configurations[2].at("description"), "\"x: y\"");
  EXPECT_EQ(p.configurations[3].at("description"), "\"~\"");
  EXPECT_EQ(p.configurations[4].at("description"), "#1");
  EXPECT_EQ(p.configurations[4].at("gravity"), "[0, 0, -9.81]");
  EXPECT_EQ(p.configurations[4].at("stages.settle"), "false");
  const fs::path scene = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  const char* texts[] = {"a #b", "[1, 2]", "x: y", "~", "#1"};
  const std::vector<SweepRun> runs = expand_plan(p);
  for (std::size_t i = 0; i < 5; ++i) {
    SweepRun r;
    r.effective = p.configurations[i];
    EXPECT_EQ(load_scene_spec(scene, r.set_arguments()).description, texts[i]);
  }
  const SweepPlan again = read_sweep_plan(plan_file("texts_resolved.yaml", resolved_plan_yaml(p)));
  EXPECT_EQ(again.configurations, p.configurations);
  const std::vector<SweepRun> runs_again = expand_plan(again);
  ASSERT_EQ(runs_again.size(), runs.size());
  for (std::size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs_again[i].id, runs[i].id);
}

/// `recordings: all` takes a recording whose scene attribute is the scene file's path relative to
/// the recording (as `ebh import --scene FILE` writes it), not only its name.
TEST(SweepPlan, AllTakesARecordingThatNamesTheSceneByItsFile) {
  const fs::path root = scratch() / "own_data";
  fs::remove_all(root);
  fs::create_directories(root / "recordings");
  Recording rec = read_recording(resolve_data_path("tube_insert", "recordings", ".h5", "recording").string());
  const fs::path tube = resolve_scene_path("tube");
  rec.scene = fs::absolute(tube).lexically_normal().lexically_relative(fs::absolute(root / "recordings")).string();
  ASSERT_NE(rec.scene.find('/'), std::string::npos);
  write_recording((root / "recordings" / "own_press.h5").string(), rec);
  ::setenv("EBH_DATA_DIR", root.c_str(), 1);
  const SweepPlan p = read_sweep_plan(plan_file("own.yaml", R"(
scenes:
  - {scene: tube, recordings: all, reference: {solver.virtual_iterations: 8}}
runs:
  - {}
)"));
  ::unsetenv("EBH_DATA_DIR");
  bool own = false, insert = false;
  for (const fs::path& r : p.scenes[0].recordings) {
    own |= r.filename() == "own_press.h5";
    insert |= r.filename() == "tube_insert.h5";
  }
  EXPECT_TRUE(own);
  EXPECT_TRUE(insert);
}

/// ... and one beside the scene file (own data kept in one folder: scene, mesh, recordings); with
/// none, the message says where it looked.
TEST(SweepPlan, AllTakesARecordingBesideItsSceneFile) {
  const fs::path root = scratch() / "own_folder";
  fs::remove_all(root);
  fs::create_directories(root);
  const fs::path scene = root / "my_tube.yaml";
  const fs::path tube = resolve_scene_path("tube");
  fs::copy_file(tube, scene);
  fs::copy_file(tube.parent_path() / "tube.msh", root / "tube.msh");
  const std::string plan = "scenes:\n  - {scene: " + scene.string() +
                           ", recordings: all, reference: {solver.virtual_iterations: 8}}\nruns:\n  - {}\n";
  try {
    (void)read_sweep_plan(plan_file("beside_none.yaml", plan));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no recording names the scene 'my_tube' (their `scene` attribute) in "
                                         "recordings/ of the data folders"),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("beside the scene file in " + root.string()), std::string::npos) << e.what();
  }
  Recording rec = read_recording(resolve_data_path("tube_insert", "recordings", ".h5", "recording").string());
  rec.scene = "my_tube.yaml";  // as `ebh import --scene my_tube.yaml -o press.h5` writes it beside the scene
  write_recording((root / "press.h5").string(), rec);
  const SweepPlan p = read_sweep_plan(plan_file("beside.yaml", plan));
  ASSERT_EQ(p.scenes[0].recordings.size(), 1u);
  EXPECT_EQ(p.scenes[0].recordings[0].filename(), "press.h5");
}

/// ... and the recordings of the scene a refined or degraded one was made from (NAME_l1, NAME_q0.05),
/// as a replay takes them.
TEST(SweepPlan, AllTakesTheRecordingsOfTheSceneARefinedOneWasMadeFrom) {
  const fs::path root = scratch() / "refined_scene";
  fs::remove_all(root);
  fs::create_directories(root);
  const fs::path tube = resolve_scene_path("tube");
  std::ostringstream read;
  read << std::ifstream(tube).rdbuf();
  std::string text = read.str();
  text.replace(text.find("\nname: tube\n"), 12, "\nname: tube_l1\n");
  std::ofstream(root / "tube_l1.yaml") << text;
  fs::copy_file(tube.parent_path() / "tube.msh", root / "tube.msh");
  const SweepPlan p = read_sweep_plan(plan_file("refined.yaml", "scenes:\n  - {scene: " + (root / "tube_l1.yaml").string() +
                                                                    ", recordings: all, reference: {}}\nruns:\n  - {}\n"));
  ASSERT_EQ(p.scenes[0].name, "tube_l1");
  ASSERT_EQ(p.scenes[0].recordings.size(), 1u);
  EXPECT_EQ(p.scenes[0].recordings[0].filename(), "tube_insert.h5");
}

TEST(SweepPlan, RunIdsAreStable) {
  const fs::path f = plan_file("ids.yaml", kPlan);
  const SweepPlan p = read_sweep_plan(f);
  const std::vector<SweepRun> a = expand_plan(p), b = expand_plan(read_sweep_plan(f));
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_TRUE(std::regex_match(a[i].id, std::regex("[0-9a-f]{16}")));
  }
  // The resolved copy a sweep keeps in its folder gives the same runs.
  const SweepPlan copy = read_sweep_plan(plan_file("ids_copy.yaml", resolved_plan_yaml(p)));
  const std::vector<SweepRun> c = expand_plan(copy);
  ASSERT_EQ(c.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(c[i].id, a[i].id);
  // Key order in the plan does not matter; every part of the replay does.
  std::string swapped = kPlan;
  swapped.replace(swapped.find("start: 4\nduration: 0.5"), 22, "duration: 0.5\nstart: 4");
  EXPECT_EQ(expand_plan(read_sweep_plan(plan_file("ids_swapped.yaml", swapped)))[3].id, a[3].id);
  const Overrides o = a[3].effective;
  const fs::path scene_file = p.scenes[0].scene_file, rec_file = p.scenes[0].recordings[0];
  const std::string scene = p.scenes[0].inputs_sha256, rec = sha256_file(rec_file.string());
  const std::string id = run_id(p, scene, rec, o, a[3].backend, a[3].repetition);
  EXPECT_EQ(id, a[3].id);
  EXPECT_NE(run_id(p, scene, rec, o, a[3].backend == "cpu" ? "cuda" : "cpu", a[3].repetition), id);
  EXPECT_NE(run_id(p, scene, rec, o, a[3].backend, a[3].repetition + 1), id);
  Overrides o2 = o;
  o2["stiffness.k_con"] = "401";
  EXPECT_NE(run_id(p, scene, rec, o2, a[3].backend, a[3].repetition), id);
  SweepPlan shorter = p;
  shorter.duration = 0.25;
  EXPECT_NE(run_id(shorter, scene, rec, o, a[3].backend, a[3].repetition), id);
  SweepPlan lockstep = p;
  lockstep.mode = "lockstep";
  EXPECT_NE(run_id(lockstep, scene, rec, o, a[3].backend, a[3].repetition), id);
  EXPECT_EQ(a[3].legacy_id, legacy_run_id(p, scene_file, rec_file, o, a[3].backend, a[3].repetition));
  EXPECT_NE(a[3].legacy_id, id);

  // The ids come from the files' contents, not their paths: the scene (with its mesh) and the
  // recording copied elsewhere under other names give the same ids (a folder's runs found from
  // another checkout or machine); the mesh the scene names edited, or the scene file, gives its
  // runs other ids (two copies of one scene text beside different meshes are different runs).
  const fs::path elsewhere = scratch() / "ids_elsewhere";
  fs::remove_all(elsewhere);
  fs::create_directories(elsewhere);
  fs::copy_file(scene_file, elsewhere / "my_tube.yaml");
  fs::copy_file(scene_file.parent_path() / "tube.msh", elsewhere / "tube.msh");
  fs::copy_file(rec_file, elsewhere / "my_insert.h5");
  std::string moved = kPlan;
  moved.replace(moved.find("scene: tube"), 11, "scene: " + (elsewhere / "my_tube.yaml").string());
  moved.replace(moved.find("[tube_insert]"), 13, "[" + (elsewhere / "my_insert.h5").string() + "]");
  const std::vector<SweepRun> m = expand_plan(read_sweep_plan(plan_file("ids_moved.yaml", moved)));
  ASSERT_EQ(m.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(m[i].id, a[i].id);
    EXPECT_NE(m[i].legacy_id, a[i].legacy_id);
  }
  std::ofstream(elsewhere / "tube.msh", std::ios::app) << "\n";
  const std::vector<SweepRun> e = expand_plan(read_sweep_plan(plan_file("ids_moved.yaml", moved)));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NE(e[i].id, a[i].id);
  std::ofstream(elsewhere / "my_tube.yaml", std::ios::app) << "# edited\n";
  const std::vector<SweepRun> e2 = expand_plan(read_sweep_plan(plan_file("ids_moved.yaml", moved)));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NE(e2[i].id, e[i].id);
}

// `baseline`: a named configuration added to the runs once (not again when a list entry is it),
// flagged on its runs, kept by the resolved copy with the same ids; the paper's configuration
// (tool.newton_calls below solver.virtual_iterations) is a plan value like any scene key.
TEST(SweepPlan, BaselineIsANamedConfiguration) {
  const char* text = R"(
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {solver.virtual_iterations: 8}}
runs:
  - {solver.virtual_iterations: 2}
  - {solver.virtual_iterations: 4, tool.newton_calls: 2}
baseline:
  name: paper
  set: {solver.virtual_iterations: 3, tool.newton_calls: 1, tool.newton_iterations: 1}
duration: 0.5
)";
  const SweepPlan p = read_sweep_plan(plan_file("baseline.yaml", text));
  ASSERT_TRUE(p.baseline.has_value());
  EXPECT_EQ(p.baseline_name, "paper");
  ASSERT_EQ(p.configurations.size(), 3u);
  EXPECT_EQ(p.configurations[2], *p.baseline);
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 4u);  // the reference and three configurations
  std::vector<std::string> flagged;
  for (const SweepRun& r : runs)
    if (r.baseline) flagged.push_back(r.overrides_text());
  EXPECT_EQ(flagged, std::vector<std::string>{"solver.virtual_iterations=3 tool.newton_calls=1 tool.newton_iterations=1"});
  const std::vector<SweepRun> again = expand_plan(read_sweep_plan(plan_file("baseline_copy.yaml", resolved_plan_yaml(p))));
  ASSERT_EQ(again.size(), runs.size());
  for (std::size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(again[i].id, runs[i].id);
    EXPECT_EQ(again[i].baseline, runs[i].baseline);
  }
  // A baseline that is one of the runs adds none; one that is the reference flags the reference.
  std::string same = text;
  same.replace(same.find("{solver.virtual_iterations: 3, tool.newton_calls: 1, tool.newton_iterations: 1}"), 79,
               "{solver.virtual_iterations: 2}");
  EXPECT_EQ(expand_plan(read_sweep_plan(plan_file("baseline_same.yaml", same))).size(), 3u);
  std::string ref = text;
  ref.replace(ref.find("{solver.virtual_iterations: 3, tool.newton_calls: 1, tool.newton_iterations: 1}"), 79,
              "{solver.virtual_iterations: 8}");
  const std::vector<SweepRun> r2 = expand_plan(read_sweep_plan(plan_file("baseline_ref.yaml", ref)));
  ASSERT_EQ(r2.size(), 3u);
  EXPECT_TRUE(r2[0].reference && r2[0].baseline);
}

/// A plan of more runs than kMaxSweepRuns is refused from its counts, naming the key that makes
/// them, before any configuration is loaded on a scene (1e5 of them took 83 s to refuse).
TEST(SweepPlan, TooManyRunsAreRefusedBeforeLoading) {
  auto refused = [](const std::string& name, const std::string& text, const std::string& expected) {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      (void)read_sweep_plan(plan_file(name, text));
      ADD_FAILURE() << name << " accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(std::regex_search(e.what(), std::regex(expected))) << e.what() << "\n  expected: " << expected;
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  std::string values;
  for (int i = 1; i <= 100000; ++i) values += (i > 1 ? ", " : "") + std::to_string(i);
  const std::string scenes = "scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\n";
  // 1e5 configurations and the reference: one run too many.
  refused("many_values.yaml", scenes + "grid:\n  stiffness.k_con: [" + values + "]\n",
          ":4: key 'grid': the plan makes 100001 runs or more \\(100000 configurations x 1 backends x 1 repetitions x 1 "
          "recordings, and their references\\); at most 100000");
  values.resize(values.find(", 1001,"));
  // 1000 configurations x 1000 repetitions: before the scene is read (the counts alone decide).
  const double seconds = refused("many_repetitions.yaml",
                                 "scenes:\n  - {scene: no_such_scene, recordings: [tube_insert], reference: {}}\n"
                                 "grid:\n  stiffness.k_con: [" + values + "]\nrepetitions: 1000\n",
                                 ":5: key 'repetitions': the plan makes 1000000 runs or more");
  EXPECT_LT(seconds, 2.0) << "a loose bound: the refusal loads no scene (it took 4.6 s loading 1000 of them)";
}

/// Each bad plan: one line naming the plan file, the line and the key, and what is wrong.
TEST(SweepPlan, BadPlansNameFileAndKey) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nwhatever: 1\n", ":2: key 'whatever': unknown key"},
      {"grid: {solver.virtual_iterations: [1]}\n", ": key 'scenes': missing \\(required\\)"},
      // A grid's keys are any overrides, but a merge key is none of them (yaml_map_entries).
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: &r {}}]\ngrid: {<<: *r}\n",
       ":2: key 'grid.<<': YAML merge keys \\('<<: \\*anchor'\\) are not read"},
      {"scenes: []\n", ":1: key 'scenes': expected a non-empty list"},
      {"scenes: [{scene: no_such_scene, recordings: [tube_insert], reference: {}}]\n",
       ":1: key 'scenes\\[0\\].scene': no_such_scene: no such scene"},
      {"scenes: [{scene: tube, recordings: [no_such_recording], reference: {}}]\n",
       ":1: key 'scenes\\[0\\].recordings\\[0\\]': no_such_recording: no such recording"},
      // A file that is no recording: its own entry and line, not the window's `start`.
      {"scenes:\n  - scene: tube\n    recordings:\n      - tube_insert\n      - " + std::string(EBH_SOURCE_DIR) +
           "/scenarios/tube.yaml\n    reference: {}\nstart: 1\n",
       ":5: key 'scenes\\[0\\].recordings\\[1\\]': .*tube.yaml: "},
      {"scenes: [{scene: tube, recordings: [tube_insert]}]\n", ":1: key 'scenes\\[0\\].reference': missing \\(required\\)"},
      {"scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\ngrid:\n  solver.no_such: [1, 2]\n",
       ":4: key 'grid.solver.no_such': on scene tube: key 'solver.no_such': unknown key"},
      {"scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\ngrid:\n  solver.virtual_iterations: [2, many]\n",
       ":4: key 'grid.solver.virtual_iterations': on scene tube: .*key 'solver.virtual_iterations': expected a whole number"},
      {"scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\ngrid:\n  solver.virtual_iterations: 2\n",
       ":4: key 'grid.solver.virtual_iterations': expected a non-empty list of values"},
      {"scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {solver.method: fast}}\n",
       ":2: key 'scenes\\[0\\].reference.solver.method': on scene tube: .*expected one of"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nbackends: [cpu, gpu]\n",
       ":2: key 'backends': expected cpu or cuda, got 'gpu'"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nreference_backend: gpu\n",
       ":2: key 'reference_backend': expected cpu or cuda, got 'gpu'"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nrepetitions: 0\n",
       ":2: key 'repetitions': expected a whole number in \\[1, 1000\\], got '0'"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nstart: 99\n",
       ":2: key 'start': start 99: the recording .*tube_insert.h5 \\(scenes\\[0\\].recordings\\) is 10 s long; start "
       "before its end"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nduration: -1\n",
       ":2: key 'duration': expected a number > 0, got '-1'"},
      // a window under one haptic tick replays one tick, with no force step: refused before any run,
      // at the slowest rate the plan's runs take (a swept time.haptic_hz), or where the recording's
      // end cuts it under a tick
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nstart: 4\nduration: 1e-320\n",
       ":3: key 'duration': duration 1e-320: shorter than one haptic tick \\(0.001 s at 1000 Hz\\), which replays a "
       "single tick with no force step to measure: expected at least 0.001 s"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\ngrid: {time.haptic_hz: [1000, 100]}\n"
       "duration: 0.005\n",
       ":3: key 'duration': duration 0.005: shorter than one haptic tick \\(0.01 s at 100 Hz\\)"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nstart: 9.9995\n",
       ":2: key 'start': start 9.9995: leaves 0.0005 s of the recording .*tube_insert.h5 \\(scenes\\[0\\].recordings\\) "
       "\\(10 s long\\), less than one haptic tick"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nmode: realtime\n",
       ":2: key 'mode': expected async or lockstep"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\ngrid: {a: [1]}\nruns: [{}]\n",
       ":3: key 'runs': give `grid` or `runs`, not both"},
      {"scenes: [{scene: tube, recordings: [tube_insert, tube_insert], reference: {}}]\n",
       ":1: key 'scenes\\[0\\].recordings\\[1\\]': .*tube_insert.h5 given twice"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}\n", ":2: YAML syntax error"},
      {"scenes: " + std::string(100000, '['), ":[0-9]+: nested too deeply \\(over 500 levels of lists and maps"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nbaseline: {name: paper}\n",
       ":2: key 'baseline.set': missing \\(required"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nbaseline: {set: {}, label: x}\n",
       ":2: key 'baseline.label': unknown key"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nbaseline:\n  set: {tool.newton_calls: 9}\n",
       ":3: key 'baseline.set.tool.newton_calls': on scene tube: .*expected all or at most solver.virtual_iterations"},
      // a configuration's keys checked together: the key the scene refuses is named, at its line
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\n"
       "runs:\n  - {solver.virtual_iterations: 2,\n     tool.newton_calls: 3}\n",
       ":4: key 'runs.tool.newton_calls': on scene tube: key 'tool.newton_calls': expected all or at most "
       "solver.virtual_iterations \\(2\\)"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\n"
       "runs:\n  - {solver.virtual_iterations: 2}\n  - {time.haptic_hz: 999.9}\n",
       ":4: key 'runs.time.haptic_hz': on scene tube: key 'time.haptic_hz': haptic_hz / physical_hz must be a whole number"},
      // `set` alone refused: its key is named (a reference that sets nothing of it)
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {solver.virtual_iterations: 8}}]\n"
       "set:\n  time.physical_hz: 99.99\n",
       ":3: key 'set.time.physical_hz': on scene tube: key 'time.physical_hz': "},
      // keys that cannot go together across `set` and a run: before any replay, not as a failed run
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nset: {solver.physical_region: 0.0003}\n"
       "runs:\n  - {solver.method: direct}\n",
       ":4: key 'runs': on scene tube: .*key 'solver.physical_region': the direct method solves for every vertex"},
      // a `set` key every configuration overrides reaches no run (a grid's key, or one in every list
      // entry)
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nset: {solver.virtual_iterations: 3}\n"
       "grid:\n  solver.virtual_iterations: [2, 4]\n",
       ":2: key 'set.solver.virtual_iterations': every configuration of `grid` gives solver.virtual_iterations its "
       "own value, so this one reaches no run"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nset: {stiffness.k_vol: 3000}\n"
       "runs:\n  - {stiffness.k_vol: 2000}\n  - {stiffness.k_vol: 4000, solver.virtual_iterations: 2}\n",
       ":2: key 'set.stiffness.k_vol': every configuration of `runs` gives stiffness.k_vol its own value"},
      // a YAML tag, which nothing reads, on a plain setting, a list's value or a key
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nrepetitions: !foo 2\n",
       ":2: key 'repetitions': YAML tag '!foo': ebh reads no tags"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\ngrid:\n  stiffness.k_con: [400, !!int 800]\n",
       ":3: key 'grid.stiffness.k_con\\[1\\]': YAML tag '!!int': ebh reads no tags"},
      {"scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nset: {!foo gravity: [0, 0, 0]}\n",
       ":2: key 'set.gravity': YAML tag '!foo'"},
  };
  int i = 0;
  for (const auto& [text, expected] : cases) {
    const fs::path f = plan_file("bad" + std::to_string(i++) + ".yaml", text);
    try {
      (void)read_sweep_plan(f);
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(what.rfind(f.string(), 0), 0u) << what;
      EXPECT_TRUE(std::regex_search(what, std::regex(expected))) << what << "\n  expected: " << expected;
    }
  }
  EXPECT_THROW((void)read_sweep_plan(scratch() / "no_such_plan.yaml"), InputError);
}

// A run's overrides are checked together, as `ebh replay --set` takes them: a haptic rate of 999.9
// Hz is a whole multiple of a physical one of 99.99 Hz only with both, in a list entry, a baseline or
// `set` (each key was checked alone against the scene, and the pair refused).
TEST(SweepPlan, KeysValidOnlyTogetherAreTakenTogether) {
  const std::string head = "scenes: [{scene: tube, recordings: [tube_insert], reference: {}}]\nstart: 4\nduration: 0.5\n";
  const SweepPlan p = read_sweep_plan(plan_file("together.yaml", head +
                                                    "runs:\n  - {time.haptic_hz: 999.9, time.physical_hz: 99.99}\n"
                                                    "  - {solver.virtual_iterations: 2}\n"
                                                    "baseline: {set: {time.physical_hz: 99.99, time.haptic_hz: 999.9}}\n"));
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[1].set_arguments(), (std::vector<std::string>{"time.haptic_hz=999.9", "time.physical_hz=99.99"}));
  EXPECT_TRUE(runs[1].baseline);
  const SweepPlan q = read_sweep_plan(plan_file("together_set.yaml", head +
                                                    "set: {time.haptic_hz: 999.9, time.physical_hz: 99.99}\n"
                                                    "grid: {solver.virtual_iterations: [2, 4]}\n"));
  EXPECT_EQ(expand_plan(q).size(), 3u);
}

// A copy of a scene (its file and meshes the same bytes) or of a recording is the same input: its
// runs are the same replays, which the plan keeps once, so its rows (and its own reference's
// errors) would be lost without a word. Refused, naming both.
TEST(SweepPlan, CopiesOfAnInputAreRefused) {
  const fs::path dir = scratch() / "copies";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path src(EBH_SOURCE_DIR);
  fs::copy_file(src / "scenarios" / "tube.yaml", dir / "other.yaml");
  fs::copy_file(src / "scenarios" / "tube.msh", dir / "tube.msh");
  fs::copy_file(src / "recordings" / "tube_insert.h5", dir / "insert_copy.h5");
  auto refused = [&](const std::string& name, const std::string& text, const std::string& expected) {
    const fs::path f = plan_file(name, text);
    try {
      (void)read_sweep_plan(f);
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      EXPECT_TRUE(std::regex_search(e.what(), std::regex(expected))) << e.what() << "\n  expected: " << expected;
    }
  };
  refused("copy_scene.yaml",
          "scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\n"
          "  - {scene: " + (dir / "other.yaml").string() + ", recordings: [tube_insert], reference: {stiffness.k_con: 300}}\n"
          "runs: [{stiffness.k_con: 500}]\n",
          ":3: key 'scenes\\[1\\].scene': .*other.yaml and its meshes have the same bytes as .*scenarios/tube.yaml: the "
          "same scene; list it once");
  refused("copy_recording.yaml",
          "scenes:\n  - {scene: tube, recordings: [tube_insert, " + (dir / "insert_copy.h5").string() + "], reference: {}}\n",
          ":2: key 'scenes\\[0\\].recordings\\[1\\]': .*insert_copy.h5 has the same bytes as .*tube_insert.h5: the same "
          "recording; list it once");
  // one byte more: another scene
  std::ofstream(dir / "other.yaml", std::ios::app) << "# changed\n";
  EXPECT_EQ(expand_plan(read_sweep_plan(plan_file("changed_scene.yaml",
                                                  "scenes:\n  - {scene: tube, recordings: [tube_insert], reference: {}}\n"
                                                  "  - {scene: " + (dir / "other.yaml").string() +
                                                      ", recordings: [tube_insert], reference: {stiffness.k_con: 300}}\n"
                                                      "runs: [{stiffness.k_con: 500}]\n")))
                .size(),
            4u);
}

TEST(SweepPlan, CommittedExamplesLoad) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(EBH_SOURCE_DIR) / "examples" / "sweeps"))
    if (e.path().extension() == ".yaml") {
      EXPECT_NO_THROW((void)expand_plan(read_sweep_plan(e.path()))) << e.path();
      ++n;
    }
  EXPECT_GE(n, 2);
}

TEST(SweepSlice, EveryRunInExactlyOneTask) {
  const std::vector<SweepRun> runs = expand_plan(read_sweep_plan(plan_file("slice.yaml", kPlan)));
  std::map<std::string, int> seen;
  for (int t = 0; t < 4; ++t)
    for (const SweepRun& r : task_slice(runs, t, 4)) ++seen[r.id];
  EXPECT_EQ(seen.size(), runs.size());
  for (const auto& [id, n] : seen) EXPECT_EQ(n, 1) << id;
}

ReplayTrace trace(const std::vector<double>& t, const std::vector<Vec3d>& f) {
  ReplayTrace tr;
  tr.t = t;
  tr.force = f;
  return tr;
}

/// A plan of tube_insert's direct reference (on `reference_backend`) and 4 CUDA runs of 0.1 s.
SweepPlan four_cuda_runs(const std::string& name, const std::string& reference_backend) {
  return read_sweep_plan(plan_file(name, R"(scenes:
  - scene: tube
    recordings: [tube_insert]
    reference: {solver.method: direct}
grid:
  stiffness.k_con: [400, 500, 600, 700]
backends: [cuda]
reference_backend: )" + reference_backend + R"(
duration: 0.1
)"));
}

/// CUDA runs go RunnerOptions::batch to one `ebh replay --batch` child (here a stand-in script,
/// tests/sweep/fake_replay.sh, that fails its file's second line): every run gets its own outcome,
/// the failed one its FILE:LINE error, the batch file holds each run's own arguments and is gone
/// once the child ends; CPU runs still go one per child; a second sweep runs only the failed run.
// The runs' warnings, which their logs hold, said once a kind: the same line but for its numbers
// and the run's output is one kind, counted; the runs' other lines are not warnings.
TEST(SweepRunner, WarningsOfTheRunsAreCountedByKind) {
  std::vector<WarningKind> kinds;
  add_warning_kinds("d/runs/a.h5: tube + tube_insert.h5\n"
                    "ebh: warning: d/runs/a.h5: up to 26 of the physical mesh's 43958 tets were inverted at t = 1.140 s\n"
                    "ebh: warning: rec.h5: --start 1.5: the replay starts with the tool's tip inside\n",
                    {"d/runs/a.h5"}, "d/runs/a.log", kinds);
  add_warning_kinds("ebh: warning: d/runs/b.h5: up to 3 of the physical mesh's 43958 tets were inverted at t = 2.5 s\n"
                    "ebh: warning: rec.h5: --start 1.5: the replay starts with the tool's tip inside\n"
                    "ebh: warning: d/runs/b.h5: the tool never touched the tissue\n",
                    {"d/runs/b.h5"}, "d/runs/b.log", kinds);
  ASSERT_EQ(kinds.size(), 3u);
  EXPECT_EQ(kinds[0].count, 2u);
  EXPECT_EQ(kinds[0].example, "d/runs/a.h5: up to 26 of the physical mesh's 43958 tets were inverted at t = 1.140 s");
  EXPECT_EQ(kinds[0].log, "d/runs/a.log");
  EXPECT_EQ(kinds[0].kind, "RUN: up to # of the physical mesh's # tets were inverted at t = # s");
  EXPECT_EQ(kinds[1].count, 2u);
  EXPECT_EQ(kinds[2].count, 1u);
  EXPECT_EQ(kinds[2].log, "d/runs/b.log");
}

TEST(SweepRunner, CudaRunsGoToBatchChildren) {
  const fs::path dir = scratch() / "batched";
  fs::remove_all(dir);
  const SweepPlan plan = four_cuda_runs("batched.yaml", "cuda");
  const std::vector<SweepRun> runs = expand_plan(plan);
  ASSERT_EQ(runs.size(), 5u);  // the reference and 4 configurations
  RunnerOptions opt;
  opt.executable = test_replay("fake_replay.sh");
  opt.batch = 3;
  std::vector<std::size_t> started_with;
  const RunnerReport rep = execute_runs(plan, runs, dir, opt, [&](const RunnerProgress& p, const RunOutcome* o) {
    if (!o) started_with.push_back(p.running);
  });
  EXPECT_EQ(started_with, (std::vector<std::size_t>{3, 2})) << "two children: 3 runs, then 2";
  EXPECT_EQ(rep.ran, 3u);
  EXPECT_EQ(rep.failed, 2u);  // the second line of each child
  ASSERT_EQ(rep.failures.size(), 2u);
  EXPECT_EQ(rep.failures[0].error, "the second replay fails");
  EXPECT_EQ(rep.failures[0].run, &runs[1]);
  EXPECT_EQ(rep.failures[1].run, &runs[4]);
  for (std::size_t i : {0u, 2u, 3u}) {
    std::ifstream in(run_output(dir, runs[i]));
    std::string line;
    std::getline(in, line);  // what the stand-in was given: the run's own arguments
    EXPECT_NE(line.find("--backend cuda --mode async --quiet"), std::string::npos) << line;
    EXPECT_NE(line.find(" --set "), std::string::npos) << line;
    EXPECT_NE(line.find("-o " + run_output(dir, runs[i]).string()), std::string::npos) << line;
  }
  EXPECT_EQ(read_run_failure(dir, runs[1]), "the second replay fails");
  EXPECT_TRUE(fs::is_empty(dir / "batches")) << "the batch files are removed";
  // Again: the three done are skipped, the two failed run (again as one child of 2).
  const RunnerReport again = execute_runs(plan, runs, dir, opt);
  EXPECT_EQ(again.skipped, 3u);
  EXPECT_EQ(again.failed, 1u);
  EXPECT_EQ(again.ran, 1u);
  // batch = 1: a child per run, with `ebh replay`'s own arguments.
  fs::remove_all(dir);
  opt.batch = 1;
  const RunnerReport single = execute_runs(plan, runs, dir, opt);
  EXPECT_EQ(single.ran, 5u);
  std::ifstream in(run_output(dir, runs[1]));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "alone");
}

/// --gpus: device i as this process sees it is the i-th entry of its own CUDA_VISIBLE_DEVICES
/// (what a Slurm allocation sets), or i; an index past the devices, or one listed twice, is refused.
TEST(SweepRunner, GpuEntriesNameTheDevicesThisProcessSees) {
  EXPECT_EQ(gpu_entries({0, 1}, 2, nullptr), (std::vector<std::string>{"0", "1"}));
  EXPECT_EQ(gpu_entries({1, 0}, 2, "2,3"), (std::vector<std::string>{"3", "2"}));
  EXPECT_EQ(gpu_entries({0}, 1, "GPU-5c2a"), (std::vector<std::string>{"GPU-5c2a"}));
  EXPECT_INPUT_ERROR(gpu_entries({2}, 2, nullptr), "--gpus 2: this process sees 2 CUDA devices, numbered 0-1");
  EXPECT_INPUT_ERROR(gpu_entries({1}, 1, "4"), "--gpus 1: this process sees 1 CUDA device, numbered 0-0 (CUDA_VISIBLE_DEVICES=4)");
  EXPECT_INPUT_ERROR(gpu_entries({0}, 0, nullptr), "--gpus 0: this process sees no CUDA device");
  EXPECT_INPUT_ERROR(gpu_entries({0, 1, 0}, 3, nullptr), "--gpus: device 0 is listed twice");
}

/// RunnerOptions::gpus: each CUDA child runs with CUDA_VISIBLE_DEVICES set to one entry, the one
/// with the fewest CUDA children running, so `jobs` children spread over the GPUs; CPU children
/// keep this process's devices (the stand-in replay writes what it was given into a log).
TEST(SweepRunner, CudaChildrenSpreadOverTheGpus) {
  const fs::path dir = scratch() / "gpus";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const SweepPlan plan = four_cuda_runs("gpus.yaml", "cpu");
  const std::vector<SweepRun> runs = expand_plan(plan);  // the CPU reference and 4 CUDA runs
  const fs::path log = dir / "devices.log";
  setenv("EBH_FAKE_DEVICE_LOG", log.c_str(), 1);
  setenv("CUDA_VISIBLE_DEVICES", "9", 1);  // what the CPU children inherit
  RunnerOptions opt;
  opt.executable = test_replay("fake_replay.sh");
  opt.jobs = 3;  // the first three children start together: two or more CUDA ones, on both GPUs
  opt.gpus = {"3", "GPU-7"};
  const RunnerReport rep = execute_runs(plan, runs, dir / "out", opt);
  unsetenv("EBH_FAKE_DEVICE_LOG");
  unsetenv("CUDA_VISIBLE_DEVICES");
  EXPECT_EQ(rep.ran, runs.size());
  std::map<std::string, int> seen;  // "cpu 9", "cuda 3", ...
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);) ++seen[line];
  int cpu = 0, cuda = 0;
  for (const SweepRun& r : runs) (r.backend == "cuda" ? cuda : cpu) += 1;
  ASSERT_EQ(cpu, 1);
  EXPECT_EQ(seen["cpu 9"], cpu) << "CPU children keep this process's CUDA_VISIBLE_DEVICES";
  EXPECT_EQ(seen["cuda 3"] + seen["cuda GPU-7"], cuda) << "every CUDA child on one of the GPUs";
  EXPECT_GE(seen["cuda 3"], 1);
  EXPECT_GE(seen["cuda GPU-7"], 1);
  EXPECT_EQ(seen.size(), 3u);
}

/// A fresh folder `name` in the scratch space holding a copy of the tube scene (scene/tube.yaml
/// and its mesh), for tests that edit a run's input files.
fs::path fresh_tube_scene(const std::string& name) {
  const fs::path d = scratch() / name;
  fs::remove_all(d);
  fs::create_directories(d / "scene");
  const fs::path scenarios = fs::path(EBH_SOURCE_DIR) / "scenarios";
  fs::copy_file(scenarios / "tube.yaml", d / "scene" / "tube.yaml");
  fs::copy_file(scenarios / "tube.msh", d / "scene" / "tube.msh");
  return d;
}

/// A plan on the tube scene copied to `d` (fresh_tube_scene), in d's name beside the other plans:
/// tube_insert with its reference, the runs `runs` (a YAML flow list) and the keys `more`, from
/// 4 s for 0.5 s (write_tube_output's window).
SweepPlan tube_plan(const fs::path& d, const std::string& runs, const std::string& more = "") {
  return read_sweep_plan(plan_file(d.filename().string() + ".yaml",
                                   "scenes:\n  - {scene: " + (d / "scene" / "tube.yaml").string() +
                                       ", recordings: [tube_insert], reference: {}}\nruns: " + runs + "\n" + more +
                                       "start: 4\nduration: 0.5\n"));
}

/// A run is done while its output was made from the run's input files as they are: the output
/// records each one's SHA-256 (the scene file, its mesh, the recording: write_provenance), and a
/// file edited or replaced since makes the run stale, so the sweep runs it again. An output of
/// another window, mode, backend or overrides (a replay by hand or a copy under the run's name),
/// or an HDF5 file that is no replay, runs again; one cut short too.
TEST(SweepRunner, AnOutputMadeFromOtherInputFilesIsStale) {
  const fs::path d = fresh_tube_scene("stale");
  const SweepPlan p = read_sweep_plan(plan_file("stale.yaml", "scenes:\n  - {scene: " + (d / "scene" / "tube.yaml").string() +
                                                                  ", recordings: [tube_insert], reference: {}}\nstart: 4\nduration: 0.5\n"));
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 1u);
  const SweepRun& r = runs[0];
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  InputDigests digests;
  EXPECT_EQ(run_state(dir, p, r, digests), RunState::Missing);
  // What the files were when the run ran, as the replay's output records them.
  struct Window {
    std::string mode = "async", backend = "cpu", overrides;
    double start = 4, duration = 0.5;
  };
  auto write_output = [&](const std::string& scene_sha, const Window& w = {}) {
    h5::File f = h5::File::create(run_output(dir, r).string());
    f.set_attr("scene_file_sha256", scene_sha);
    f.set_attr("physical_mesh_sha256", sha256_file((d / "scene" / "tube.msh").string()));
    f.set_attr("recording_sha256", sha256_file(r.recording.string()));
    f.set_attr("mode", w.mode);
    f.set_attr("backend", w.backend);
    f.set_attr("overrides_list", w.overrides);
    f.set_attr("start", w.start);
    f.set_attr("duration", w.duration);
    f.set_attr("haptic_hz", 1000.0);  // scenarios/tube.yaml's time.haptic_hz, time.physical_hz
    f.set_attr("physical_hz", 100.0);
  };
  const std::string scene_sha = sha256_file((d / "scene" / "tube.yaml").string());
  write_output(scene_sha);
  EXPECT_EQ(run_state(dir, p, r, digests), RunState::Done);
  // The scene file edited since (a stiffness changed): stale, in a new sweep.
  std::ofstream(d / "scene" / "tube.yaml", std::ios::app) << "# edited\n";
  InputDigests later;
  EXPECT_EQ(run_state(dir, p, r, later), RunState::Stale);
  // An output recording the edited file is done again; one made from another mesh is stale.
  write_output(sha256_file((d / "scene" / "tube.yaml").string()));
  EXPECT_EQ(run_state(dir, p, r, later), RunState::Done);
  std::ofstream(d / "scene" / "tube.msh", std::ios::app) << "\n";
  InputDigests mesh_changed;
  EXPECT_EQ(run_state(dir, p, r, mesh_changed), RunState::Stale);
  // A replay of another window, mode, backend or overrides under the run's name (replayed by
  // hand into runs/, or another run's output copied): its numbers are not the run's; run again.
  const std::string scene_now = sha256_file((d / "scene" / "tube.yaml").string());
  write_output(scene_now);
  InputDigests now;
  EXPECT_EQ(run_state(dir, p, r, now), RunState::Done);
  std::vector<Window> others(6);
  others[0].start = 0;
  others[1].duration = 0.05;
  others[2].duration = 0;
  others[3].mode = "lockstep";
  others[4].backend = "cuda";
  others[5].overrides = "solver.virtual_iterations=2";
  for (const Window& w : others) {
    write_output(scene_now, w);
    EXPECT_EQ(run_state(dir, p, r, now), RunState::Other) << w.mode << " " << w.backend << " " << w.start << " "
                                                          << w.duration << " " << w.overrides;
  }
  // A window past the recording's end: the replay records the part it played (tube_insert: 10 s).
  const SweepPlan past = read_sweep_plan(plan_file("past.yaml", "scenes:\n  - {scene: " + (d / "scene" / "tube.yaml").string() +
                                                                 ", recordings: [tube_insert], reference: {}}\nstart: 9.8\nduration: 0.5\n"));
  const SweepRun pr = expand_plan(past).at(0);
  {
    h5::File f = h5::File::create(run_output(dir, pr).string());
    f.set_attr("mode", "async");
    f.set_attr("backend", "cpu");
    f.set_attr("overrides_list", "");
    f.set_attr("start", 9.8);
    f.set_attr("duration", 10.0 - 9.8);
    f.set_attr("haptic_hz", 1000.0);
    f.set_attr("physical_hz", 100.0);
  }
  EXPECT_EQ(run_state(dir, past, pr, now), RunState::Done);
  // An HDF5 file that is no replay (an h5py slip emptied it; another program's): run again.
  fs::remove(run_output(dir, r));
  { h5::File::create(run_output(dir, r).string()); }
  EXPECT_EQ(run_state(dir, p, r, mesh_changed), RunState::Other);
  // Another program's file of another kind: done, as before.
  std::ofstream(run_output(dir, r)) << "not HDF5\n";
  EXPECT_EQ(run_state(dir, p, r, mesh_changed), RunState::Done);
  // An output cut short (a copy, a full disk), or empty: its replay runs again, rather than the
  // run failing in every summary from then on.
  write_output(scene_sha);
  fs::resize_file(run_output(dir, r), fs::file_size(run_output(dir, r)) / 2);
  EXPECT_EQ(run_state(dir, p, r, mesh_changed), RunState::Unreadable);
  fs::resize_file(run_output(dir, r), 0);
  EXPECT_EQ(run_state(dir, p, r, mesh_changed), RunState::Unreadable);
}

/// A sweep replays with no pose transform and at the rates of the run's scene under its overrides
/// (it gives `ebh replay` no --transform, --tool-transform, --haptic-hz or --physical-hz): a replay
/// of the run's window, mode, backend and overrides made by hand with one of those, copied under
/// the run's name, is not the run's (its forces differ: another pose, another rate) and runs again.
TEST(SweepRunner, AReplayWithATransformOrOtherRatesIsNotTheRuns) {
  const fs::path d = fresh_tube_scene("transform_rates");
  const SweepPlan p = tube_plan(d, "[{time.haptic_hz: 2000}]");
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 2u);
  const SweepRun& ref = runs[0];  // the scene's rates: 1000 Hz, 100 Hz (scenarios/tube.yaml)
  const SweepRun& fast = runs[1];  // time.haptic_hz=2000
  ASSERT_TRUE(ref.set_arguments().empty());
  ASSERT_EQ(fast.set_arguments(), std::vector<std::string>{"time.haptic_hz=2000"});
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  struct Made {  // what `ebh replay` records of the options it was given
    std::string transform, tool_transform;
    std::optional<double> haptic_hz = 1000, physical_hz = 100;  // none: an output without the attribute
    bool transform_attributes = true;  // false: an output older than the transform options
  };
  auto write_output = [&](const SweepRun& as, const Made& m) {
    h5::File f = h5::File::create(run_output(dir, as).string());
    f.set_attr("mode", "async");
    f.set_attr("backend", "cpu");
    f.set_attr("overrides_list", as.set_arguments().empty() ? std::string() : as.set_arguments()[0]);
    f.set_attr("start", 4.0);
    f.set_attr("duration", 0.5);
    if (m.transform_attributes) {
      f.set_attr("transform_option", m.transform);
      f.set_attr("tool_transform_option", m.tool_transform);
    }
    if (m.haptic_hz) f.set_attr("haptic_hz", *m.haptic_hz);
    if (m.physical_hz) f.set_attr("physical_hz", *m.physical_hz);
  };
  InputDigests digests(&p);
  write_output(ref, {});
  EXPECT_EQ(run_state(dir, p, ref, digests), RunState::Done);
  // A replay older than --transform (no transform_option attributes) could not be given one.
  Made older;
  older.transform_attributes = false;
  write_output(ref, older);
  EXPECT_EQ(run_state(dir, p, ref, digests), RunState::Done);
  std::vector<Made> others(6);
  others[0].transform = "0,0,5,0,0,0";
  others[1].tool_transform = "0,0,0,180,0,0";
  others[2].haptic_hz = 2000;
  others[3].physical_hz = 50;
  others[4].haptic_hz.reset();  // every replay output holds its rates: this is none
  others[5].physical_hz.reset();
  for (const Made& m : others) {
    write_output(ref, m);
    EXPECT_EQ(run_state(dir, p, ref, digests), RunState::Other)
        << m.transform << " " << m.tool_transform << " " << m.haptic_hz.value_or(-1) << " " << m.physical_hz.value_or(-1);
  }
  // The rates a run's overrides give are its own: 2000 Hz is the run's, the scene's 1000 Hz is not.
  Made at_2k;
  at_2k.haptic_hz = 2000;
  write_output(fast, at_2k);
  EXPECT_EQ(run_state(dir, p, fast, digests), RunState::Done);
  write_output(fast, {});
  EXPECT_EQ(run_state(dir, p, fast, digests), RunState::Other);
  EXPECT_NE(std::string(redo_reason(RunState::Other)).find("pose transform or rate"), std::string::npos);
}

// The summary takes a run's output only where the sweep would (run_state): another run's output
// copied under its name, one made from input files edited since, or edited while the sweep ran
// (against the digests the plan read), is no result but a run to do again, saying why.
TEST(SweepSummary, OutputsTheSweepWouldRunAgainAreNotOk) {
  const fs::path d = fresh_tube_scene("summary_redo");
  const SweepPlan p = tube_plan(d, "[{solver.virtual_iterations: 2}]");
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 2u);
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  auto write_output = [&](const SweepRun& as, const std::string& scene_sha, const std::string& overrides) {
    h5::File f = h5::File::create(run_output(dir, as).string());
    f.set_attr("scene_file_sha256", scene_sha);
    f.set_attr("physical_mesh_sha256", sha256_file((d / "scene" / "tube.msh").string()));
    f.set_attr("recording_sha256", sha256_file(as.recording.string()));
    f.set_attr("mode", "async");
    f.set_attr("backend", "cpu");
    f.set_attr("overrides_list", overrides);
    f.set_attr("start", 4.0);
    f.set_attr("duration", 0.5);
    f.set_attr("haptic_hz", 1000.0);  // scenarios/tube.yaml's rates
    f.set_attr("physical_hz", 100.0);
  };
  const std::string scene_sha = sha256_file((d / "scene" / "tube.yaml").string());
  // The reference's output copied over the other run's.
  write_output(runs[1], scene_sha, "");
  SweepSummary s = summarize_sweep(p, runs, dir);
  const std::size_t c_error = s.table.column("error", "summary");
  EXPECT_EQ(s.table.rows[1][1], "pending");
  EXPECT_NE(s.table.rows[1][c_error].find("not the run's replay"), std::string::npos) << s.table.rows[1][c_error];
  EXPECT_EQ(s.redo, 1u);
  // The report says why beside the count.
  const std::string md = report_markdown(build_report(s.table, "summary.csv"));
  EXPECT_NE(md.find("not run yet: " + runs[1].id + " solver.virtual_iterations=2: to run again: a run whose output is not "
                    "the run's replay"), std::string::npos) << md;
  // Its own, made from another scene file than the one the plan read.
  write_output(runs[1], std::string(64, '0'), "solver.virtual_iterations=2");
  s = summarize_sweep(p, runs, dir);
  EXPECT_EQ(s.table.rows[1][1], "pending");
  EXPECT_NE(s.table.rows[1][c_error].find("edited or replaced since"), std::string::npos) << s.table.rows[1][c_error];
  // The scene file edited while the sweep ran: the replay records the edited file; the plan read the old one.
  std::ofstream(d / "scene" / "tube.yaml", std::ios::app) << "# edited\n";
  write_output(runs[1], sha256_file((d / "scene" / "tube.yaml").string()), "solver.virtual_iterations=2");
  s = summarize_sweep(p, runs, dir);
  EXPECT_EQ(s.table.rows[1][1], "pending");
  EXPECT_EQ(s.ok, 0u);
}

/// A replay output of 0.5 s at 1 kHz as `ebh replay` lays it out, for run `as` of a plan on the
/// tube scene copied to `d` (fresh_tube_scene) with start 4 and duration 0.5: its force 0.1 N along
/// x but `force_at_50` at tick 50, its times i / 1000 s but `t_at_7` at tick 7.
void write_tube_output(const fs::path& d, const fs::path& dir, const SweepRun& as, double force_at_50, double t_at_7 = 0.007) {
  h5::File f = h5::File::create(run_output(dir, as).string());
  f.set_attr("scene_file_sha256", sha256_file((d / "scene" / "tube.yaml").string()));
  f.set_attr("physical_mesh_sha256", sha256_file((d / "scene" / "tube.msh").string()));
  f.set_attr("recording_sha256", sha256_file(as.recording.string()));
  f.set_attr("mode", "async");
  f.set_attr("backend", "cpu");
  f.set_attr("overrides_list", as.set_arguments().empty() ? std::string() : as.set_arguments()[0]);
  f.set_attr("start", 4.0);
  f.set_attr("duration", 0.5);
  f.set_attr("haptic_hz", 1000.0);  // scenarios/tube.yaml's rates
  f.set_attr("physical_hz", 100.0);
  f.set_attr("wall_s", 0.25);
  f.set_attr("virtual_s", 0.5);
  const std::size_t n = 501;
  std::vector<double> t(n), force(3 * n, 0.0), pose(7 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = i == 7 ? t_at_7 : static_cast<double>(i) / 1000.0;
    force[3 * i] = i == 50 ? force_at_50 : 0.1;
    pose[7 * i + 3] = 1;  // the identity rotation
  }
  f.write<double>("/haptic/t", t, {n});
  f.write<double>("/haptic/force", force, {n, 3});
  f.write<double>("/haptic/torque", std::vector<double>(3 * n, 0.0), {n, 3});
  f.write<std::uint8_t>("/haptic/force_clamped", std::vector<std::uint8_t>(n, 0), {n});
  f.write<double>("/haptic/pose_physical", pose, {n, 7});
  f.write<double>("/haptic/pose_virtual", pose, {n, 7});
  f.write<double>("/haptic/penetration", std::vector<double>(n, 0.0), {n});
  f.write<std::int32_t>("/haptic/contacts", std::vector<std::int32_t>(n, 3), {n});
  f.write<double>("/timing/haptic_step_s", std::vector<double>(n, 1e-4), {n});
}

// The summary never holds what its own report refuses: a run whose output holds an inf force
// sample is failed, naming the dataset (as a NaN one is: SweepSummary.ANonFiniteSampleFailsTheRun);
// one with a finite force no replay writes (1e300 N, whose square was inf) is failed by the loader,
// naming the dataset and index. The report then reads the summary; before, it held "ok,...,inf"
// and the report refused its own summary.
TEST(SweepSummary, ARunWhoseMeasuresTheReportRefusesIsFailed) {
  const fs::path d = fresh_tube_scene("summary_refused");
  const SweepPlan p = tube_plan(d, "[{solver.virtual_iterations: 2}, {solver.virtual_iterations: 4}]");
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 3u);
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  auto write_output = [&](const SweepRun& as, double force_at_50) { write_tube_output(d, dir, as, force_at_50); };
  write_output(runs[0], 0.1);
  write_output(runs[1], INFINITY);
  write_output(runs[2], 1e300);
  const SweepSummary s = summarize_sweep(p, runs, dir);
  const std::size_t c_error = s.table.column("error", "summary");
  EXPECT_EQ(s.table.rows[0][1], "ok");
  EXPECT_EQ(s.table.rows[1][1], "failed");
  EXPECT_EQ(s.table.rows[1][c_error], run_output(dir, runs[1]).string() +
                                          ": non-finite samples (/haptic/force: 1): the run's numbers went wrong; no "
                                          "force error or metric is taken from it");
  EXPECT_EQ(s.table.rows[2][1], "failed");
  EXPECT_NE(s.table.rows[2][c_error].find("dataset '/haptic/force' holds 1e+300 N at index 50 (column 0), beyond 1e+30"),
            std::string::npos)
      << s.table.rows[2][c_error];
  EXPECT_EQ(s.ok, 1u);
  EXPECT_EQ(s.failed, 2u);
  // What it wrote, the report reads: both runs listed as failed.
  const std::string md = report_markdown(build_report(s.table, "summary.csv"));
  EXPECT_NE(md.find("failed: " + runs[1].id), std::string::npos) << md;
  // The rule the two share: an ok row's measures empty or finite >= 0, its wall time finite > 0.
  EXPECT_EQ(report_cell_problem("force_error_rms_N", ""), "");
  EXPECT_EQ(report_cell_problem("force_error_rms_N", "-inf"), "a finite number >= 0 or nothing");
  EXPECT_EQ(report_cell_problem("wall_s", ""), "a finite number > 0 (the run's wall time)");
  EXPECT_EQ(report_cell_problem("whole.peak_force_N", "inf"), "");  // no measure of the report's
}

// A summary written before a run's output was deleted (or cut short) still says ok, and no file is
// newer than it: outdated_ok_rows finds such rows by run_state, so the report collects again
// rather than count them (tests/sweep/report_outdated.sh runs it end to end). Rows not ok, or of
// no run of the plan, and a summary without ids give none.
TEST(SweepSummary, OkRowsWhoseOutputIsGoneAreOutdated) {
  const fs::path d = fresh_tube_scene("summary_outdated");
  const SweepPlan p = tube_plan(d, "[{solver.virtual_iterations: 2}]");
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 2u);
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  for (const SweepRun& r : runs) write_tube_output(d, dir, r, 0.1);
  const SweepSummary s = summarize_sweep(p, runs, dir);
  ASSERT_EQ(s.ok, 2u);
  EXPECT_TRUE(outdated_ok_rows(p, runs, s.table, dir).empty());
  // The run's output deleted: its row, the run and why.
  fs::remove(run_output(dir, runs[1]));
  std::vector<OutdatedRow> o = outdated_ok_rows(p, runs, s.table, dir);
  ASSERT_EQ(o.size(), 1u);
  EXPECT_EQ(o[0].row, 1u);
  EXPECT_EQ(o[0].run, &runs[1]);
  EXPECT_EQ(o[0].why, "to run again: its output " + run_output(dir, runs[1]).string() +
                          " is not there (deleted since the summary was written)");
  // The reference's cut short: run again too, as the summary would say.
  fs::resize_file(run_output(dir, runs[0]), fs::file_size(run_output(dir, runs[0])) / 2);
  o = outdated_ok_rows(p, runs, s.table, dir);
  ASSERT_EQ(o.size(), 2u);
  EXPECT_EQ(o[0].row, 0u);
  EXPECT_EQ(o[0].why, "to run again: a run whose output does not open");
  // Collected again, the summary agrees with the folder: nothing outdated.
  const SweepSummary again = summarize_sweep(p, runs, dir);
  EXPECT_EQ(again.ok, 0u);
  EXPECT_TRUE(outdated_ok_rows(p, runs, again.table, dir).empty());
  // Rows of no run of the plan, or without ids (an older ebh): taken as they are.
  CsvTable other = s.table;
  for (auto& row : other.rows) row[other.column("id", "summary")] += "0";
  EXPECT_TRUE(outdated_ok_rows(p, runs, other, dir).empty());
  CsvTable no_ids = s.table;
  no_ids.header[no_ids.column("id", "summary")] = "name";
  EXPECT_TRUE(outdated_ok_rows(p, runs, no_ids, dir).empty());
}

// One rule for non-finite samples: a NaN in a run's force fails the run as an inf does (it made an
// ok run with empty force errors and an empty error column), and a NaN time too (it gave a force
// error 6x the true one, ok). A reference with one fails, and the runs compared with it are ok with
// empty errors, their error column saying why; the report says why its baseline gives no
// comparison and the 2x-goal section lists the pair as not compared (both were left out silently).
TEST(SweepSummary, ANonFiniteSampleFailsTheRun) {
  const fs::path d = fresh_tube_scene("summary_nonfinite");
  const SweepPlan p = tube_plan(d, "[{solver.virtual_iterations: 2}, {solver.virtual_iterations: 4}]",
                                "baseline: {name: paper, set: {solver.virtual_iterations: 2}}\n");
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_EQ(runs.size(), 3u);
  ASSERT_TRUE(runs[0].reference && runs[1].baseline);
  const fs::path dir = d / "out";
  fs::create_directories(dir / "runs");
  const double nan = std::nan("");
  write_tube_output(d, dir, runs[0], 0.1);
  write_tube_output(d, dir, runs[1], nan);
  write_tube_output(d, dir, runs[2], INFINITY);
  SweepSummary s = summarize_sweep(p, runs, dir);
  const std::size_t c_error = s.table.column("error", "summary"), c_rms = s.table.column("force_error_rms_N", "summary");
  for (std::size_t i : {1u, 2u}) {
    EXPECT_EQ(s.table.rows[i][1], "failed") << i;
    EXPECT_EQ(s.table.rows[i][c_error], run_output(dir, runs[i]).string() +
                                            ": non-finite samples (/haptic/force: 1): the run's numbers went wrong; no "
                                            "force error or metric is taken from it");
  }
  std::string md = report_markdown(build_report(s.table, "summary.csv"));
  EXPECT_NE(md.find("Against the baseline paper: no comparison: none of its runs is ok (1 failed, 0 not run yet).\n"),
            std::string::npos) << md;
  EXPECT_NE(md.find("## The 2x goal\n\n- cpu: met on 0 of 0 scene and recording pairs; not compared on tube_insert, "
                    "whose baseline gives no comparison (see its section)\n"),
            std::string::npos) << md;

  // A NaN time: failed, naming /haptic/t (the loader refuses it, or the non-finite rule does).
  write_tube_output(d, dir, runs[1], 0.1, nan);
  write_tube_output(d, dir, runs[2], 0.1);
  s = summarize_sweep(p, runs, dir);
  EXPECT_EQ(s.table.rows[1][1], "failed");
  EXPECT_NE(s.table.rows[1][c_error].find("/haptic/t"), std::string::npos) << s.table.rows[1][c_error];
  EXPECT_EQ(s.table.rows[1][c_rms], "");
  EXPECT_EQ(s.table.rows[2][1], "ok");
  EXPECT_EQ(s.table.rows[2][c_rms], "0");

  // A NaN in the reference: it fails; the others are ok without force errors, saying why.
  write_tube_output(d, dir, runs[0], nan);
  write_tube_output(d, dir, runs[1], 0.1);
  s = summarize_sweep(p, runs, dir);
  EXPECT_EQ(s.table.rows[0][1], "failed");
  EXPECT_EQ(s.ok, 2u);
  const std::string why = "no reference: its run " + runs[0].id + " failed: " + run_output(dir, runs[0]).string() +
                          ": non-finite samples (/haptic/force: 1)";
  for (std::size_t i : {1u, 2u}) {
    EXPECT_EQ(s.table.rows[i][1], "ok") << i;
    EXPECT_EQ(s.table.rows[i][c_rms], "") << i;
    EXPECT_EQ(s.table.rows[i][c_error].rfind(why, 0), 0u) << s.table.rows[i][c_error];
  }
  md = report_markdown(build_report(s.table, "summary.csv"));
  EXPECT_NE(md.find("Against the baseline paper: no comparison: its runs have no force error: " + why), std::string::npos) << md;
  EXPECT_NE(md.find("not compared on tube_insert"), std::string::npos) << md;
}

// A folder made before the ids came from the files' contents holds its outputs under the runs'
// legacy ids (the files' paths): a sweep takes each over (output, log) for the run that has none
// under its id, and leaves a legacy file alone where the run already has its own.
TEST(SweepRunner, OutputsNamedAfterThePathsAreTakenOver) {
  const fs::path dir = scratch() / "legacy";
  fs::remove_all(dir);
  fs::create_directories(dir / "runs");
  const SweepPlan p = read_sweep_plan(plan_file("legacy.yaml", kPlan));
  const std::vector<SweepRun> runs = expand_plan(p);
  ASSERT_GE(runs.size(), 3u);
  EXPECT_EQ(adopt_legacy_outputs(dir, runs), 0u);
  auto legacy = [&](const SweepRun& r, const char* ext) { return dir / "runs" / (r.legacy_id + ext); };
  std::ofstream(legacy(runs[0], ".h5")) << "reference\n";
  std::ofstream(legacy(runs[0], ".log")) << "warning\n";
  std::ofstream(legacy(runs[1], ".h5")) << "legacy\n";
  std::ofstream(run_output(dir, runs[1])) << "own\n";
  std::ofstream(legacy(runs[2], ".failed")) << "an error\n";
  EXPECT_EQ(adopt_legacy_outputs(dir, runs), 1u);
  auto text = [](const fs::path& f) {
    std::ifstream in(f);
    std::string line;
    std::getline(in, line);
    return line;
  };
  EXPECT_EQ(text(run_output(dir, runs[0])), "reference");
  EXPECT_EQ(text(run_log(dir, runs[0])), "warning");
  EXPECT_FALSE(fs::exists(legacy(runs[0], ".h5")));
  EXPECT_EQ(text(run_output(dir, runs[1])), "own");
  EXPECT_TRUE(fs::exists(legacy(runs[1], ".h5")));
  EXPECT_EQ(read_run_failure(dir, runs[2]), "an error");
  InputDigests digests(&p);
  EXPECT_EQ(run_state(dir, p, runs[0], digests), RunState::Done);  // not an ebh output: done, as before
  EXPECT_EQ(adopt_legacy_outputs(dir, runs), 0u);
}

/// A plan of three runs (two grid points and the reference) whose replays the tests below replace
/// with stand-in scripts.
std::vector<SweepRun> three_runs(SweepPlan& plan, const std::string& name) {
  plan = read_sweep_plan(plan_file(name, R"(scenes:
  - scene: tube
    recordings: [tube_insert]
    reference: {solver.method: direct}
grid:
  stiffness.k_con: [400, 500]
duration: 0.1
)"));
  return expand_plan(plan);
}

/// An interrupted sweep passes SIGTERM on to its replays; one stuck past even its own grace
/// (tests/sweep/stuck_replay.sh ignores every signal but SIGKILL) is killed RunnerOptions::
/// stop_grace_s later, counted as interrupted, with no output, and the sweep returns.
TEST(SweepRunner, AReplayStuckAfterTheInterruptIsKilled) {
  const fs::path dir = scratch() / "stuck";
  fs::remove_all(dir);
  SweepPlan plan;
  const std::vector<SweepRun> runs = three_runs(plan, "stuck.yaml");
  RunnerOptions opt;
  opt.executable = test_replay("stuck_replay.sh");
  opt.stop_grace_s = 0.5;
  install_interrupt_handlers();
  set_interrupted(false);
  const auto t0 = std::chrono::steady_clock::now();
  const RunnerReport rep = execute_runs(plan, runs, dir, opt, [](const RunnerProgress&, const RunOutcome* o) {
    if (!o) set_interrupted(true);  // as a SIGTERM once the first replay runs
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  set_interrupted(false);
  EXPECT_LT(seconds, 10.0) << "the stuck replay was not killed";
  EXPECT_EQ(rep.interrupted, 1u);
  EXPECT_EQ(rep.ran, 0u);
  EXPECT_EQ(rep.failed, 0u);
  EXPECT_TRUE(rep.stopped);
  for (const SweepRun& r : runs) EXPECT_FALSE(fs::exists(run_output(dir, r))) << r.id;
  EXPECT_EQ(interrupt_grace(), 0u) << "the sweep's process waits for its replays";
  set_interrupt_grace(kInterruptGraceSeconds);
}

/// A replay the interrupt reaches after it wrote its output (tests/sweep/late_replay.sh exits 143
/// then) ran: counted done, not stopped in flight. A stale output a child was to replace, which the
/// interrupt stopped before it wrote (stuck_replay.sh writes nothing), is no run done.
TEST(SweepRunner, AnOutputWrittenBeforeTheInterruptIsARunDone) {
  const fs::path dir = scratch() / "late";
  fs::remove_all(dir);
  SweepPlan plan;
  const std::vector<SweepRun> runs = three_runs(plan, "late.yaml");
  RunnerOptions opt;
  opt.executable = test_replay("late_replay.sh");
  opt.stop_grace_s = 5;
  install_interrupt_handlers();
  set_interrupted(false);
  const fs::path first = run_output(dir, runs[0]);
  RunnerReport rep = execute_runs(plan, runs, dir, opt, [&first](const RunnerProgress&, const RunOutcome* o) {
    if (o) return;
    for (int i = 0; i < 500 && !fs::exists(first); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    set_interrupted(true);  // as a SIGTERM once the first replay wrote its output
  });
  set_interrupted(false);
  EXPECT_EQ(rep.ran, 1u);
  EXPECT_EQ(rep.interrupted, 0u);
  EXPECT_EQ(rep.failed, 0u);
  EXPECT_TRUE(rep.stopped);

  const fs::path stale_dir = scratch() / "late_stale";
  fs::remove_all(stale_dir);
  fs::create_directories(stale_dir / "runs");
  std::ofstream(run_output(stale_dir, runs[0])) << "an old output\n";
  const std::vector<RunState> stale(runs.size(), RunState::Stale);  // as run_state would say
  opt.executable = test_replay("stuck_replay.sh");
  opt.stop_grace_s = 0.5;
  rep = execute_runs(plan, runs, stale_dir, opt, [](const RunnerProgress&, const RunOutcome* o) {
    if (!o) set_interrupted(true);
  }, &stale);
  set_interrupted(false);
  EXPECT_EQ(rep.ran, 0u);
  EXPECT_EQ(rep.interrupted, 1u);
  set_interrupt_grace(kInterruptGraceSeconds);
}

/// The temporaries left in `folder` (*.ebh-partial).
std::vector<std::string> partials(const fs::path& folder) {
  std::vector<std::string> out;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
    if (is_partial_output(it->path().string())) out.push_back(it->path().filename().string());
  return out;
}

/// A replay killed by a signal (SIGKILL: the OOM killer) cannot remove its output's temporary;
/// the sweep removes it when it sees the child die, and records the run as failed.
TEST(SweepRunner, AKilledReplaysTemporaryIsRemoved) {
  const fs::path dir = scratch() / "killed";
  fs::remove_all(dir);
  SweepPlan plan;
  const std::vector<SweepRun> runs = three_runs(plan, "killed.yaml");
  RunnerOptions opt;
  opt.executable = test_replay("partial_replay.sh");
  setenv("EBH_FAKE_KILL_SELF", "1", 1);
  const RunnerReport rep = execute_runs(plan, runs, dir, opt);
  unsetenv("EBH_FAKE_KILL_SELF");
  EXPECT_EQ(rep.failed, runs.size());
  ASSERT_FALSE(rep.failures.empty());
  EXPECT_EQ(rep.failures[0].error, "the replay was killed by signal 9");
  EXPECT_TRUE(partials(dir / "runs").empty()) << partials(dir / "runs").front();
}

/// Whether process `pid` has ended (gone, or a zombie no one has reaped yet).
bool process_ended(pid_t pid) {
  if (kill(pid, 0) != 0) return errno == ESRCH;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(stat, text);
  const auto paren = text.rfind(')');
  return paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] == 'Z';
}

/// A sweep killed with SIGKILL (it cannot pass anything on) takes its replays with it: each gets
/// SIGTERM as its parent dies, so none goes on writing into runs/ as an orphan.
TEST(SweepRunner, ReplaysEndWithAKilledSweep) {
  const fs::path dir = scratch() / "orphans", pids = scratch() / "orphan_pids";
  fs::remove_all(dir);
  fs::remove_all(pids);
  fs::create_directories(pids);
  SweepPlan plan;
  const std::vector<SweepRun> runs = three_runs(plan, "orphans.yaml");
  const pid_t sweep = fork();
  ASSERT_GE(sweep, 0);
  if (sweep == 0) {  // the sweep: two replays at a time, each sleeping until a signal ends it
    setenv("EBH_FAKE_PID_DIR", pids.c_str(), 1);
    RunnerOptions opt;
    opt.executable = test_replay("partial_replay.sh");
    opt.jobs = 2;
    try {
      execute_runs(plan, runs, dir, opt);
    } catch (...) {
    }
    _exit(0);
  }
  std::vector<pid_t> replays;
  for (int i = 0; i < 300 && replays.size() < 2; ++i) {  // at most 30 s for both to start
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    replays.clear();
    for (const auto& e : fs::directory_iterator(pids)) replays.push_back(static_cast<pid_t>(std::stol(e.path().filename().string())));
  }
  kill(sweep, SIGKILL);
  waitpid(sweep, nullptr, 0);
  ASSERT_EQ(replays.size(), 2u) << "the replays did not start";
  for (const pid_t r : replays) {
    bool ended = false;
    for (int i = 0; i < 100 && !(ended = process_ended(r)); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_TRUE(ended) << "replay " << r << " outlived its sweep";
    if (!ended) kill(r, SIGKILL);
  }
}

TEST(SweepError, IdenticalForcesHaveNoError) {
  const ReplayTrace a = trace({0, 1e-3, 2e-3}, {{0.1, 0.2, 0.3}, {1, 2, 3}, {-1, 0, 0.5}});
  const ForceError e = force_error(a, a);
  EXPECT_EQ(e.rms, 0.0);
  EXPECT_EQ(e.max, 0.0);
  EXPECT_EQ(e.p999, 0.0);
  EXPECT_EQ(e.ticks, 3u);
}

TEST(SweepError, TickByTickRmsMaxAndPercentile) {
  // |F - F_ref| = 0, 3, 4 N (a 3-4-5 triangle for the last): RMS sqrt(25/3), max 4, p99.9 at
  // position 0.999 * 2 between 3 and 4.
  const ReplayTrace ref = trace({0, 1e-3, 2e-3}, {{0, 0, 0}, {0, 0, 0}, {1, 1, 1}});
  const ReplayTrace run = trace({0, 1e-3, 2e-3}, {{0, 0, 0}, {3, 0, 0}, {1, 5, 1}});
  const ForceError e = force_error(run, ref);
  EXPECT_NEAR(e.rms, std::sqrt(25.0 / 3.0), 1e-15);
  EXPECT_EQ(e.max, 4.0);
  EXPECT_NEAR(e.p999, 3.0 + 0.998, 1e-12);
}

TEST(SweepError, OtherRatesAreComparedAsTheDeviceHoldsTheForce) {
  // The run ticks at half the reference's rate: between its ticks its last force is held.
  const ReplayTrace ref = trace({0, 1e-3, 2e-3, 3e-3}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}});
  const ReplayTrace run = trace({0, 2e-3}, {{0, 0, 0}, {2, 0, 0}});
  const ForceError e = force_error(run, ref);
  // Compared at 0, 1, 2 ms (3 ms is past the run's last tick): errors 0, 1, 0.
  EXPECT_EQ(e.ticks, 3u);
  EXPECT_EQ(e.max, 1.0);
  EXPECT_NEAR(e.rms, std::sqrt(1.0 / 3.0), 1e-15);
  // No overlap: no error to give.
  const ForceError none = force_error(trace({5, 6}, {{0, 0, 0}, {0, 0, 0}}), ref);
  EXPECT_EQ(none.ticks, 0u);
  EXPECT_TRUE(std::isnan(none.rms));
}

TEST(SweepCsv, QuotedFieldsRoundTrip) {
  CsvTable t;
  t.header = {"id", "error"};
  t.rows = {{"a", "plain"}, {"b", "with, comma"}, {"c", "with \"quotes\"\nand a line break"}, {"d", ""}};
  const CsvTable back = parse_csv(t.to_csv(), "t.csv");
  EXPECT_EQ(back.header, t.header);
  EXPECT_EQ(back.rows, t.rows);
  try {
    (void)parse_csv("a,b\n1,2\n3\n", "t.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "t.csv:3: 1 fields, the header has 2");
  }
  EXPECT_THROW((void)parse_csv("a,b\n\"1,2\n", "t.csv"), InputError);
}

// A quote where RFC 4180 allows none is refused, naming the file, line, column and field: an
// undoubled one inside a quoted field (the report read '"tu,be|"x<b>"' as the scene tu,be|x<b> and
// split its group), and one inside a field that does not begin with one. A CR alone ends a line:
// the field count then says so.
TEST(SweepCsv, MalformedQuotingIsRefused) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"id,scene\na,\"tu,be|\"x<b>\"\n", "t.csv:2:10: field 2: a quote inside a quoted field must be doubled (\"\")"},
      {"id,scene\na,\"multi\nline\" x\n", "t.csv:3:5: field 2: a quote inside a quoted field must be doubled (\"\")"},
      {"id,scene\na,tu\"be\n", "t.csv:2:5: field 2: a quote in a field that does not begin with one (quote the field and "
                                 "double the quote)"},
      {"id,scene,x\na,tu\rbe,1\n", "t.csv:2: 2 fields, the header has 3 (a carriage return with no line feed after it ends a "
                                     "line here: one inside a field must be quoted)"},
  };
  for (const auto& [text, expected] : cases) {
    try {
      (void)parse_csv(text, "t.csv");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), expected);
    }
  }
  // Well-formed: a doubled quote, a quoted field at the line's and the file's end, CRLF and lone CR lines.
  const CsvTable t = parse_csv("id,scene\r\na,\"x\"\"y\"\rb,\"z\"", "t.csv");
  EXPECT_EQ(t.rows, (std::vector<std::vector<std::string>>{{"a", "x\"y"}, {"b", "z"}}));
}

// summary.h5: the hand-made summary plus a numeric and a text scene-key column, written and read
// back: every column a dataset of its kind with the CSV's values (empty cells NaN), the column
// order in `columns`; a numeric column with text is refused and leaves no file.
TEST(SweepSummaryH5, SameRowsAndColumnsTyped) {
  const std::string file = front_file();
  const std::string text = front_text();
  CsvTable t = parse_csv(text, file);
  t.header.insert(t.header.begin() + 8, {"set.k", "set.solver.method"});
  for (std::size_t r = 0; r < t.rows.size(); ++r)
    t.rows[r].insert(t.rows[r].begin() + 8, {r == 0 ? "" : std::to_string(r), r == 0 ? "direct" : ""});
  const fs::path out = scratch() / "summary.h5";
  fs::remove(out);
  write_summary_h5(t, out.string());
  const h5::File f = h5::File::open_read(out.string());
  std::string columns;
  for (const std::string& c : t.header) columns += (columns.empty() ? "" : "\n") + c;
  EXPECT_EQ(f.attr_string("columns"), columns);
  const std::size_t n = t.rows.size();
  auto col = [&](const std::string& name) {
    std::vector<std::string> v;
    for (const auto& row : t.rows) v.push_back(row[t.column(name, file)]);
    return v;
  };
  for (const char* name : {"id", "status", "scene", "recording", "backend", "overrides", "error", "set.solver.method"})
    EXPECT_EQ(f.dataset(name).read_strings(), col(name)) << name;
  EXPECT_EQ(f.read<std::int64_t>("repetition", {static_cast<std::ptrdiff_t>(n)}).data,
            (std::vector<std::int64_t>{0, 0, 0, 1, 0, 0, 0, 0, 0}));
  EXPECT_EQ(f.read<std::int64_t>("reference").data, (std::vector<std::int64_t>{1, 0, 0, 0, 0, 0, 0, 0, 0}));
  const std::vector<double> wall = f.read<double>("wall_s").data;
  ASSERT_EQ(wall.size(), n);
  EXPECT_EQ(wall[0], 10.0);
  EXPECT_EQ(wall[3], 2.4);
  EXPECT_TRUE(std::isnan(wall[7]) && std::isnan(wall[8]));  // failed and pending: no value
  const std::vector<double> k = f.read<double>("set.k").data;
  EXPECT_TRUE(std::isnan(k[0]));
  EXPECT_EQ(k[5], 5.0);
  EXPECT_THROW((void)f.read<std::int64_t>("wall_s"), InputError);  // float64, not int64
  for (const std::string& c : t.header) EXPECT_TRUE(f.has(c)) << c;

  CsvTable bad = t;
  bad.rows[2][bad.column("wall_s", file)] = "fast";
  const fs::path out2 = scratch() / "bad_summary.h5";
  fs::remove(out2);
  try {
    write_summary_h5(bad, out2.string());
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), out2.string() + ": row 3, column 'wall_s': expected a number, got 'fast'");
  }
  EXPECT_FALSE(fs::exists(out2));
}

TEST(SweepReport, ParetoFront) {
  const double nan = std::nan("");
  // (wall, error): (1, .5) (2, .2) (3, .3) (4, .1) (1.5, .5) (2, .2) again, a NaN.
  const std::vector<bool> f = pareto_front({{1, .5}, {2, .2}, {3, .3}, {4, .1}, {1.5, .5}, {2, .2}, {nan, 0}});
  EXPECT_EQ(f, (std::vector<bool>{true, true, false, true, false, true, false}));
  EXPECT_TRUE(pareto_front({}).empty());
}

TEST(SweepReport, HandMadeSummary) {
  const std::string file = front_file();
  const std::string text = front_text();
  const std::vector<ReportGroup> g = build_report(parse_csv(text, file), file);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0].reference, "solver.method=direct (cpu)");
  std::vector<std::string> order, front;
  for (const ReportPoint& p : g[0].points) {
    order.push_back(p.overrides);
    if (p.front) front.push_back(p.overrides);
  }
  EXPECT_EQ(order, (std::vector<std::string>{"k=1", "k=5", "k=2", "k=3", "k=4", "solver.method=direct"}));
  EXPECT_EQ(front, (std::vector<std::string>{"k=1", "k=2", "k=4"}));
  EXPECT_EQ(g[0].points[2].runs, 2u);
  EXPECT_DOUBLE_EQ(g[0].points[2].wall_s, 2.2);  // the median of 2 and 2.4
  ASSERT_EQ(g[0].failed.size(), 1u);
  EXPECT_EQ(g[0].failed[0], "f k=6: the replay failed, for a reason with a comma");
  EXPECT_EQ(g[0].pending, 1u);
  const std::string md = report_markdown(g);
  EXPECT_NE(md.find("| * | k=1 | 1 | 1 | 2x | 0.5 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| reference | solver.method=direct | 1 | 10 |"), std::string::npos) << md;
  EXPECT_TRUE(std::isnan(g[0].points[0].max_force_rate));  // the hand-made summary has no metrics
  // Names from the summary are escaped in headings as in cells: a line break ended the heading and
  // made its rest another.
  std::vector<ReportGroup> odd = g;
  odd[0].scene = "tu|be\n# hdr";
  const std::string odd_md = report_markdown(odd);
  EXPECT_NE(odd_md.find("\n## tu\\|be\\x0a# hdr + "), std::string::npos) << odd_md;
  EXPECT_EQ(odd_md.find("\n# hdr"), std::string::npos) << odd_md;
}

// The rendered force's largest rate (ebh metrics' whole.max_force_rate_N_per_s) beside the
// errors: the median of a configuration's runs, in the table's column before the residual.
TEST(SweepReport, MaxForceRateColumn) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("whole.max_force_rate_N_per_s");
  for (std::size_t r = 0; r < t.rows.size(); ++r) t.rows[r].push_back(std::to_string(100 * (r + 1)));
  const std::vector<ReportGroup> g = build_report(t, file);
  ASSERT_EQ(g.size(), 1u);
  const std::string md = report_markdown(g);
  EXPECT_NE(md.find("| max force rate (N/s) | max physical residual |"), std::string::npos) << md;
  for (const ReportPoint& p : g[0].points) {
    std::vector<double> rates;  // the rows of this configuration, as the summary lists them
    for (std::size_t r = 0; r < t.rows.size(); ++r)
      if (t.rows[r][t.column("overrides", file)] == p.overrides && t.rows[r][t.column("status", file)] == "ok")
        rates.push_back(100.0 * static_cast<double>(r + 1));
    ASSERT_FALSE(rates.empty()) << p.overrides;
    std::sort(rates.begin(), rates.end());  // their median
    const std::size_t n = rates.size();
    const double expected = n % 2 ? rates[n / 2] : 0.5 * (rates[n / 2 - 1] + rates[n / 2]);
    EXPECT_DOUBLE_EQ(p.max_force_rate, expected) << p.overrides;
  }
}

// The regions' sizes (active_vertices_mean, awake_vertices_mean): a column of the table only when a
// run of the group has one, its cells the medians of a configuration's runs, "-" where a run has
// no region (an empty cell).
TEST(SweepReport, RegionColumnOnlyWithARegion) {
  const std::string file = front_file();
  const CsvTable plain = parse_csv(front_text(), file);
  const std::string without = report_markdown(build_report(plain, file));
  EXPECT_EQ(without.find("vertices iterated"), std::string::npos) << without;
  CsvTable t = plain;
  t.header.push_back("active_vertices_mean");
  t.header.push_back("awake_vertices_mean");
  const std::size_t over = t.column("overrides", file);
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const bool region = t.rows[r][over] == "k=2";  // two runs: 1000 and 3000 virtual, 50 and 70 physical
    t.rows[r].push_back(region ? (r % 2 ? "1000" : "3000") : "");
    t.rows[r].push_back(region ? (r % 2 ? "50" : "70") : "");
  }
  const std::vector<ReportGroup> g = build_report(t, file);
  ASSERT_EQ(g.size(), 1u);
  const std::string md = report_markdown(g);
  EXPECT_NE(md.find("| max physical residual | vertices iterated (virtual / physical) |\n|---|---|---|---|---|---|---|---|---|---|---|\n"),
            std::string::npos) << md;
  for (const ReportPoint& p : g[0].points) {
    if (p.overrides == "k=2") {
      EXPECT_DOUBLE_EQ(p.active_mean, 2000);
      EXPECT_DOUBLE_EQ(p.awake_mean, 60);
    } else {
      EXPECT_TRUE(std::isnan(p.active_mean) && std::isnan(p.awake_mean)) << p.overrides;
    }
  }
  EXPECT_NE(md.find(" | 2000 / 60 |\n"), std::string::npos) << md;
  EXPECT_NE(md.find(" | - / - |\n"), std::string::npos) << md;
}

// A window where no run's tool touched the tissue is said so above the group's table (its errors
// are all 0 and compare free motion); one run in contact is enough to say nothing.
TEST(SweepReport, AWindowWithoutContactIsSaidSo) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("contact_fraction");
  for (auto& row : t.rows) row.push_back("0");
  const std::string none = report_markdown(build_report(t, file));
  EXPECT_NE(none.find("**The tool never touched the tissue in this window**"), std::string::npos) << none;
  t.rows.front().back() = "0.4";
  EXPECT_EQ(report_markdown(build_report(t, file)).find("never touched"), std::string::npos);
  // Without the column (an older summary): nothing said.
  EXPECT_EQ(report_markdown(build_report(parse_csv(front_text(), file), file)).find("never touched"), std::string::npos);
}

// The baseline column: its point is marked, and the report finds the fastest configuration at
// its error or lower and the most accurate at its wall time or lower (the hand-made summary with
// k=3, wall 3 s and error 0.3 N, as the baseline: k=2 is both, 2.2 s and 0.2 N).
TEST(SweepReport, BaselineGoal) {
  const std::string file = front_file();
  const std::string text = front_text();
  CsvTable t = parse_csv(text, file);
  t.header.push_back("baseline");
  for (auto& row : t.rows) row.push_back(row[t.column("overrides", file)] == "k=3" ? "paper" : "");
  const std::vector<ReportGroup> g = build_report(t, file);
  ASSERT_EQ(g.size(), 1u);
  const auto goal = baseline_goal(g[0]);
  ASSERT_TRUE(goal.has_value());
  EXPECT_EQ(g[0].points[goal->baseline].overrides, "k=3");
  EXPECT_EQ(g[0].points[goal->baseline].baseline, "paper");
  EXPECT_EQ(g[0].points[goal->fastest].overrides, "k=2");
  EXPECT_EQ(g[0].points[goal->most_accurate].overrides, "k=2");
  EXPECT_DOUBLE_EQ(goal->speedup, 3 / 2.2);
  EXPECT_DOUBLE_EQ(goal->error_ratio, 0.3 / 0.2);
  const std::string md = report_markdown(g);
  EXPECT_NE(md.find("|  paper | k=3 |"), std::string::npos) << md;
  EXPECT_NE(md.find("is k=2, 2.2 s, **1.36x faster**"), std::string::npos) << md;
  EXPECT_NE(md.find("**1.5x lower error**. 2x goal: not met."), std::string::npos) << md;
  EXPECT_NE(md.find("## The 2x goal\n\n- cpu: met on 0 of 1 scene and recording pairs\n"), std::string::npos) << md;
  // As the baseline k=4 (4 s, 0.1 N): k=2 at 2.2 s is not as accurate, so nothing is faster at
  // 0.1 N; nothing slower counts for accuracy, and k=4 is the most accurate at 4 s or less.
  for (auto& row : t.rows) row.back() = row[t.column("overrides", file)] == "k=4" ? "paper" : "";
  const auto g4 = build_report(t, file);
  const auto goal4 = baseline_goal(g4[0]);
  ASSERT_TRUE(goal4.has_value());
  EXPECT_EQ(goal4->fastest, goal4->baseline);
  EXPECT_EQ(goal4->speedup, 1.0);
  EXPECT_EQ(g4[0].points[goal4->most_accurate].overrides, "k=4");
  // No baseline column: no comparison.
  EXPECT_FALSE(baseline_goal(build_report(parse_csv(text, file), file)[0]).has_value());
  // Every error 0 (a window where the tool never touches the tissue): no gain in accuracy, where
  // 0 / 0 was taken for an infinite one that met the goal.
  CsvTable zero = t;
  for (auto& row : zero.rows) row[zero.column("force_error_rms_N", file)] = "0";
  const auto gz = build_report(zero, file);
  EXPECT_EQ(baseline_goal(gz[0])->error_ratio, 1.0);
  EXPECT_FALSE(baseline_goal(gz[0])->more_accurate());
  // One configuration with no error where the baseline has some (an override that changes nothing:
  // the reference in effect) is no candidate, not an infinite gain that met the goal.
  CsvTable same = t;
  for (auto& row : same.rows)
    if (row[same.column("overrides", file)] == "k=2") row[same.column("force_error_rms_N", file)] = "3.7e-15";  // round-off
  const auto gs = build_report(same, file);
  const auto goal_same = baseline_goal(gs[0]);
  ASSERT_TRUE(goal_same.has_value());
  EXPECT_NE(gs[0].points[goal_same->most_accurate].overrides, "k=2");
  EXPECT_NE(gs[0].points[goal_same->fastest].overrides, "k=2");
  EXPECT_TRUE(std::isfinite(goal_same->error_ratio));
  // A winner whose physical mesh is far less converged than the baseline's (its max residual over
  // kLooserSolve times the baseline's) is named so beside the comparison; one within it is not.
  for (auto& row : t.rows) row.back() = row[t.column("overrides", file)] == "k=3" ? "paper" : "";
  t.header.push_back("timing.physical_residual_max");
  for (auto& row : t.rows) row.push_back(row[t.column("overrides", file)] == "k=2" ? "0.02" : "0.002");
  const std::string loose = report_markdown(build_report(t, file));
  EXPECT_EQ(report_markdown(build_report(parse_csv(text, file), file)).find("The 2x goal"), std::string::npos);
  EXPECT_NE(loose.find("**1.36x faster** (its physical solve is less converged: max residual 0.02 mesh weights, 10x the "
                       "baseline's); the most accurate"),
            std::string::npos) << loose;
  for (auto& row : t.rows) row.back() = row[t.column("overrides", file)] == "k=2" ? "0.009" : "0.002";
  const std::string close = report_markdown(build_report(t, file));
  EXPECT_EQ(close.find("less converged"), std::string::npos) << close;
  // The baseline at 5 s: k=2 (2.2 s, 0.2 N) is 2.27x faster at a lower error, and the plan's
  // summary counts the pair.
  for (auto& row : t.rows)
    if (row[t.column("overrides", file)] == "k=3") row[t.column("wall_s", file)] = "5";
  const std::string met = report_markdown(build_report(t, file));
  EXPECT_NE(met.find("2x goal: met."), std::string::npos) << met;
  EXPECT_NE(met.find("- cpu: met on 1 of 1 scene and recording pairs (tube_insert)\n"), std::string::npos) << met;
  // Met by k=2 (faster) and k=4 (3x more accurate in 4 s): marked only when both are less converged.
  for (auto& row : t.rows)
    if (row[t.column("overrides", file)] == "k=2") row.back() = "0.02";  // its residual 10x the baseline's
  EXPECT_NE(report_markdown(build_report(t, file)).find("(tube_insert)\n"), std::string::npos);
  for (auto& row : t.rows)
    if (row[t.column("overrides", file)] == "k=4") row.back() = "0.02";
  const std::string met_loose = report_markdown(build_report(t, file));
  EXPECT_NE(met_loose.find("(tube_insert [less converged])\n"), std::string::npos) << met_loose;
}

// A group whose baseline gives no comparison says why, and the 2x-goal section counts it as not
// compared: both were left out without a word (a baseline without force errors, one that failed).
// A summary without rows is refused: it gave a report of its title and exit 0.
TEST(SweepReport, ABaselineWithoutAComparisonSaysWhy) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("baseline");
  for (auto& row : t.rows) row.push_back(row[t.column("overrides", file)] == "k=3" ? "paper" : "");
  CsvTable no_error = t;
  for (auto& row : no_error.rows)
    if (row.back() == "paper") {
      for (const char* c : {"force_error_rms_N", "force_error_max_N", "force_error_p999_N"}) row[no_error.column(c, file)] = "";
      row[no_error.column("error", file)] = "no reference: its run r0 failed";
    }
  std::vector<ReportGroup> g = build_report(no_error, file);
  EXPECT_FALSE(baseline_goal(g[0]).has_value());
  EXPECT_EQ(g[0].no_baseline_goal, "its runs have no force error: no reference: its run r0 failed");
  std::string md = report_markdown(g);
  EXPECT_NE(md.find("\nAgainst the baseline paper: no comparison: its runs have no force error: no reference: its run r0 "
                    "failed.\n"), std::string::npos) << md;
  EXPECT_NE(md.find("## The 2x goal\n\n- cpu: met on 0 of 0 scene and recording pairs; not compared on tube_insert, whose "
                    "baseline gives no comparison (see its section)\n"), std::string::npos) << md;
  CsvTable failed = t;
  for (auto& row : failed.rows)
    if (row.back() == "paper") row[failed.column("status", file)] = "failed";
  g = build_report(failed, file);
  EXPECT_EQ(g[0].no_baseline_goal, "none of its runs is ok (1 failed, 0 not run yet)");
  EXPECT_NE(report_markdown(g).find("Against the baseline paper: no comparison: none of its runs is ok"), std::string::npos);
  // With a comparison, or no baseline, nothing is said.
  EXPECT_EQ(build_report(t, file)[0].no_baseline_goal, "");
  EXPECT_EQ(report_markdown(build_report(parse_csv(front_text(), file), file)).find("no comparison"), std::string::npos);

  CsvTable empty = t;
  empty.rows.clear();
  try {
    (void)build_report(empty, "s.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv: no runs (a header line and no rows; a sweep's summary has a row per run)");
  }
}

// The baseline is no candidate against itself: where no configuration is faster at its error (or
// more accurate at its time), the comparison says so, where it said the baseline itself was "1x
// faster" ("1x lower error"). In the hand-made summary, k=4 (4 s, 0.1 N) is both the fastest at its
// error and the most accurate at its time; k=5 (1.5 s, 0.5 N) is beaten on time by k=1 (1 s, 0.5 N)
// and on error by none at 1.5 s or less.
TEST(SweepReport, TheBaselineIsNotComparedWithItself) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("baseline");
  for (auto& row : t.rows) row.push_back(row[t.column("overrides", file)] == "k=4" ? "paper" : "");
  const std::string both = report_markdown(build_report(t, file));
  EXPECT_NE(both.find("Against the baseline paper (k=4: 4 s, RMS error 0.1 N): no configuration is faster at an RMS error "
                      "<= 0.1 N; no configuration is more accurate at a wall time <= 4 s. 2x goal: not met.\n"),
            std::string::npos) << both;
  EXPECT_EQ(both.find("1x"), std::string::npos) << both;
  for (auto& row : t.rows) row.back() = row[t.column("overrides", file)] == "k=5" ? "paper" : "";
  const std::string faster = report_markdown(build_report(t, file));
  EXPECT_NE(faster.find("Against the baseline paper (k=5: 1.5 s, RMS error 0.5 N): the fastest at an RMS error <= 0.5 N is "
                        "k=1, 1 s, **1.5x faster**; no configuration is more accurate at a wall time <= 1.5 s. 2x goal: not "
                        "met.\n"),
            std::string::npos) << faster;
  EXPECT_EQ(faster.find("1x lower error"), std::string::npos) << faster;
}

// Names, overrides and errors from the summary show in the report as written: what Markdown or
// HTML would take for syntax (a tag, a link, emphasis, a code span, a table's bar) is escaped,
// where a Markdown viewer rendered <b>tube</b> bold and [x](y) a link. Plain names (tube_insert,
// solver.virtual_iterations=2, a list) are left byte for byte.
TEST(SweepReport, NamesShowAsWrittenNotAsMarkup) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("baseline");
  const std::size_t c_over = t.column("overrides", file), c_error = t.column("error", file);
  for (auto& row : t.rows) {
    row[t.column("scene", file)] = "<b>tube</b>";
    row[t.column("recording", file)] = "rec[x](y)*";
    row.push_back(row[c_over] == "k=3" ? "**paper** & co" : "");
    if (row[c_over] == "k=1") row[c_over] = "description=`x` | *y* _z_ ~w~ $m$ a\\b";
    if (row[c_over] == "k=5") row[c_over] = "gravity=[0, 0, -9.81] solver.virtual_iterations=2 k_con=tube_insert";
    if (row[c_over] == "k=6") row[c_error] = "<script>x</script>: see [the log](runs/f.log)";
  }
  const std::string md = report_markdown(build_report(t, file));
  EXPECT_NE(md.find("\n## \\<b\\>tube\\</b\\> + rec[x\\](y)\\*, cpu\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| * | description=\\`x\\` \\| \\*y\\* \\_z\\_ \\~w\\~ \\$m\\$ a\\\\b | 1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("|  \\*\\*paper\\*\\* \\& co | k=3 |"), std::string::npos) << md;
  EXPECT_NE(md.find("Against the baseline \\*\\*paper\\*\\* \\& co (k=3:"), std::string::npos) << md;
  EXPECT_NE(md.find("\nfailed: f k=6: \\<script\\>x\\</script\\>: see [the log\\](runs/f.log)\n"), std::string::npos) << md;
  EXPECT_NE(md.find("- cpu: met on 0 of 1 scene and recording pairs\n"), std::string::npos) << md;
  // Plain text as it is: an underscore between letters opens no emphasis, a bracket no link but "](".
  EXPECT_NE(md.find("|  | gravity=[0, 0, -9.81] solver.virtual_iterations=2 k_con=tube_insert | 1 | 1.5 |"), std::string::npos)
      << md;
  EXPECT_NE(report_markdown(build_report(parse_csv(front_text(), file), file)).find("\n## tube + tube_insert, cpu\n"),
            std::string::npos);
}

/// The haptic rate floor (`ebh sweep report --min-haptic-hz`, kDeviceHapticHz by default there): a
/// configuration below it is listed, marked, and no candidate. In the hand-made summary k=2 (2.2 s,
/// 0.2 N), at 500 Hz, leaves the front and the comparison with the baseline k=3 (3 s, 0.3 N),
/// which then finds nothing better than k=3 itself; with the floor at 0, or without the column,
/// k=2 is back.
TEST(SweepReport, ConfigurationsBelowTheHapticRateAreNoCandidates) {
  const std::string file = front_file();
  CsvTable t = parse_csv(front_text(), file);
  t.header.push_back("baseline");
  t.header.push_back("haptic_hz");
  for (auto& row : t.rows) {
    const std::string& over = row[t.column("overrides", file)];
    row.push_back(over == "k=3" ? "paper" : "");
    row.push_back(over == "k=2" ? "500" : "1000");
  }
  auto front_of = [](const ReportGroup& g) {
    std::vector<std::string> f;
    for (const ReportPoint& p : g.points)
      if (p.front) f.push_back(p.overrides);
    return f;
  };
  const std::vector<ReportGroup> g = build_report(t, file, kDeviceHapticHz);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(front_of(g[0]), (std::vector<std::string>{"k=1", "k=3", "k=4"}));
  const auto goal = baseline_goal(g[0]);
  ASSERT_TRUE(goal.has_value());
  EXPECT_EQ(goal->fastest, goal->baseline);
  EXPECT_EQ(goal->most_accurate, goal->baseline);
  const std::string md = report_markdown(g);
  EXPECT_NE(md.find("| < Hz | k=2 |"), std::string::npos) << md;
  EXPECT_NE(md.find("below 1000 haptic ticks per second"), std::string::npos) << md;
  // No floor: k=2 is a candidate again.
  const std::vector<ReportGroup> all = build_report(t, file, 0);
  EXPECT_EQ(front_of(all[0]), (std::vector<std::string>{"k=1", "k=2", "k=4"}));
  EXPECT_EQ(all[0].points[baseline_goal(all[0])->fastest].overrides, "k=2");
  EXPECT_EQ(report_markdown(all).find("haptic ticks per second"), std::string::npos);
  // A summary without the column: no point is below the floor.
  EXPECT_EQ(front_of(build_report(parse_csv(front_text(), file), file, kDeviceHapticHz)[0]),
            (std::vector<std::string>{"k=1", "k=2", "k=4"}));
}

TEST(SweepReport, MissingColumnAndBadNumberAreNamed) {
  try {
    (void)build_report(parse_csv("status,scene\nok,tube\n", "s.csv"), "s.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv: no column 'recording'");
  }
  const std::string header =
      "status,scene,recording,backend,reference,overrides,wall_s,real_time_factor,force_error_rms_N,force_error_max_N,"
      "force_error_p999_N\n";
  try {
    (void)build_report(parse_csv(header + "ok,tube,r,cpu,0,-,fast,1,0,0,0\n", "s.csv"), "s.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv: row 2, column 'wall_s': expected a number, got 'fast'");
  }
  // Values a replay cannot have written: a negative wall time (it would lead the front), two
  // references for one recording (the errors would be against either).
  for (const char* wall : {"-1", "nan", "inf", "0"})
    try {
      (void)build_report(parse_csv(header + "ok,tube,r,cpu,0,-," + wall + ",1,0,0,0\n", "s.csv"), "s.csv");
      ADD_FAILURE() << wall;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()),
                std::string("s.csv: row 2, column 'wall_s': expected a finite number > 0 (the run's wall time), got '") +
                    wall + "'");
    }
  try {
    (void)build_report(parse_csv(header + "ok,tube,r,cpu,1,a=1,1,1,0,0,0\nok,tube,r,cpu,1,a=1,1,1,0,0,0\n"
                                          "ok,tube,r,cpu,1,a=2,1,1,0,0,0\n",
                                 "s.csv"),
                       "s.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv: row 4, column 'reference': a second reference for tube + r (a=2 (cpu); the first: a=1 (cpu))");
  }
  // Two baselines for one group (a plan names one): the goal would be against either.
  const std::string with_baseline = header.substr(0, header.size() - 1) + ",baseline\n";
  try {
    (void)build_report(parse_csv(with_baseline + "ok,tube,r,cpu,1,-,1,1,0,0,0,\nok,tube,r,cpu,0,a=1,1,1,0,0,0,paper\n"
                                                  "ok,tube,r,cpu,0,a=2,1,1,0,0,0,other\n",
                                 "s.csv"),
                       "s.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv: row 4, column 'baseline': a second baseline 'other' for tube + r on cpu (the first: "
                           "'paper', row 3)");
  }
}

// Each measure of an ok row is what a replay can give (empty, or a finite number >= 0), the
// reference flag 0 or 1, each column named once, the rate floor a number: a summary edited by
// hand that breaks one is refused naming the row and column, not reported (an error of -1 or
// -inf led the front, a wall time of 0 gave "-x faster").
TEST(SweepReport, BadCellsAreNamed) {
  const std::string header =
      "status,scene,recording,backend,reference,overrides,wall_s,real_time_factor,force_error_rms_N,force_error_max_N,"
      "force_error_p999_N,haptic_hz\n";
  auto error_of = [](const std::string& text, double min_hz = 0) {
    try {
      (void)build_report(parse_csv(text, "s.csv"), "s.csv", min_hz);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error_of(header + "ok,tube,r,cpu,0,-,1,1,0,0,0,\n"), "accepted");
  for (const char* v : {"-1", "-inf", "inf", "nan"}) {
    EXPECT_EQ(error_of(header + "ok,tube,r,cpu,0,-,1,1," + v + ",0,0,1000\n"),
              std::string("s.csv: row 2, column 'force_error_rms_N': expected a finite number >= 0 or nothing, got '") + v + "'");
    EXPECT_EQ(error_of(header + "ok,tube,r,cpu,0,-,1,1,0,0,0," + v + "\n"),
              std::string("s.csv: row 2, column 'haptic_hz': expected a finite number >= 0 or nothing, got '") + v + "'");
  }
  EXPECT_EQ(error_of(header + "ok,tube,r,cpu,0,-,1,1,0,-5,0,1000\n"),
            "s.csv: row 2, column 'force_error_max_N': expected a finite number >= 0 or nothing, got '-5'");
  for (const char* ref : {"yes", "2", ""})
    EXPECT_EQ(error_of(header + "ok,tube,r,cpu," + ref + ",-,1,1,0,0,0,1000\n"),
              std::string("s.csv: row 2, column 'reference': expected 0 or 1, got '") + ref + "'");
  EXPECT_EQ(error_of("status,scene,recording,backend,reference,overrides,wall_s,real_time_factor,force_error_rms_N,"
                     "force_error_max_N,force_error_p999_N,wall_s\nok,tube,r,cpu,0,-,1,1,0,0,0,2\n"),
            "s.csv: line 1, column 'wall_s': given twice (fields 7 and 12)");
  EXPECT_EQ(error_of(header + "ok,tube,r,cpu,0,-,1,1,0,0,0,1000\n", std::nan("")),
            "--min-haptic-hz nan: expected a finite number >= 0 (haptic ticks per second)");
}

}  // namespace
}  // namespace ebh
