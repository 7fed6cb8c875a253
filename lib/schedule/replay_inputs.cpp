#include "schedule/replay_inputs.hpp"

#include "io/error.hpp"

namespace ebh {

std::string resolve_recording_path(const std::string& name_or_path) {
  return resolve_data_path(name_or_path, "recordings", ".h5", "recording").string();
}

std::vector<RoleFile> replay_input_files(const std::string& scene, const std::string& recording,
                                         const std::vector<std::string>& overrides) {
  std::vector<RoleFile> files{{resolve_recording_path(recording), "the recording"}};
  const SceneSpec spec = load_scene_spec(resolve_scene_path(scene), overrides);
  files.push_back({spec.file.string(), "the scene file"});
  files.push_back({spec.physical_mesh.string(), "the scene's physical mesh"});
  if (spec.virtual_mesh) files.push_back({spec.virtual_mesh->string(), "the scene's virtual mesh"});
  return files;
}

LoadedReplay load_replay_inputs(const std::string& scene, const std::string& recording,
                                const std::vector<std::string>& overrides, std::optional<double> haptic_hz,
                                std::optional<double> physical_hz, bool allow_outside,
                                Backend backend) {
  LoadedReplay r;
  r.recording_path = resolve_recording_path(recording);
  r.recording = read_recording(r.recording_path);
  Scene s = load_scene(resolve_scene_path(scene), overrides);
  const double hz_h = haptic_hz.value_or(s.spec.haptic_hz), hz_p = physical_hz.value_or(s.spec.physical_hz);
  if (!allow_outside) {
    Vec3d lo = s.physical.vertices.front(), hi = lo;
    for (const Vec3d& p : s.physical.vertices) {
      lo = cwise_min(lo, p);
      hi = cwise_max(hi, p);
    }
    // The tool's handle may start well away from the tissue; a unit mistake (cm or mm read as
    // m) puts it tens to thousands of scene sizes away.
    const double margin = std::max(norm(hi - lo), 0.1);
    if (auto err = check_recording_in_scene(r.recording, lo, hi, margin))
      throw InputError(r.recording_path + ": " + *err + " (a unit mistake? --allow-outside accepts it)");
  }
  r.world = build_world(std::move(s), hz_h, hz_p, backend);
  return r;
}

}  // namespace ebh
