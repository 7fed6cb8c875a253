#pragma once
// Loading what a replay needs — scene, overrides, rates, recording — with the checks a user
// relies on (a trajectory far outside the scene is most likely a unit mistake).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/paths.hpp"
#include "io/recording.hpp"
#include "schedule/simulation.hpp"

namespace ebh {

/// A replay's --transform and --tool-transform as given: "x,y,z,rx,ry,rz", translation in the
/// scene's world unit (its top-level `unit` key), rotation vector in degrees; empty: not given.
struct ReplayTransformOptions {
  std::string world, tool;
};

struct LoadedReplay {
  std::shared_ptr<const World> world;
  Recording recording;             ///< poses in ebh's frames: every transform applied, none left stored
  std::string recording_path;
  PoseTransforms transforms;       ///< what was applied to the recording's poses (options or its attributes)
  std::vector<std::string> warnings;  ///< one line each ("REC: ..."): the unit sanity check
};

/// Under this physical rate a replay warns: the tissue follows the tool a long period late, and a
/// press's force rises with its speed (5 mm/s into an own block: 0.289 N at 20 Hz, 0.185 N at
/// 100 Hz, 0.139 N at 500 Hz); the paper steps at 60-100 Hz.
inline constexpr double kMinPlausiblePhysicalHz = 50;

/// A forceps log whose jaws never open past this is doubted: a jaw in another range (jaw_range_doubt).
inline constexpr double kJawOpenMin = 0.6;
/// A release followed by a closing sooner than this is a noisy jaw signal, not a hand (grasp_flicker).
inline constexpr double kRegraspS = 0.05;

/// A replay window that begins with the tool in the tissue (a --start inside a press; from the
/// recording's first sample, start_warning says it after the replay): the replay begins from the
/// tissue at rest around a tool already inside it, not deformed by the path that brought it there,
/// and renders another force until the tool leaves (cholecystectomy_press from 1.5 s: 0.02-0.04 N,
/// against 0.35-0.47 N replayed from 0).
struct StartInTissue {
  double t = 0;  ///< the window's first time (the recording's clock)
  /// About when the tool was last clear of the tissue before it (the recording's clock; the whole
  /// path's outline where only a window was read); nullopt: in it from the recording's start
  std::optional<double> clear_t;
};

/// How deep in the tissue the tool's tip must start for window_starts_in_tissue (m): a tip that
/// only grazes it (the hook along tube_insert's bore) renders the force of a replay through it.
inline constexpr double kStartInTissueDepth = 1e-3;

/// Whether the tool is in the tissue at the window's start, start s after the recording's first
/// sample: its tip (the pose's origin, and with `tool` the end points of its colliders, as
/// tip_inside_mesh) inside `mesh` (the tissue where the replay starts: settled under gravity), and
/// so still when moved by kStartInTissueDepth along each axis; nullopt when it is not.
std::optional<StartInTissue> window_starts_in_tissue(const Recording& rec, const TetMesh& mesh, double start,
                                                     const ToolModel* tool = nullptr);
/// The warning for it, naming the start (> 0) as `option` gave it ("--start", a gate case's
/// "start") and the time to start from (window_start_warning).
std::string start_in_tissue_warning(const StartInTissue& s, double start, const std::string& option);

/// Resolves a recording argument: an existing file, else recordings/NAME.h5 looked up in
/// $EBH_DATA_DIR, the working directory and the source tree. Throws InputError if missing.
std::string resolve_recording_path(const std::string& name_or_path);

/// The first time (s, the recording's clock) in the window [start, start + duration] (duration 0:
/// to the end) at which the tool's tip lies inside `mesh` (its rest shape), or nullopt: a replay
/// that never touched the tissue although the device went into it let the tool pass between the
/// virtual vertices or through an opening of the virtual mesh. The tip: the pose's origin, and with
/// `tool` the end points of its colliders at each sample's pose and jaw (a hook's tip reaches past
/// the origin).
std::optional<double> tip_inside_mesh(const Recording& rec, const TetMesh& mesh, double start, double duration,
                                      const ToolModel* tool = nullptr);


/// The files a replay of (scene, recording) reads, with what each is: the recording, the scene file
/// and its meshes. Cheap (the scene file is parsed, no mesh is loaded), so a command checks its
/// outputs against them before any work (io/paths.hpp check_outputs). Throws InputError like
/// load_replay_inputs for a missing file or a bad scene.
std::vector<RoleFile> replay_input_files(const std::string& scene, const std::string& recording,
                                         const std::vector<std::string>& overrides);

/// load_replay_inputs in two parts: read_replay_recording reads the recording, or the part of it
/// that `window` replays (io/recording.hpp read_recording; HDF5: one thread at a time),
/// load_replay_scene does the rest (the scene and its meshes, the checks, the world;
/// no HDF5, so replays loaded together run it on several threads). With `worlds`, replays of one
/// scene share its world where WorldCache allows.
struct RecordingFile {
  std::string path;
  Recording recording;
  std::optional<std::string> hidden;  ///< the name found another file than ebh's own (hidden_builtin)
};
RecordingFile read_replay_recording(const std::string& recording, std::optional<RecordingWindow> window = std::nullopt);
LoadedReplay load_replay_scene(RecordingFile&& recording, const std::string& scene,
                               const std::vector<std::string>& overrides, std::optional<double> haptic_hz,
                               std::optional<double> physical_hz, bool allow_outside, Backend backend,
                               const ReplayTransformOptions& transforms = {}, WorldCache* worlds = nullptr);

/// Loads scene (name or path) with --set overrides, builds the world at the given rates (the
/// scene's when empty), reads the recording, maps its poses to ebh's frames and checks that it
/// lies near the scene (unless allow_outside); with `window`, only the part a replay of that
/// window plays, whose poses the checks see. Throws InputError on any bad input.
/// The poses get the world and tool transforms (io/pose_transform.hpp) of the recording's
/// attributes and of `transforms`, each applied once: a recording that stores a tool (world)
/// transform and a --tool-transform (--transform) option is an error, since applying both would
/// move the tool twice. The unit sanity check (check_recording_scale) adds its line to warnings.
LoadedReplay load_replay_inputs(const std::string& scene, const std::string& recording,
                                const std::vector<std::string>& overrides, std::optional<double> haptic_hz,
                                std::optional<double> physical_hz, bool allow_outside,
                                Backend backend = Backend::Cpu, const ReplayTransformOptions& transforms = {},
                                std::optional<RecordingWindow> window = std::nullopt);

/// "REC: --start S: the replay starts with the tool's tip ... inside the tissue ..." (`option`
/// naming the start) for a window of `in` that starts start (> 0) s into its recording with the
/// tool in the tissue where the replay starts (its world's physical mesh, settled under gravity);
/// "" otherwise (and for start 0, which start_warning covers after the replay). `ebh replay` and
/// `ebh gate` say it.
std::string window_start_warning(const LoadedReplay& in, double start, const std::string& option);

}  // namespace ebh
