// The replay output's provenance (docs/FORMATS.md, "Replay output"): from nothing but the output's
// root attributes and the files they name, a replay is reproduced bit for bit.
#include <gtest/gtest.h>

#include <bit>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "io/h5.hpp"
#include "io/sha256.hpp"
#include "schedule/replay_inputs.hpp"
#include "schedule/replay_output.hpp"
#include "schedule/scheduler.hpp"

using namespace ebh;

namespace {

/// The force of every tick, as the output file stores it.
struct Forces : ReplayObserver {
  std::vector<double> f;
  void on_tick(const World&, const HapticSide& h, double) override {
    f.insert(f.end(), {h.output.force.x, h.output.force.y, h.output.force.z});
  }
};

std::vector<std::string> lines(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// Replays SCENE's tube_insert window 2.8 .. 2.85 s with `overrides` and the pose `transforms` into
/// DIR/out.h5, then reproduces it from nothing but the output's attributes and the files they name,
/// and checks that every tick's force is the same bits.
void expect_reproduced_from_output(const std::string& scene, const std::vector<std::string>& overrides,
                                   const std::filesystem::path& dir, const ReplayTransformOptions& transforms = {}) {
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "out.h5").string();
  std::filesystem::remove(out);
  {
    const LoadedReplay in =
        load_replay_inputs(scene, "tube_insert", overrides, std::nullopt, std::nullopt, false, Backend::Cpu, transforms);
    ReplayOptions opt;
    opt.start = 2.8;
    opt.duration = 0.05;
    ReplayMetadata meta;
    meta.recording = in.recording_path;
    meta.start = opt.start;
    meta.duration = opt.duration;
    meta.mode = mode_name(opt.mode);
    meta.overrides = overrides;
    meta.transforms = transforms;
    meta.applied = in.transforms;
    meta.threads = split_threads(opt.mode, opt.haptic_threads);
    ReplayWriter writer(out, *in.world, meta, tick_count(*in.world, opt.duration), false);
    writer.commit(replay(*in.world, in.recording, opt, writer));
  }

  // The reproduction knows only OUT.
  const h5::File f = h5::File::open_read(out);
  for (const char* key : {"scene_file", "physical_mesh", "recording"}) {
    const std::string path = f.attr_string(key);
    EXPECT_TRUE(std::filesystem::path(path).is_absolute()) << key << ": " << path;
    EXPECT_EQ(sha256_file(path), f.attr_string(std::string(key) + "_sha256")) << key << " changed since the replay";
  }
  EXPECT_EQ(lines(f.attr_string("overrides_list")), overrides);
  // The CPU replay's threads: in all, and each side's share (split_threads).
  const ThreadSplit split = split_threads(parse_mode(f.attr_string("mode")), 0);
  EXPECT_EQ(f.attr_int("haptic_threads"), split.haptic);
  EXPECT_EQ(f.attr_int("physical_threads"), split.physical);
  EXPECT_EQ(f.attr_int("shared_physical_loops"), split.shared_physical_loops);
  EXPECT_EQ(f.attr_int("shared_virtual_loops"), split.shared_virtual_loops);
  EXPECT_GE(f.attr_int("threads"), f.attr_int("haptic_threads"));
  // The transforms: the options as given, and what the poses got (absent when nothing).
  EXPECT_EQ(f.attr_string("transform_option"), transforms.world);
  EXPECT_EQ(f.attr_string("tool_transform_option"), transforms.tool);
  EXPECT_EQ(f.has_attr("world_transform"), !transforms.world.empty());
  EXPECT_EQ(f.has_attr("tool_transform"), !transforms.tool.empty());

  // The scene from the stored YAML alone: a complete scene file with absolute mesh paths.
  const std::string yaml = f.attr_string("scene_yaml");
  const auto scene_copy = dir / "resolved.yaml";
  std::ofstream(scene_copy) << yaml;
  const ReplayTransformOptions options{f.attr_string("transform_option"), f.attr_string("tool_transform_option")};
  const LoadedReplay again = load_replay_inputs(scene_copy.string(), f.attr_string("recording"), {}, std::nullopt,
                                                std::nullopt, false, Backend::Cpu, options);
  EXPECT_EQ(resolved_scene_yaml(again.world->scene.spec), yaml);  // every key reloads to the same value
  // The stored path and overrides resolve to the same scene.
  EXPECT_EQ(resolved_scene_yaml(load_scene_spec(f.attr_string("scene_file"), lines(f.attr_string("overrides_list")))),
            yaml);
  // The applied transforms, stored in a recording's layout, are the ones the reproduction applies.
  if (again.transforms.world) {
    EXPECT_EQ(f.attr_doubles("world_transform"), to_attribute(*again.transforms.world));
  }
  if (again.transforms.tool) {
    EXPECT_EQ(f.attr_doubles("tool_transform"), to_attribute(*again.transforms.tool));
  }

  ReplayOptions opt;
  opt.mode = parse_mode(f.attr_string("mode"));
  opt.start = f.attr_double("start");
  opt.duration = f.attr_double("duration");
  opt.frames_hz = f.attr_double("frames_hz");
  Forces forces;
  replay(*again.world, again.recording, opt, forces);
  const auto stored = f.read<double>("haptic/force");
  ASSERT_EQ(stored.data.size(), forces.f.size());
  bool touched = false;
  for (std::size_t i = 0; i < forces.f.size(); ++i) {
    ASSERT_EQ(std::bit_cast<std::uint64_t>(stored.data[i]), std::bit_cast<std::uint64_t>(forces.f[i])) << "value " << i;
    touched = touched || forces.f[i] != 0;
  }
  EXPECT_TRUE(touched) << "the window should have contact forces, or the comparison proves little";
}

}  // namespace

// The committed tube, with three overrides (one of them a length, in the scene's mm, one the
// estimated Chebyshev rho) that the reproduction must pick up.
TEST(ReplayProvenance, TheOutputAloneReproducesTheReplayBitForBit) {
  const auto dir = std::filesystem::temp_directory_path() / "ebh_test_provenance";
  expect_reproduced_from_output("tube", {"stiffness.k_con=500", "tool.max_step=0.4", "solver.chebyshev_rho=auto"}, dir);
  const h5::File f = h5::File::open_read((dir / "out.h5").string());
  EXPECT_FALSE(f.has_attr("virtual_mesh"));  // tube's virtual mesh is its boundary
  EXPECT_EQ(f.attr_string("length_unit"), "m");
  EXPECT_DOUBLE_EQ(f.attr_double("max_step"), 0.4e-3);
  // The rho the step used, estimated on the mesh (it was written as the spec's unused 0.95).
  EXPECT_EQ(f.attr_int("chebyshev_rho_auto"), 1);
  EXPECT_GT(f.attr_double("chebyshev_rho"), 0.0);
  EXPECT_LT(f.attr_double("chebyshev_rho"), 1.0);
  EXPECT_NE(f.attr_double("chebyshev_rho"), 0.95);
  EXPECT_EQ(f.attr_string("pinned_regions"), "group ends");
  EXPECT_GT(f.attr_int("pinned_vertices"), 0);
  EXPECT_FALSE(f.attr_string("git_commit").empty());
  EXPECT_FALSE(f.attr_string("compiler").empty());
}

// A scene whose mesh has its own unit and a transform and whose tool has its own unit: the tube's
// mm mesh read as cm and scaled by 0.1 (the same size), turned by a hundredth of a degree about x
// and moved 0.1 mm up; the world in m, the tool in mm. The resolved YAML carries every one of them.
TEST(ReplayProvenance, AScenePlacedByMeshUnitAndTransformIsReproducedBitForBit) {
  const auto dir = std::filesystem::temp_directory_path() / "ebh_test_provenance_placed";
  std::filesystem::create_directories(dir);
  const std::string tube = (std::filesystem::path(EBH_SOURCE_DIR) / "scenarios" / "tube.msh").string();
  const auto scene = dir / "placed_tube.yaml";
  std::ofstream(scene) << "unit: m\n"
                          "mesh: {physical: " << tube << ", virtual_refine: 1, unit: cm,\n"
                          "       transform: {scale: 0.1, rotvec_deg: [0.01, 0, 0], translate: [0, 0, 0.01]}}\n"
                          "stiffness: {k_vol: 5000}\n"
                          "damping: 0.05\n"
                          "gravity: [0, 0, 0]\n"
                          "pinned: [{group: ends}]\n"
                          "tool: {unit: mm, kind: hook, shaft_radius: 2.5, shaft_length: 300, hook: {tip_length: 6, tip_radius: 1},\n"
                          "       newton_iterations: 1, max_step: 0.5}\n";
  expect_reproduced_from_output(scene.string(), {"stiffness.k_con=500"}, dir);
  const h5::File f = h5::File::open_read((dir / "out.h5").string());
  const std::string yaml = f.attr_string("scene_yaml");
  for (const char* key : {"unit: cm", "scale: 0.10000000000000001", "rotvec_deg: [0.01", "unit: mm"})
    EXPECT_NE(yaml.find(key), std::string::npos) << key << " missing from\n" << yaml;
}

// Pose transforms on replay: the hook turned 30 degrees about its shaft and the workspace moved
// 0.2 mm (the scene's unit) along x; it still touches the bore's wall. The reproduction takes the
// options from the output.
TEST(ReplayProvenance, AReplayWithPoseTransformsIsReproducedBitForBit) {
  const auto dir = std::filesystem::temp_directory_path() / "ebh_test_provenance_transforms";
  expect_reproduced_from_output("tube", {"stiffness.k_con=500"}, dir, {"0.2,0,0,0,0,0", "0,0,0,0,0,30"});
}

// The writers of a batch share their inputs' digests (ReplayMetadata::digests): each file is
// hashed once, by the first writer, and every output names the same digests as one written alone.
TEST(ReplayProvenance, WritersOfABatchHashEachInputOnce) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "ebh_test_provenance_digests";
  std::filesystem::create_directories(dir);
  const LoadedReplay in = load_replay_inputs("tube", "tube_insert", {}, std::nullopt, std::nullopt, false);
  std::map<std::string, std::string> digests;
  auto write = [&](const std::string& name, std::map<std::string, std::string>* shared) {
    const std::string out = (dir / name).string();
    std::filesystem::remove(out);
    ReplayOptions opt;
    opt.start = 2.8;
    opt.duration = 0.01;
    ReplayMetadata meta;
    meta.recording = in.recording_path;
    meta.digests = shared;
    ReplayWriter writer(out, *in.world, meta, tick_count(*in.world, opt.duration), false);
    writer.commit(replay(*in.world, in.recording, opt, writer));
    return out;
  };
  const std::string alone = write("alone.h5", nullptr), first = write("first.h5", &digests);
  EXPECT_EQ(digests.size(), 3u);  // the scene file, its mesh, the recording
  // A digest already in the map is what the next writer names: the file is not hashed again.
  const std::string mesh = std::filesystem::absolute(in.world->scene.spec.physical_mesh).lexically_normal().string();
  ASSERT_EQ(digests.count(mesh), 1u);
  digests[mesh] = "from the map";
  const std::string second = write("second.h5", &digests);
  const h5::File a = h5::File::open_read(alone), b = h5::File::open_read(first), c = h5::File::open_read(second);
  for (const char* key : {"scene_file_sha256", "physical_mesh_sha256", "recording_sha256"})
    EXPECT_EQ(a.attr_string(key), b.attr_string(key)) << key;
  EXPECT_EQ(c.attr_string("physical_mesh_sha256"), "from the map");
  EXPECT_EQ(c.attr_string("recording_sha256"), a.attr_string("recording_sha256"));
  std::filesystem::remove_all(dir);
}
