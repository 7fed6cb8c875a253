#include "schedule/replay_inputs.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "core/error.hpp"
#include "core/number_text.hpp"
#include "io/import.hpp"
#include "mesh/tet_locator.hpp"
#include "tool/surface_contact.hpp"

namespace ebh {
namespace {

// The recording's own transforms and the options', each kind given once, applied to its poses.
PoseTransforms apply_replay_transforms(Recording& rec, const std::string& path, const ReplayTransformOptions& opt,
                                       const SceneSpec& scene) {
  auto take = [&](std::optional<RigidTransform>& slot, const std::optional<RigidTransform>& baked,
                  const std::string& text, const char* option, const char* attribute) {
    if (text.empty()) return;
    if (slot)
      throw InputError(std::string(option) + ": the recording " + path + " stores a " + attribute + " (" +
                       describe(*slot) + "), which replay applies; applying " + option +
                       " too would transform the poses twice: give one of them");
    if (baked)
      throw InputError(std::string(option) + ": the recording " + path + "'s poses already include a " + attribute +
                       " (baked_" + attribute + ": " + describe(*baked) + ", applied when it was made); applying " +
                       option + " too would transform them twice: import the log again with the transform you want");
    slot = parse_rigid_transform(option, text, scene.unit);
  };
  take(rec.transforms.world, rec.baked.world, opt.world, "--transform", "world_transform");
  take(rec.transforms.tool, rec.baked.tool, opt.tool, "--tool-transform", "tool_transform");
  const PoseTransforms applied = rec.transforms;
  apply_stored_transforms(rec, path);
  return applied;
}

/// Whether the tool's tip at `pose` lies inside the located mesh: the pose's origin, and with
/// `tool` the end points of its colliders at that pose and jaw.
bool tip_inside(const TetLocator& locator, const ToolModel* tool, const ToolPose& pose, double jaw) {
  if (locator.inside(pose.position)) return true;
  if (!tool) return false;
  const PosedTool posed = pose_tool(*tool, pose, jaw);
  for (int k = 0; k < posed.count; ++k)
    if (locator.inside(apply(posed.world[k], posed.shape[k].a)) || locator.inside(apply(posed.world[k], posed.shape[k].b)))
      return true;
  return false;
}

}  // namespace

std::optional<double> tip_inside_mesh(const Recording& rec, const TetMesh& mesh, double start, double duration,
                                      const ToolModel* tool) {
  if (rec.t.empty() || mesh.tets.empty()) return std::nullopt;
  const TetLocator locator(mesh);
  const double t0 = rec.start_time() + start, t1 = duration > 0 ? t0 + duration : INFINITY;
  for (std::size_t i = 0; i < rec.t.size(); ++i) {
    if (rec.t[i] < t0 || rec.t[i] > t1) continue;
    if (tool ? tip_inside(locator, tool, ToolPose{rec.position[i], rec.orientation[i]}, rec.jaw[i])
             : locator.inside(rec.position[i]))
      return rec.t[i];
  }
  return std::nullopt;
}

std::optional<StartInTissue> window_starts_in_tissue(const Recording& rec, const TetMesh& mesh, double start,
                                                     const ToolModel* tool) {
  if (rec.t.empty() || mesh.tets.empty()) return std::nullopt;
  const double t0 = rec.start_time() + start;
  const DeviceSample first = sample_at(rec, t0);
  const TetLocator locator(mesh);
  // In, by more than kStartInTissueDepth: the tip moved that far along each axis is inside too.
  bool deep = true;
  for (int k = 0; k < 7 && deep; ++k) {
    Vec3d shift{};
    if (k > 0) shift[(k - 1) / 2] = (k % 2 ? 1 : -1) * kStartInTissueDepth;
    deep = tip_inside(locator, tool, ToolPose{first.position + shift, first.orientation}, first.jaw);
  }
  if (!deep) return std::nullopt;
  StartInTissue s;
  s.t = t0;
  // Back from the start: the window's samples, then (read as a window) the whole path's outline,
  // at its samples' own times (a device's rate varies: a mean rate would misplace them), with the
  // jaw of the window's start.
  std::size_t i = rec.t.size();
  while (i > 0 && rec.t[i - 1] > t0) --i;
  for (; i > 0; --i)
    if (!tip_inside(locator, tool, ToolPose{rec.position[i - 1], rec.orientation[i - 1]}, rec.jaw[i - 1])) {
      s.clear_t = rec.t[i - 1];
      return s;
    }
  if (!rec.span || rec.span->first_row == 0) return s;
  const Recording::FileSpan& span = *rec.span;
  for (std::size_t k = std::min(span.outline.size(), span.first_row / span.outline_stride + 1); k > 0; --k) {
    const std::size_t row = (k - 1) * span.outline_stride;
    if (row >= span.first_row) continue;
    if (!tip_inside(locator, tool, ToolPose{span.outline[k - 1], span.outline_orientation[k - 1]}, first.jaw)) {
      s.clear_t = span.outline_t[k - 1];
      return s;
    }
  }
  return s;
}

std::string start_in_tissue_warning(const StartInTissue& s, double start, const std::string& option) {
  const double first = s.t - start;  // the recording's first time: the start counts from it
  std::string w = option + " " + shown_number(start) + ": the replay starts with the tool's tip " + shown_number(kStartInTissueDepth * 1e3) +
                  " mm or more inside the tissue (at the recording's t = " + fixed_text(s.t, 3) +
                  " s), which begins at rest around it, not deformed by the path that brought the tool there: until the "
                  "tool leaves it the force is not a replay's through that path (cholecystectomy_press from 1.5 s renders "
                  "0.02-0.04 N against 0.35-0.47 N)";
  if (s.clear_t)
    w += "; start at or before " + fixed_text(*s.clear_t - first, 3) + " s into the recording, where the tool was clear of it";
  return w;
}

std::string window_start_warning(const LoadedReplay& in, double start, const std::string& option) {
  if (!(start > 0)) return "";
  const World& world = *in.world;
  TetMesh settled = world.scene.physical;
  if (world.initial_physical.x.size() == settled.vertices.size()) settled.vertices = world.initial_physical.x;
  const auto s = window_starts_in_tissue(in.recording, settled, start, &world.tool);
  return s ? in.recording_path + ": " + start_in_tissue_warning(*s, start, option) : "";
}

std::string resolve_recording_path(const std::string& name_or_path) {
  return resolve_data_path(name_or_path, "recordings", ".h5", "recording").string();
}

std::vector<RoleFile> replay_input_files(const std::string& scene, const std::string& recording,
                                         const std::vector<std::string>& overrides) {
  std::vector<RoleFile> files{{resolve_recording_path(recording), "the recording"}};
  for (const SceneInputFile& file : scene_input_files(load_scene_spec(resolve_scene_path(scene), overrides)))
    files.push_back({file.path.string(), file.what});
  return files;
}

RecordingFile read_replay_recording(const std::string& recording, std::optional<RecordingWindow> window) {
  RecordingFile r;
  r.path = resolve_recording_path(recording);
  r.recording = read_recording(r.path, window);
  r.hidden = hidden_builtin(recording, r.path, "recordings", ".h5", "recording");
  return r;
}

namespace {
/// A recording that closes a forceps' jaws past the grasp threshold, replayed where nothing can
/// grasp (the scene's tool a hook, or stages.grasp off): one line saying the grasp is lost.
std::optional<std::string> grasp_lost(const Recording& rec, const SceneSpec& spec) {
  if (rec.jaw.empty()) return std::nullopt;
  const double threshold = spec.tool.forceps.grasp_threshold;
  const auto closest = std::min_element(rec.jaw.begin(), rec.jaw.end());
  if (!(*closest < threshold)) return std::nullopt;
  const bool forceps = spec.tool.kind == ToolSpec::Kind::Forceps;
  if (forceps && spec.stages.grasp) return std::nullopt;
  if (!forceps && rec.tool != "forceps") return std::nullopt;  // a hook's log need not hold a jaw
  char line[256];
  std::snprintf(line, sizeof line, "the jaws close to %.3g at the recording's t = %.3f s (below the grasp threshold %.3g), but %s: "
                "nothing is grasped", *closest, rec.t[static_cast<std::size_t>(closest - rec.jaw.begin())],
                threshold, forceps ? "stages.grasp is off" : "the scene's tool is a hook");
  return std::string(line);
}

/// A jaw signal that lets go and grasps again within kRegraspS (a noisy gripper around the
/// thresholds): each release drops the tissue and the next closing grasps it where it is then.
/// One line naming how often and the first time; nullopt for a tool without a grasp.
std::optional<std::string> grasp_flicker(const Recording& rec, const SceneSpec& spec) {
  if (spec.tool.kind != ToolSpec::Kind::Forceps || !spec.stages.grasp) return std::nullopt;
  const ForcepsSpec& f = spec.tool.forceps;
  bool closed = false;
  double released_at = -INFINITY, first = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const bool now = f.closed_at(rec.jaw[i], closed);
    if (now == closed) continue;
    closed = now;
    if (!closed) released_at = rec.t[i];
    else if (rec.t[i] - released_at < kRegraspS && count++ == 0) first = rec.t[i];
  }
  if (count == 0) return std::nullopt;
  char line[480];
  std::snprintf(line, sizeof line,
                "the jaws let go and grasp again within %g ms %zu times, first at the recording's t = %.3f s (the jaw "
                "signal crosses tool.forceps.grasp_threshold %g and release_threshold %g back and forth: a noisy "
                "gripper): each release drops the tissue; a release threshold above the noise holds on (docs/TOOLS.md, "
                "\"Grasping\")",
                kRegraspS * 1e3, count, first, f.grasp_threshold, f.release());
  return std::string(line);
}

/// A forceps log whose jaw signal is in another range than ebh's 0 closed .. 1 open, which import
/// cannot tell from its values: one that never opens past kJawOpenMin (a jaw in radians, 0 ..
/// 0.52, grasped ten times as hard: the limit for 330 ticks against 46), or one closed at its
/// first sample and for most of it (1 meaning closed: the grasps fell from 38% of the ticks to 7%
/// and the jaws closed where the hand let go). The committed grasps open to 1 and start open,
/// closed for 34% of their samples. nullopt for a scene without a grasp.
std::optional<std::string> jaw_range_doubt(const Recording& rec, const SceneSpec& spec) {
  // A window of the recording (--start, --duration) may lie inside a grasp: the whole log only.
  if (spec.tool.kind != ToolSpec::Kind::Forceps || !spec.stages.grasp || rec.jaw.empty() || !rec.whole_file())
    return std::nullopt;
  char line[400];
  // A device without a gripper (a Geomagic Touch) grasps with a button, which no jaw follows.
  if (std::all_of(rec.jaw.begin(), rec.jaw.end(), [&rec](double j) { return j == rec.jaw.front(); })) {
    std::array<std::size_t, 8> presses{};
    for (int b = 0; b < 8; ++b) presses[b] = button_presses(rec.buttons, b);
    const auto most = std::max_element(presses.begin(), presses.end());
    if (*most > 0) {
      const auto b = static_cast<int>(most - presses.begin());
      std::snprintf(line, sizeof line,
                    "the jaws stand at %.3g throughout while button %d is pressed %s: a grasp logged as a button (a "
                    "device without a gripper)? `ebh import --jaw-button %d` closes the jaws while it is pressed",
                    rec.jaw.front(), b, *most == 1 ? "once" : (std::to_string(*most) + " times").c_str(), b);
      return std::string(line);
    }
  }
  const double threshold = spec.tool.forceps.grasp_threshold;
  const double closed = static_cast<double>(std::count_if(rec.jaw.begin(), rec.jaw.end(),
                                                          [threshold](double j) { return j < threshold; })) /
                        static_cast<double>(rec.jaw.size());
  if (rec.jaw.front() < threshold && closed > 0.5) {
    std::snprintf(line, sizeof line,
                  "the jaws are closed at the first sample and for %.0f%% of the recording: a jaw logged the other way "
                  "round (1 closed, 0 open)? `ebh import --jaw-range 1,0` turns it",
                  100 * closed);
    return std::string(line);
  }
  const double widest = *std::max_element(rec.jaw.begin(), rec.jaw.end());
  if (widest < kJawOpenMin) {
    std::snprintf(line, sizeof line,
                  "the jaws never open past %.3g (1 is fully open): a jaw logged in another range (radians, the "
                  "gripper's own units)? `ebh import --jaw-range CLOSED,OPEN` maps the log's values",
                  widest);
    return std::string(line);
  }
  return std::nullopt;
}

/// The recording's tool attribute against the scene's tool: one that is neither hook nor forceps,
/// or the other kind (unless grasp_lost says so already: `grasp_lost_said`), in one line; the
/// replay moves the scene's tool.
std::optional<std::string> tool_mismatch(const Recording& rec, const SceneSpec& spec, bool grasp_lost_said) {
  const char* scene_tool = spec.tool.kind == ToolSpec::Kind::Forceps ? "forceps" : "hook";
  if (rec.tool == scene_tool || grasp_lost_said) return std::nullopt;
  if (rec.tool != "hook" && rec.tool != "forceps")
    return "attribute tool = '" + clipped(escape_unprintable(rec.tool), 80) +
           "' is neither hook nor forceps: the replay moves the scene's " + scene_tool;
  return "recorded with a " + rec.tool + " (its tool attribute) and replayed with the scene's " + scene_tool;
}

/// Rates given as options (--haptic-hz, --physical-hz) against the scene's other rate, the error
/// naming the option (the options' ranges are their validators' and build_world's; the scene's own
/// pair is the scene reader's to check).
void check_rate_options(const SceneSpec& spec, std::optional<double> haptic_hz, std::optional<double> physical_hz) {
  if (!haptic_hz && !physical_hz) return;
  const double h = haptic_hz.value_or(spec.haptic_hz), p = physical_hz.value_or(spec.physical_hz);
  const double ratio = h / p;
  // (whole_ticks_per_step takes a ratio a round-off under 1 for 1: 1000 / 1000.0000001)
  if (p > h) {
    const std::string option = physical_hz ? "--physical-hz " + shortest_text(p) : "--haptic-hz " + shortest_text(h);
    throw InputError(option + ": the physical rate is above the haptic rate (" + shortest_text(p) + " Hz > " +
                     shortest_text(h) + " Hz" + (haptic_hz ? "" : ", the scene's time.haptic_hz") +
                     (physical_hz ? "" : ", against the scene's time.physical_hz") + "): a physical step takes one tick or more");
  }
  if (!whole_ticks_per_step(h, p)) {
    const std::string ratio_text = shortest_text(ratio);  // "%g" shows 1000 / 333.333 as 3
    const std::string option = physical_hz ? "--physical-hz " + shortest_text(p) : "--haptic-hz " + shortest_text(h);
    throw InputError(option + ": the haptic rate over the physical rate must be a whole number >= 1 (ticks per " +
                     "physical step), got " + shortest_text(h) + (haptic_hz ? "" : " (the scene's time.haptic_hz)") +
                     " / " + shortest_text(p) + (physical_hz ? "" : " (the scene's time.physical_hz)") + " = " + ratio_text);
  }
}

/// A recording replayed on a scene other than the one its `scene` attribute names (by name, or as a
/// file beside it): its path was made for another geometry. Scenes derived from it keep quiet:
/// `ebh scene refine` names them NAME_lN, `ebh scene degrade` NAME_qQ.
std::optional<std::string> scene_mismatch(const Recording& rec, const std::string& recording_path,
                                          const std::filesystem::path& scene_file, const std::string& scene_name) {
  if (rec.scene.empty() || rec.scene == scene_name) return std::nullopt;
  std::string named = rec.scene;
  try {
    const std::filesystem::path file = resolve_recording_scene(rec.scene, recording_path);
    std::error_code ec;
    if (std::filesystem::equivalent(file, scene_file, ec)) return std::nullopt;
    if (named.find('/') != std::string::npos || std::filesystem::path(named).has_extension())
      named = load_scene_spec(file).name;  // a file's scene by its name
  } catch (const InputError&) {
    // a scene this machine does not have: compare by the attribute alone
  }
  if (named == scene_name || derived_scene_name(scene_name, named)) return std::nullopt;
  return "recorded for the scene '" + clipped(escape_unprintable(rec.scene), 80) + "' (its scene attribute) and replayed on '" +
         scene_name + "' (" +
         scene_file.string() + "): its path was made for another scene's geometry and tool";
}

}  // namespace

LoadedReplay load_replay_scene(RecordingFile&& recording, const std::string& scene,
                               const std::vector<std::string>& overrides, std::optional<double> haptic_hz,
                               std::optional<double> physical_hz, bool allow_outside, Backend backend,
                               const ReplayTransformOptions& transforms, WorldCache* worlds) {
  LoadedReplay r;
  r.recording_path = std::move(recording.path);
  r.recording = std::move(recording.recording);
  const std::filesystem::path scene_file = resolve_scene_path(scene);
  if (auto w = hidden_builtin(scene, scene_file, "scenarios", ".yaml", "scene")) r.warnings.push_back(*w);
  if (recording.hidden) r.warnings.push_back(*recording.hidden);
  SceneSpec spec = load_scene_spec(scene_file, overrides);
  const std::optional<std::string> lost = grasp_lost(r.recording, spec);  // said with the path's checks below
  if (auto w = scene_mismatch(r.recording, r.recording_path, scene_file, spec.name))
    r.warnings.push_back(r.recording_path + ": " + *w);
  else if (auto t = tool_mismatch(r.recording, spec, lost.has_value()))  // another scene's recording: its tool is said with it
    r.warnings.push_back(r.recording_path + ": " + *t);
  r.transforms = apply_replay_transforms(r.recording, r.recording_path, transforms, spec);
  check_rate_options(spec, haptic_hz, physical_hz);
  const double hz_h = haptic_hz.value_or(spec.haptic_hz), hz_p = physical_hz.value_or(spec.physical_hz);
  // A rate below what a device's loop or the paper's physical mesh runs at, named by the option
  // or the key that gave it.
  auto low_rate = [&](const char* option, const char* key, bool from_option, const std::string& why) {
    r.warnings.push_back((from_option ? std::string(option) : value_source(spec, key) + ": " + key) + why);
  };
  char why[360];
  if (hz_h < kDeviceHapticHz) {
    std::snprintf(why, sizeof why,
                  " %s Hz: below a haptic device's 1 kHz the rendered force of a press has not converged in the rate "
                  "(the own-data press peaks at 2.1 N at 100 Hz against 1.13 N at 1 kHz; docs/MODEL.md, \"Held loads\")",
                  shortest_text(hz_h).c_str());
    low_rate("--haptic-hz", "time.haptic_hz", haptic_hz.has_value(), why);
  }
  if (hz_p < kMinPlausiblePhysicalHz) {
    std::snprintf(why, sizeof why,
                  " %s Hz: the physical mesh answers the virtual mesh %g times a second (the paper: 60-100), so the "
                  "tissue follows the tool %g ms late and the virtual mesh alone holds it meanwhile: the force of a "
                  "press rises with its speed (5 mm/s into an own block: 0.289 N at 20 Hz, 0.185 N at 100 Hz)",
                  shortest_text(hz_p).c_str(), hz_p, 1e3 / hz_p);
    low_rate("--physical-hz", "time.physical_hz", physical_hz.has_value(), why);
  }
  if (worlds) {
    r.world = worlds->get(std::move(spec), hz_h, hz_p, backend);
  } else {
    r.world = build_world(build_scene(std::move(spec)), hz_h, hz_p, backend);
  }
  if (const auto& surface = r.world->tool.surface; surface && surface->stiffness_factor > 1) {
    // Surface contact's floor (docs/MODEL.md, "Stiffness floor") renders a k_con below it as the
    // floor: a sweep over such values measures one configuration.
    const SceneSpec& s = r.world->scene.spec;
    char line[400];
    std::snprintf(line, sizeof line,
                  ": stiffness.k_con = %g N/m is below surface contact's floor, %.4g N/m (tool.force_limit %.4g N over "
                  "1.5 x the tool's thinnest part, %.4g mm), which it renders with: every k_con below the floor renders "
                  "the same, to round-off (docs/MODEL.md, \"Stiffness floor\")",
                  s.stiffness.k_con, s.stiffness.k_con * surface->stiffness_factor, s.tool.force_limit, surface->spacing * 1e3);
    r.warnings.push_back(value_source(s, "stiffness.k_con") + line);
  }
  const BoundingBox box = bounding_box(r.world->scene.physical.vertices);
  if (!allow_outside) {
    const double margin = replay_outside_margin(box.diagonal());
    if (auto err = check_recording_in_scene(r.recording, box.lo, box.hi, margin))
      throw InputError(r.recording_path + ": " + *err +
                       (glitch_samples(r.recording.position).empty()
                            ? " (a unit mistake, or a path in the device's frame, not the scene's? `ebh import --scene` "
                              "names the likely fix, --unit or --transform; --allow-outside accepts it)"
                            : " (--allow-outside accepts it)"));
  }
  // A synthesised path's unit is its plan's (position_mm): only a device log's can be mistaken.
  if (r.recording.source != "synthetic")
    if (auto w = check_recording_scale(r.recording, box.lo, box.hi, std::nullopt))
      r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = check_recording_rate(r.recording)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = check_recording_speed(r.recording)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = check_recording_gaps(r.recording)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = check_recording_stale(r.recording)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = check_recording_turn(r.recording)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (lost) r.warnings.push_back(r.recording_path + ": " + *lost);
  if (auto w = grasp_flicker(r.recording, r.world->scene.spec)) r.warnings.push_back(r.recording_path + ": " + *w);
  if (auto w = jaw_range_doubt(r.recording, r.world->scene.spec)) r.warnings.push_back(r.recording_path + ": " + *w);
  return r;
}

LoadedReplay load_replay_inputs(const std::string& scene, const std::string& recording,
                                const std::vector<std::string>& overrides, std::optional<double> haptic_hz,
                                std::optional<double> physical_hz, bool allow_outside,
                                Backend backend, const ReplayTransformOptions& transforms,
                                std::optional<RecordingWindow> window) {
  return load_replay_scene(read_replay_recording(recording, window), scene, overrides, haptic_hz, physical_hz, allow_outside,
                           backend, transforms);
}

}  // namespace ebh
