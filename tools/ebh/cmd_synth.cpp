// `ebh synth PLAN -o REC.h5 [--seed N] [--rate HZ]`: a synthetic device recording from a plan of
// timed waypoints (minimum-jerk motion, physiological tremor, device quantisation). Plan format:
// docs/FORMATS.md.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "command.hpp"
#include "core/error.hpp"
#include "core/number_text.hpp"
#include "ebh/version.hpp"
#include "io/atomic.hpp"
#include "io/paths.hpp"
#include "io/recording.hpp"
#include "io/synth.hpp"
#include "options.hpp"
#include "scene/scene.hpp"

namespace {

struct SynthArgs {
  std::string plan;
  std::string output;
  std::uint64_t seed = 1;
  std::optional<double> rate_hz;  // default: the plan's rate_hz (default 1000)
};

std::string file_name(const std::string& path) {
  auto s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

/// "PLAN:LINE" for messages about the plan's key on that line ("PLAN" where the line is unknown).
std::string plan_at(const std::string& plan, int line) {
  return line > 0 ? plan + ":" + std::to_string(line) : plan;
}

/// The scene the recording names, read as a scene: a file that is none (a log, /etc/passwd,
/// a scene's mesh) is refused, since every replay of the recording would take it for its scene.
/// Its keys only: synth uses no mesh, and a scene's meshes may be made after the plan.
ebh::SceneSpec plan_scene(const ebh::SynthPlan& plan, const std::filesystem::path& scene_file) {
  try {
    return ebh::load_scene_spec(scene_file, {}, /*mesh_files_must_exist=*/false);
  } catch (const ebh::InputError& e) {
    throw ebh::InputError(plan_at(plan.file, plan.scene_line) + ": key 'scene': " + e.what() +
                          " (a recording names the scene it is replayed on)");
  }
}

void run(const SynthArgs& a) {
  ebh::check_outputs({{a.output, "the recording to write"}}, {{a.plan, "the plan"}});
  ebh::SynthPlan plan = ebh::read_plan(a.plan, a.rate_hz);
  const std::filesystem::path plan_folder = std::filesystem::path(a.plan).parent_path();
  // A scene file's path is relative to the plan; the recording names it relative to itself, where
  // readers look first (as `ebh import --scene` does), so that it names the same file.
  std::string scene;
  try {
    scene = ebh::scene_attribute_from(plan.scene, plan_folder, ebh::output_target(a.output));  // a link's target's folder
  } catch (const ebh::InputError& e) {
    throw ebh::InputError(plan_at(a.plan, plan.scene_line) + ": key 'scene': " + e.what() +
                          " (a path in a plan is relative to the plan's folder)");
  }
  // A name is stored as it is (the data folders at replay time may hold it), but one found in none
  // of today's is likely misspelt: said, not refused.
  std::filesystem::path scene_file;
  if (ebh::is_data_name(scene)) try {
      scene_file = ebh::resolve_scene_path(scene);
    } catch (const ebh::InputError& e) {
      if (plan.tool.empty())
        throw ebh::InputError(a.plan + ": key 'tool': missing, and the scene is none to take it from (" + e.what() +
                              "): write tool: hook or tool: forceps");
      std::fprintf(stderr, "ebh: warning: %s: key 'scene': %s; the recording names it all the same\n",
                   plan_at(a.plan, plan.scene_line).c_str(), e.what());
    }
  else
    scene_file = ebh::resolve_scene_path(ebh::data_reference_from(plan.scene, plan_folder));
  // The recording's tool says what instrument its poses move. A device log's is a fact about the
  // hardware, which `ebh import` records as given even against the scene's (warned); a plan's only
  // labels the path it plans for its scene, whose tool every replay moves whatever the attribute
  // says (and warns when they differ): another tool than the scene's is a slip, refused.
  if (!scene_file.empty()) {
    const ebh::SceneSpec spec = plan_scene(plan, scene_file);
    const char* scene_tool = spec.tool.kind == ebh::ToolSpec::Kind::Forceps ? "forceps" : "hook";
    if (plan.tool.empty()) plan.tool = scene_tool;  // a plan without `tool` plans for its scene's
    if (plan.tool != scene_tool)
      throw ebh::InputError(plan_at(a.plan, plan.tool_line) + ": key 'tool': " + plan.tool + ", but the scene '" + plan.scene +
                            "' (" + scene_file.string() + ") moves a " + scene_tool +
                            ": a replay on it would move a " + scene_tool + " along the path and say the tools differ; "
                            "write tool: " + scene_tool + ", or name a scene whose tool is a " + plan.tool);
  }
  for (const std::string& w : ebh::plan_rate_warnings(plan)) std::fprintf(stderr, "ebh: warning: %s\n", w.c_str());
  ebh::Recording rec = ebh::synthesize(plan, a.seed);
  rec.scene = scene;
  // The plan's file name only (no directories), so regenerated files do not depend on where the
  // repository lives.
  char rate[32];
  std::snprintf(rate, sizeof rate, "%g", plan.rate_hz);
  rec.generator = "ebh synth " + file_name(a.plan) + " --seed " + std::to_string(a.seed) + " --rate " + rate +
                  " (ebh " + ebh::kVersion + ")";
  ebh::write_recording(a.output, rec);
  std::printf("%s: %zu samples, %.3f s at %g Hz, scene %s, tool %s\n", a.output.c_str(), rec.size(), rec.duration(),
              rec.rate_hz, rec.scene.c_str(), rec.tool.c_str());
}

void setup(CLI::App& root) {
  auto args = std::make_shared<SynthArgs>();
  CLI::App* c = root.add_subcommand("synth", "Synthesise a device recording from a waypoint plan (YAML)");
  c->add_option("plan", args->plan, "plan file (YAML: scene, tool, waypoints; see docs/FORMATS.md)")->required();
  c->add_option("-o,--output", args->output, "recording to write (HDF5)")->required();
  c->add_option("--seed", args->seed, "tremor seed (same seed, same recording)")
      ->capture_default_str()
      ->check(ebh::cli::seed_number());
  c->add_option("--rate", args->rate_hz, "sample rate in Hz (default: the plan's rate_hz, else 1000)")
      ->check(ebh::cli::finite_number(0, ebh::kMaxSampleRateHz, true, "Hz"));
  c->callback([args] { run(*args); });
}

}  // namespace

EBH_COMMAND(setup);
