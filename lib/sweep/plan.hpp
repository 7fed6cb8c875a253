#pragma once
// A sweep plan (docs/FORMATS.md, "Sweep plan"): which replays a sweep runs. A YAML file:
//
//   scenes:                              # required, a non-empty list
//     - scene: tube                      # a name in scenarios/ or a path (relative to the plan)
//       recordings: [tube_insert]        # names or paths, or `all`: every recording whose
//                                        #   `scene` attribute names this scene
//       reference:                       # required: the converged configuration whose replay the
//         solver.method: direct          #   others are compared with ({} for the scene as it is)
//         solver.virtual_iterations: 64
//   grid:                                # every combination of these values (optional), or
//     solver.virtual_iterations: [1, 2, 4]
//   runs:                                # an explicit list of override sets (optional)
//     - {solver.virtual_iterations: 2}
//   baseline:                            # optional: the configuration the report measures
//     name: paper                        #   speed-ups and error ratios against (one more
//     set: {solver.virtual_iterations: 3}  #   configuration when no other is the same)
//   set: {stiffness.k_con: 800}          # overrides of every replay, the reference's included
//   backends: [cpu, cuda]                # default [cpu]
//   reference_backend: cpu               # where the references run (default cpu, the reference
//                                        #   backend; cuda compares within the device's numbers)
//   repetitions: 1                       # replays of each configuration (timing spread)
//   mode: async                          # async (default) or lockstep
//   start: 0                             # s into each recording (default 0)
//   duration: 2.0                        # s replayed (default: the rest of the recording)
//
// Every key is checked, and every configuration (with `set`, all its keys together, as `ebh replay
// --set` takes them) on every scene, before any replay: errors name the plan file and the key.
//
// A plan expands to runs: for each scene, recording, configuration (grid combination or list
// entry), backend and repetition one replay, plus one reference replay per scene and recording
// (on the CPU unless reference_backend says otherwise). Each run has a stable id (run_id, from the
// input files' contents) from which its output's name is made.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ebh {

/// Scene-key overrides, "dotted.key" -> value as YAML text (what `--set key=value` takes).
using Overrides = std::map<std::string, std::string>;

struct SweepScene {
  std::string scene;                                  ///< as written in the plan
  std::filesystem::path scene_file;                   ///< resolved, absolute
  std::string name;                                   ///< the scene's name (its file's stem)
  std::vector<std::filesystem::path> recordings;      ///< resolved, absolute, in plan order
  /// The SHA-256 of the scene's input files as the scene names them (scene file, meshes:
  /// scene_input_files), each file's digest under its key: what the run ids hash for the scene
  std::string inputs_sha256;
  Overrides reference;                                ///< the converged configuration
};

struct SweepPlan {
  std::filesystem::path file;                 ///< the plan file (messages)
  std::vector<SweepScene> scenes;
  std::vector<Overrides> configurations;      ///< grid combinations or list entries (at least one)
  std::vector<std::string> grid_keys;         ///< the keys that vary, in plan order
  Overrides set;                              ///< applied to every replay first
  std::optional<Overrides> baseline;          ///< the configuration speed-ups are measured against (in configurations)
  std::string baseline_name = "baseline";     ///< its label in the summary and the report
  /// The SHA-256 (hex) of each scene's input files and each recording, by path: read once with the
  /// plan (run ids, and the outputs' checks: InputDigests)
  std::map<std::string, std::string> sha256;
  /// Each recording's length (s), by path: read with the plan (the window its replays cover: run_state).
  std::map<std::string, double> recording_length;
  std::vector<std::string> backends{"cpu"};
  std::string reference_backend = "cpu";
  int repetitions = 1;
  std::string mode = "async";
  double start = 0;
  double duration = 0;                        ///< s; 0: the rest of the recording
};

/// Reads and checks a plan. Throws InputError "PLAN:LINE: key 'grid.solver.x': what is wrong".
SweepPlan read_sweep_plan(const std::filesystem::path& file);

/// The plan as a YAML file with every path absolute and every default written: what a sweep keeps
/// in its folder (DIR/plan.yaml), so `ebh sweep report DIR` and the Slurm tasks read the same plan
/// whatever their working directory. read_sweep_plan of it gives the same runs (the same ids).
std::string resolved_plan_yaml(const SweepPlan& plan);

/// The shortest text that reads back as v ("0.2", not "0.20000000000000001"): times in the
/// resolved plan, in run ids and on the replays' command lines.
std::string shortest_number(double v);

/// The most runs one plan may expand to (a grid's combinations multiply quickly).
inline constexpr std::size_t kMaxSweepRuns = 100000;

struct SweepRun {
  std::string id;                        ///< run_id(): 16 hex digits
  std::string legacy_id;                 ///< legacy_run_id(): its id in folders made before
  std::size_t scene = 0;                 ///< index into SweepPlan::scenes
  std::filesystem::path recording;       ///< absolute
  Overrides overrides;                   ///< the configuration's own (or the reference's)
  Overrides effective;                   ///< plan `set`, then `overrides`: what the replay gets
  std::string backend;
  int repetition = 0;
  bool reference = false;                ///< this is its scene and recording's reference replay
  bool baseline = false;                 ///< a run of the plan's baseline configuration
  std::string reference_id;              ///< the id of the reference it is compared with

  /// "solver.method=direct solver.virtual_iterations=64" (the run's own overrides; "-" for none).
  std::string overrides_text() const;
  /// The --set arguments of its replay: "key=value", sorted by key.
  std::vector<std::string> set_arguments() const;
};

/// The stable id of a replay: the first 16 hex digits of the SHA-256 of everything that decides
/// its output: the contents of the scene's input files (SweepScene::inputs_sha256: the scene file
/// and the meshes it names) and of the recording (their SHA-256, not their paths), mode, start,
/// duration, effective overrides (sorted by key), backend and repetition. The same
/// replay asked for twice, by two plans, after editing other parts of a plan, from another
/// checkout or on another machine, has the same id; the run's output file is named after it
/// (runs/ID.h5), which is what makes a sweep resumable and a folder's references reusable
/// elsewhere. An edited scene file, mesh or recording gives its runs new ids.
std::string run_id(const SweepPlan& plan, const std::string& scene_inputs_sha256, const std::string& recording_sha256,
                   const Overrides& effective, const std::string& backend, int repetition);

/// The id that folders made before the ids came from the files' contents gave a run: the same
/// with the scene file's and the recording's absolute paths (adopt_legacy_outputs).
std::string legacy_run_id(const SweepPlan& plan, const std::filesystem::path& scene_file,
                          const std::filesystem::path& recording, const Overrides& effective, const std::string& backend,
                          int repetition);

/// The runs of a plan: references first (one per scene and recording, on reference_backend,
/// repetition 0), then scene by scene, recording by recording, configuration, backend and
/// repetition. A configuration equal to its reference (same effective overrides and backend,
/// repetition 0) is that reference's run, not a second one. The ids hash the files' digests the plan
/// read (read_sweep_plan). Throws InputError when it exceeds kMaxSweepRuns.
std::vector<SweepRun> expand_plan(const SweepPlan& plan);

}  // namespace ebh
