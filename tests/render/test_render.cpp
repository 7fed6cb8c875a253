// ebh render on a synthetic replay output written here: a flat 40 mm patch (the virtual mesh) in
// the z = 0 plane and a hook above it, the physical tool 8 mm left of the virtual tool, both
// pointing down (tool +z -> world -z). Frame 1 lowers both tools by 4 mm and dents the patch's
// centre by 3 mm; frame 2 repeats frame 1.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>

#include "core/error.hpp"
#include "io/atomic.hpp"
#include "io/h5.hpp"
#include "io/sha256.hpp"
#include "render/camera.hpp"
#include "render/image.hpp"
#include "render/offscreen.hpp"
#include "render/render_replay.hpp"
#include "render/replay_frames.hpp"
#include "render/tessellate.hpp"
#include "render/xdmf.hpp"
#include "scene/scene.hpp"

namespace fs = std::filesystem;
namespace ebh {
namespace {

struct Scratch {
  fs::path dir;
  Scratch() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          (std::string("ebh_render_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Scratch() { fs::remove_all(dir); }
  std::string operator/(const std::string& n) const { return (dir / n).string(); }
};

std::string slurp_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

constexpr int kGrid = 11;            // vertices per side of the patch
constexpr double kHalf = 0.02;       // m, half the patch's side
constexpr double kDent = 0.003;      // m, the centre vertex's displacement in frames 1 and 2
const Quatd kDown{0, 1, 0, 0};       // 180 degrees about x: tool +z -> world -z, +x stays +x
const Vec3d kPhysical0{-0.008, 0, 0.012}, kVirtual0{0.008, 0, 0.012};
const Vec3d kLower{0, 0, -0.004};

struct SyntheticOptions {
  bool frames = true;
  std::string scene = "no_such_scene_for_render_tests";
  std::string scene_file = "/nonexistent/scene.yaml";
  int bad_triangle = -1;  // >= 0: write this vertex index into the first triangle
  std::optional<std::string> overrides, overrides_list;  // the root attributes, when given
  std::optional<std::string> scene_yaml;                  // the root attribute, when given
  std::optional<double> virtual_s;                        // the root attribute (the window replayed), when given
  std::optional<std::string> scene_file_sha256;           // the root attribute, when given
  std::vector<double> t = {0.0, 0.1, 0.2};  // /frames/t
  bool triangles = true;                    // false: /mesh/virtual_triangles of shape (0, 3)
  std::string unit = "m";  // the `unit` attribute of /frames/virtual_positions and /frames/physical_positions
  // Changes to what is written: /mesh/virtual_rest (#m x 3; the frames' positions start from it as
  // it was), and /frames/virtual_positions (F x m x 3) and /frames/tool_poses (F x 2 x 7).
  std::function<void(std::vector<double>& rest)> edit_rest;
  std::function<void(std::vector<float>& positions, std::vector<double>& poses)> edit_frames;
};

void write_synthetic(const std::string& path, const SyntheticOptions& o = {}) {
  h5::File f = h5::File::create(path);
  f.set_attr("scene", o.scene);
  f.set_attr("scene_file", o.scene_file);
  f.set_attr("tool", "hook");
  f.set_attr("shaft_radius", 0.0025);
  if (o.overrides) f.set_attr("overrides", *o.overrides);
  if (o.overrides_list) f.set_attr("overrides_list", *o.overrides_list);
  if (o.scene_yaml) f.set_attr("scene_yaml", *o.scene_yaml);
  if (o.virtual_s) f.set_attr("virtual_s", *o.virtual_s);
  if (o.scene_file_sha256) f.set_attr("scene_file_sha256", *o.scene_file_sha256);
  std::vector<double> rest;
  std::vector<std::int32_t> tris;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i)
      rest.insert(rest.end(), {-kHalf + 2 * kHalf * i / (kGrid - 1), -kHalf + 2 * kHalf * j / (kGrid - 1), 0.0});
  for (int j = 0; j + 1 < kGrid; ++j)
    for (int i = 0; i + 1 < kGrid; ++i) {
      const int a = j * kGrid + i, b = a + 1, c = a + kGrid, d = c + 1;
      tris.insert(tris.end(), {a, b, d, a, d, c});
    }
  if (o.bad_triangle >= 0) tris[0] = o.bad_triangle;
  if (!o.triangles) tris.clear();
  const std::size_t m = rest.size() / 3;
  h5::Group mesh = f.create_group("mesh");
  std::vector<double> rest_written = rest;
  if (o.edit_rest) o.edit_rest(rest_written);
  mesh.write<double>("virtual_rest", rest_written, {m, 3});
  mesh.write<std::int32_t>("virtual_triangles", tris, {tris.size() / 3, 3});
  // The physical mesh: the same vertices plus one below the centre, and two tets under it.
  std::vector<double> prest = rest;
  prest.insert(prest.end(), {0.0, 0.0, -0.01});
  const std::int32_t below = static_cast<std::int32_t>(m), c0 = (kGrid / 2) * kGrid + kGrid / 2;
  const std::vector<std::int32_t> tets = {c0, c0 + 1, c0 + kGrid, below, c0, c0 - 1, c0 - kGrid, below};
  mesh.write<double>("physical_rest", prest, {m + 1, 3});
  mesh.write<std::int32_t>("physical_tets", tets, {2, 4});
  if (!o.frames) return;

  const std::size_t F = 3;
  std::vector<double> t = o.t, jaw = {1.0, 1.0, 1.0}, poses;
  std::vector<float> q, x;
  for (std::size_t k = 0; k < F; ++k) {
    const Vec3d down = k == 0 ? Vec3d{} : kLower;
    for (const Vec3d& p : {kPhysical0 + down, kVirtual0 + down})
      poses.insert(poses.end(), {p.x, p.y, p.z, kDown.w, kDown.x, kDown.y, kDown.z});
    for (std::size_t v = 0; v < m; ++v) {
      const double dz = (k > 0 && static_cast<std::int32_t>(v) == c0) ? -kDent : 0.0;
      q.insert(q.end(), {float(rest[3 * v]), float(rest[3 * v + 1]), float(rest[3 * v + 2] + dz)});
    }
    for (double p : prest) x.push_back(float(p));
  }
  if (o.edit_frames) o.edit_frames(q, poses);
  h5::Group fr = f.create_group("frames");
  fr.write<double>("t", t, {F});
  fr.write<double>("jaw", jaw, {F});
  fr.write<double>("tool_poses", poses, {F, 2, 7});
  fr.write<float>("virtual_positions", q, {F, m, 3}).set_attr("unit", o.unit);
  fr.write<float>("physical_positions", x, {F, m + 1, 3}).set_attr("unit", o.unit);
}

std::string read_file(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The centre of the hook's bent tip capsule, (L/2, 0, L) in the tool frame, in the world.
Vec3d tip_centre(const Vec3d& origin) {
  const double L = HookSpec{}.tip_length;  // the fallback tool is a default hook
  return origin + rotate(kDown, Vec3d{L / 2, 0, L});
}

/// Frames of 64 x 48 pixels: the tests of what a render does with its folder need no more.
RenderOptions small_frames() {
  RenderOptions o;
  o.width = 64;
  o.height = 48;
  return o;
}

#define REQUIRE_OSMESA() \
  if (!have_osmesa()) GTEST_SKIP() << kNoOsmesa

/// The InputError `open_replay_frames(path)` throws ("" when it opens).
std::string open_error(const std::string& path) {
  try {
    open_replay_frames(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Without OSMesa: reading, cameras, tessellation, XDMF

TEST(ReplayFrames, ReadsTheSyntheticFile) {
  Scratch s;
  write_synthetic(s / "r.h5");
  const ReplayFrames f = open_replay_frames(s / "r.h5");
  EXPECT_EQ(f.frame_count(), 3u);
  EXPECT_EQ(f.virtual_vertices(), std::size_t(kGrid * kGrid));
  EXPECT_EQ(f.triangles.size(), std::size_t(2 * (kGrid - 1) * (kGrid - 1)));
  EXPECT_EQ(f.physical_tets, 2u);
  std::vector<Vec3f> q;
  f.read_virtual_positions(1, q);
  const int c0 = (kGrid / 2) * kGrid + kGrid / 2;
  EXPECT_FLOAT_EQ(q[c0].z, float(-kDent));
  EXPECT_DOUBLE_EQ(f.poses[1][0].position.z, kPhysical0.z + kLower.z);
}

// The --set overrides the scene is reloaded with: one per line in overrides_list; files written
// before it have only the space-joined `overrides`, split where a piece starts a new key.
TEST(ReplayFrames, ReadsTheOverridesListAndTheOlderJoinedForm) {
  Scratch s;
  SyntheticOptions o;
  o.overrides = "gravity=[0, 0, -1] description=a b";
  o.overrides_list = "gravity=[0, 0, -1]\ndescription=a b";
  write_synthetic(s / "list.h5", o);
  EXPECT_EQ(open_replay_frames(s / "list.h5").overrides,
            (std::vector<std::string>{"gravity=[0, 0, -1]", "description=a b"}));
  o.overrides = "gravity=[0, 0, -1] stiffness.k_con=800";
  o.overrides_list.reset();
  write_synthetic(s / "joined.h5", o);
  EXPECT_EQ(open_replay_frames(s / "joined.h5").overrides,
            (std::vector<std::string>{"gravity=[0, 0, -1]", "stiffness.k_con=800"}));
}

TEST(ReplayFrames, FileWithoutFramesIsAnInputError) {
  Scratch s;
  SyntheticOptions o;
  o.frames = false;
  write_synthetic(s / "noframes.h5", o);
  try {
    open_replay_frames(s / "noframes.h5");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("noframes.h5: /frames: no mesh snapshots"), std::string::npos) << e.what();
  }
  EXPECT_THROW(render_replay(s / "noframes.h5", s / "out", RenderOptions{}), InputError);
  EXPECT_THROW(write_xdmf(s / "noframes.h5"), InputError);
  EXPECT_FALSE(fs::exists(s / "noframes.xdmf"));
}

// A device recording was said to be a replay without snapshots ("replay with --frames-hz"): it is
// named a recording, as `ebh metrics` names it, by render and by --xdmf-only.
TEST(ReplayFrames, ARecordingIsSaidToBeOne) {
  Scratch s;
  h5::File::create(s / "rec.h5").create_group("trajectory");
  const std::string said = s / "rec.h5" + ": a device recording (/trajectory), not a replay output (/frames): replay it "
                                          "first, with mesh snapshots (ebh replay SCENE " + s / "rec.h5" +
                           " -o OUT.h5 --frames-hz N)";
  EXPECT_EQ(open_error(s / "rec.h5"), said);
  try {
    write_xdmf(s / "rec.h5");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), said);
  }
}

TEST(ReplayFrames, TriangleIndexOutOfRangeNamesTheDataset) {
  Scratch s;
  SyntheticOptions o;
  o.bad_triangle = 5000;
  write_synthetic(s / "bad.h5", o);
  try {
    open_replay_frames(s / "bad.h5");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.h5: /mesh/virtual_triangles: row 0 refers to vertex 5000"),
              std::string::npos)
        << e.what();
  }
}

// Positions rewritten in mm by another program (`unit = mm`) were drawn 1000 times too large, the
// tissue far out of view, without a word; a unit other than the SI one `ebh replay` writes is
// refused, as `ebh metrics` refuses it, and a render of such a file writes nothing.
TEST(ReplayFrames, PositionsInAnotherUnitAreRefused) {
  Scratch s;
  SyntheticOptions o;
  o.unit = "mm";
  write_synthetic(s / "mm.h5", o);
  EXPECT_EQ(open_error(s / "mm.h5"),
            s / "mm.h5" + ": /frames/virtual_positions: has unit 'mm'; expected 'm' (SI, docs/FORMATS.md)");
  EXPECT_THROW(render_replay(s / "mm.h5", s / "out", small_frames()), InputError);
  EXPECT_FALSE(fs::exists(s / "out"));
  o.unit = "m";
  write_synthetic(s / "m.h5", o);
  EXPECT_EQ(open_error(s / "m.h5"), "");
}

// Frame times running backwards or holding NaN were drawn in file order (a PNG titled `t = nan
// s`); an empty triangle list drew the tools alone. Each is refused naming the dataset.
TEST(ReplayFrames, TimesThatDoNotIncreaseAndAnEmptySurfaceAreRefused) {
  Scratch s;
  SyntheticOptions o;
  o.t = {0.0, 0.2, 0.1};
  write_synthetic(s / "back.h5", o);
  EXPECT_EQ(open_error(s / "back.h5"), s / "back.h5" + ": /frames/t: is not strictly increasing at index 2");
  o.t = {0.0, 0.1, 0.1};
  write_synthetic(s / "same.h5", o);
  EXPECT_EQ(open_error(s / "same.h5"), s / "same.h5" + ": /frames/t: is not strictly increasing at index 2");
  o.t = {0.0, std::nan(""), 0.2};
  write_synthetic(s / "nan.h5", o);
  EXPECT_EQ(open_error(s / "nan.h5"), s / "nan.h5" + ": /frames/t: nan at index 1: expected finite times");
  EXPECT_THROW(render_replay(s / "nan.h5", s / "out", small_frames()), InputError);
  EXPECT_FALSE(fs::exists(s / "out"));
  o = {};
  o.triangles = false;
  write_synthetic(s / "empty.h5", o);
  EXPECT_EQ(open_error(s / "empty.h5"),
            s / "empty.h5" + ": /mesh/virtual_triangles: no triangles: the virtual mesh has no surface to draw");
}

TEST(ReplayFrames, NotAnHdf5FileIsAnInputError) {
  Scratch s;
  std::ofstream(s / "text.h5") << "not hdf5\n";
  EXPECT_THROW(open_replay_frames(s / "text.h5"), InputError);
  EXPECT_THROW(open_replay_frames(s / "missing.h5"), InputError);
}

TEST(Camera, SceneFileCameraIsUsedWhenTheSceneLoads) {
  Scratch s;
  SyntheticOptions o;
  o.scene_file = std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml";  // camera eye (0, -100, 50) mm
  write_synthetic(s / "r.h5", o);
  const ReplayFrames f = open_replay_frames(s / "r.h5");
  std::vector<std::string> warnings;
  const auto scene = find_replay_scene(f, warnings);
  ASSERT_TRUE(scene.has_value());
  EXPECT_TRUE(warnings.empty());
  std::string source;
  const ViewCamera c = choose_camera("scene", scene, bounds_of(f.virtual_rest), 4.0 / 3.0, source);
  // The file says millimetres; the loader gives metres (exact decimal scaling within 1e-15).
  EXPECT_NEAR(c.eye.y, -0.1, 1e-15);
  EXPECT_NEAR(c.eye.z, 0.05, 1e-15);
  EXPECT_DOUBLE_EQ(c.fov_deg, 45.0);
  EXPECT_NE(source.find("cube.yaml"), std::string::npos);
  EXPECT_EQ(replay_tool(f, scene).spec.kind, ToolSpec::Kind::Forceps);  // cube.yaml's tool
}

// The tool and camera drawn are those of the scene the replay ran (its scene_yaml), not of what
// the scene file says now: edited after the replay (another tool), gone, or its mesh gone too (a
// project moved: the output holds the meshes it draws).
TEST(Camera, TheSceneTheReplayRanIsDrawnNotTheFileAsItIsNow) {
  Scratch s;
  const std::string cube = std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml";  // a forceps, eye (0, -100, 50) mm
  fs::create_directories(s / "scene");
  fs::create_directories(s / "mesh");
  fs::copy_file(std::string(EBH_TEST_DATA_DIR) + "/mesh/cube22.msh", s / "mesh/cube22.msh");
  const std::string copy = s / "scene/cube.yaml";
  fs::copy_file(cube, copy);
  SyntheticOptions o;
  o.scene_file = copy;
  o.scene_yaml = resolved_scene_yaml(load_scene_spec(copy, {"camera.eye=[0, -200, 50]"}));
  write_synthetic(s / "r.h5", o);
  std::string text = slurp_file(copy);
  const auto at = text.find("kind: forceps");
  ASSERT_NE(at, std::string::npos);
  std::ofstream(copy, std::ios::binary) << text.replace(at, 13, "kind: hook   ");  // edited since
  for (const std::string gone : {"nothing", "the scene file", "its mesh"}) {
    if (gone == "the scene file") fs::remove(copy);
    if (gone == "its mesh") fs::remove(s / "mesh/cube22.msh");
    const ReplayFrames f = open_replay_frames(s / "r.h5");
    std::vector<std::string> warnings;
    const auto scene = find_replay_scene(f, warnings);
    ASSERT_TRUE(scene.has_value()) << gone;
    EXPECT_TRUE(warnings.empty()) << gone;
    EXPECT_EQ(replay_tool(f, scene).spec.kind, ToolSpec::Kind::Forceps) << gone;
    std::string source;
    EXPECT_NEAR(choose_camera("scene", scene, bounds_of(f.virtual_rest), 1.0, source).eye.y, -0.2, 1e-15) << gone;
  }
}

// An output without its scene (written before it was stored) is drawn with the scene file; one
// edited since the replay (its SHA-256 no longer the output's) is said.
TEST(Camera, AnOutputWithoutItsSceneSaysTheSceneFileChangedSince) {
  Scratch s;
  const std::string copy = s / "cube.yaml";
  std::string text = slurp_file(std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml");
  text.replace(text.find("../mesh/"), 8, std::string(EBH_TEST_DATA_DIR) + "/mesh/");  // the mesh where it is
  std::ofstream(copy, std::ios::binary) << text;
  SyntheticOptions o;
  o.scene_file = copy;
  o.scene_file_sha256 = sha256_file(copy);
  write_synthetic(s / "same.h5", o);
  o.scene_file_sha256 = std::string(64, '0');
  write_synthetic(s / "edited.h5", o);
  std::vector<std::string> warnings;
  ASSERT_TRUE(find_replay_scene(open_replay_frames(s / "same.h5"), warnings).has_value());
  EXPECT_TRUE(warnings.empty()) << warnings[0];
  ASSERT_TRUE(find_replay_scene(open_replay_frames(s / "edited.h5"), warnings).has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], std::string(s / "edited.h5") + ": the scene file " + copy +
                             " changed since the replay (its SHA-256 is not the output's scene_file_sha256): "
                             "rendered with it as it is now");
}

// A stored scene that does not load (a damaged attribute) falls back to the scene file, saying so:
// that file as it is now may not be the scene the replay ran.
TEST(Camera, AStoredSceneThatDoesNotLoadIsSaidWhenTheFileStandsIn) {
  Scratch s;
  SyntheticOptions o;
  o.scene_file = std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml";
  o.scene_yaml = "mesh: [unclosed";
  write_synthetic(s / "r.h5", o);
  const ReplayFrames f = open_replay_frames(s / "r.h5");
  std::vector<std::string> warnings;
  const auto scene = find_replay_scene(f, warnings);
  ASSERT_TRUE(scene.has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find(": its scene_yaml does not load ("), std::string::npos) << warnings[0];
  // The stored text's error names it (OUT.h5:scene_yaml:LINE), not the scene file, which may say otherwise.
  EXPECT_NE(warnings[0].find("(" + std::string(s / "r.h5") + ":scene_yaml:1: "), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("): rendered with the scene file " + o.scene_file + " as it is now"), std::string::npos)
      << warnings[0];
}

TEST(Camera, MissingSceneFallsBackToTheBoundingBoxWithAWarning) {
  Scratch s;
  write_synthetic(s / "r.h5");
  const ReplayFrames f = open_replay_frames(s / "r.h5");
  std::vector<std::string> warnings;
  const auto scene = find_replay_scene(f, warnings);
  EXPECT_FALSE(scene.has_value());
  ASSERT_EQ(warnings.size(), 1u);
  std::string source;
  const Bounds b = bounds_of(f.virtual_rest);
  const ViewCamera c = choose_camera("scene", scene, b, 1.0, source);
  EXPECT_NE(source.find("bounding box"), std::string::npos);
  // Every corner of the patch projects inside the image.
  for (double x : {-kHalf, kHalf})
    for (double y : {-kHalf, kHalf}) {
      const auto p = project(c, 200, 200, {x, y, 0});
      ASSERT_TRUE(p.has_value());
      EXPECT_GT((*p)[0], 0);
      EXPECT_LT((*p)[0], 200);
      EXPECT_GT((*p)[1], 0);
      EXPECT_LT((*p)[1], 200);
    }
  EXPECT_THROW(choose_camera("fisheye", scene, b, 1.0, source), InputError);
}

// An `up` parallel to the view direction in decimal ([0, 76, -45.7] mm for a view along (0, 76,
// -45.7) mm) differs from it by round-off only: its cross product with the view direction, of
// round-off size, was normalised into an arbitrary side and the image came out upside down. It takes the
// fallback up (world z) as an up along the view exactly does.
TEST(Camera, AnUpAlongTheViewUpToRoundOffTakesTheFallback) {
  ViewCamera along;
  along.eye = Vec3d{1500, -1276, 855.7} * 1e-3;  // a scene camera in mm, read into metres
  along.target = Vec3d{1500, -1200, 810} * 1e-3;
  along.up = normalized(Vec3d{0, 76, -45.7});
  ASSERT_LT(norm(cross(normalized(along.target - along.eye), along.up)), 1e-12);  // parallel but for round-off
  ViewCamera upright = along;
  upright.up = {0, 0, 1};
  const auto a = view_matrix(along), b = view_matrix(upright);
  // Each entry is a unit vector's component or a dot with the eye (|eye| < 2.3 m): 1e-12 is a
  // few hundred double ulps of either.
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(a[i], b[i], 1e-12) << i;
}

// An eye at the target is named by the override that put it there, whichever of the two it set:
// `--set camera.eye=...` was reported as the scene file's camera.target.
TEST(Camera, AnEyeAtTheTargetNamesTheOverrideThatPutItThere) {
  const std::string cube = std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml";  // eye (0, -100, 50), target (5, 5, 5) mm
  auto error_of = [&](const std::string& override_text) -> std::string {
    try {
      load_scene_spec(cube, {override_text});
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const std::string same = "camera.eye and camera.target are the same point: the camera looks nowhere";
  EXPECT_EQ(error_of("camera.eye=[5, 5, 5]"), "--set 'camera.eye=[5, 5, 5]': key 'camera.eye': " + same);
  EXPECT_EQ(error_of("camera.target=[0, -100, 50]"), "--set 'camera.target=[0, -100, 50]': key 'camera.target': " + same);
}

TEST(Camera, PresetsLookAtTheCentreFromTheirSide) {
  Bounds b{{-1, -2, -3}, {3, 2, 1}};
  const Vec3d c = b.centre();
  EXPECT_GT(preset_camera("top", b, 1.0).eye.z, c.z + b.radius());
  EXPECT_LT(preset_camera("front", b, 1.0).eye.y, c.y - b.radius());
  EXPECT_GT(preset_camera("side", b, 1.0).eye.x, c.x + b.radius());
  const ViewCamera iso = preset_camera("iso", b, 1.0);
  // The target projects to the image centre (to rounding).
  const auto p = project(iso, 100, 80, iso.target);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p)[0], 50.0, 1e-9);
  EXPECT_NEAR((*p)[1], 40.0, 1e-9);
  // Image up is world +z for front: a point above the target lands above the centre.
  const ViewCamera front = preset_camera("front", b, 1.0);
  EXPECT_LT((*project(front, 100, 100, c + Vec3d{0, 0, 1}))[1], 50.0);
  EXPECT_GT((*project(front, 100, 100, c + Vec3d{1, 0, 0}))[0], 50.0);  // +x to the right
}

TEST(Tessellate, ToolSurfacesLieOnTheCollidersWithOutwardNormals) {
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    ToolSpec spec;
    spec.kind = kind;
    const ToolModel tool = build_tool(spec);
    const PosedTool posed = pose_tool(tool, ToolPose{{0.01, -0.02, 0.03}, normalized(Quatd{0.9, 0.1, -0.3, 0.2})}, 0.7);
    for (int i = 0; i < posed.count; ++i) {
      TriangleSoup soup;
      tessellate(posed.shape[i], posed.world[i], 32, soup);
      ASSERT_GT(soup.triangles(), 0u);
      Vec3d area_normal{};
      for (std::size_t k = 0; k < soup.position.size(); ++k) {
        const Vec3d p = apply_inverse(posed.world[i], static_cast<Vec3d>(soup.position[k]));
        // Vertices are on the surface up to float32 storage (~1e-7 relative of a 0.3 m shaft).
        EXPECT_LT(std::abs(query_local(posed.shape[i], p).sd), 1e-6);
      }
      for (std::size_t k = 0; k < soup.position.size(); k += 3) {
        const auto a = static_cast<Vec3d>(soup.position[k]), b = static_cast<Vec3d>(soup.position[k + 1]),
                   c = static_cast<Vec3d>(soup.position[k + 2]);
        const Vec3d face = cross(b - a, c - a);
        area_normal += face;
        // At the centroid (inside a face, away from the edges where the outward normal is not
        // unique) the facet and its vertex normals point out: within the 11.25 degree facet angle
        // of 32 segments, so cos > 0.9 is a margin, not a fit.
        const Vec3d centroid = apply_inverse(posed.world[i], (a + b + c) / 3.0);
        const Vec3d out = posed.world[i].R * query_local(posed.shape[i], centroid).normal;
        if (norm(face) > 0) { EXPECT_GT(dot(normalized(face), out), 0.9); }
        const Vec3d vn = static_cast<Vec3d>(soup.normal[k]) + static_cast<Vec3d>(soup.normal[k + 1]) +
                         static_cast<Vec3d>(soup.normal[k + 2]);
        EXPECT_GT(dot(normalized(vn), out), 0.9);
      }
      // A closed surface: the area-weighted normals sum to zero (float rounding of the vertices).
      EXPECT_LT(norm(area_normal), 1e-8);
    }
  }
}

TEST(Xdmf, IndexesEveryFrameOfBothMeshes) {
  Scratch s;
  write_synthetic(s / "r.h5");
  const std::string x = write_xdmf(s / "r.h5");
  EXPECT_EQ(x, s / "r.xdmf");
  const std::string text = read_file(x);
  EXPECT_NE(text.find("<Xdmf Version=\"3.0\">"), std::string::npos);
  std::size_t times = 0, temporal = 0;
  for (std::size_t p = 0; (p = text.find("<Time Value=", p)) != std::string::npos; ++p) ++times;
  for (std::size_t p = 0; (p = text.find("CollectionType=\"Temporal\"", p)) != std::string::npos; ++p) ++temporal;
  EXPECT_EQ(times, 6u);  // 3 frames x 2 meshes
  EXPECT_EQ(temporal, 2u);
  EXPECT_NE(text.find("r.h5:/frames/virtual_positions"), std::string::npos);
  EXPECT_NE(text.find("r.h5:/mesh/physical_tets"), std::string::npos);
  EXPECT_NE(text.find("TopologyType=\"Tetrahedron\" NumberOfElements=\"2\""), std::string::npos);
  EXPECT_NE(text.find("<Time Value=\"0.2\"/>"), std::string::npos);
  for (const auto& e : fs::directory_iterator(s.dir))
    EXPECT_FALSE(is_partial_output(e.path().string())) << e.path();
}

TEST(Image, PngRoundTripAndDownsample) {
  Scratch s;
  Image img(4, 2, {10, 20, 30});
  img.set(3, 1, {200, 100, 0});
  write_png(s / "a.png", img, {{"Comment", "test"}});
  const Image back = read_png(s / "a.png");
  EXPECT_EQ(back.width, 4);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.rgb, img.rgb);
  const Image half = downsample(img, 2);
  EXPECT_EQ(half.width, 2);
  EXPECT_EQ(half.at(1, 0), (Rgb{58, 40, 23}));  // (3 * (10,20,30) + (200,100,0)) / 4, rounded
  EXPECT_THROW(read_png(s / "missing.png"), InputError);
}

// ---------------------------------------------------------------------------------------------
// With OSMesa

TEST(Render, WithoutOsmesaTheMessageSaysWhatToInstall) {
  if (have_osmesa()) GTEST_SKIP() << "this build has OSMesa";
  Scratch s;
  write_synthetic(s / "r.h5");
  try {
    render_replay(s / "r.h5", s / "out", RenderOptions{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), kNoOsmesa);
  }
}

TEST(Render, ToolsAppearWhereTheCameraProjectsThem) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o;
  o.width = 320;
  o.height = 240;
  o.camera = "front";
  o.time_bar = false;
  const RenderSummary r = render_replay(s / "r.h5", s / "out", o);
  ASSERT_EQ(r.files.size(), 3u);
  EXPECT_EQ(r.camera_source, "preset front");
  const Image img = read_png(r.files[0]);
  ASSERT_EQ(img.width, 320);
  ASSERT_EQ(img.height, 240);
  auto pixel_of = [&](Vec3d p) {
    const auto q = project(r.camera, o.width, o.height, p);
    EXPECT_TRUE(q.has_value());
    return img.at(static_cast<int>((*q)[0]), static_cast<int>((*q)[1]));
  };
  // The physical tool's tip: translucent green over the background.
  const Rgb green = pixel_of(tip_centre(kPhysical0));
  EXPECT_GT(green.g, green.r + 25) << int(green.r) << " " << int(green.g) << " " << int(green.b);
  EXPECT_GT(green.g, green.b + 25);
  // The virtual tool's tip: opaque grey, darker than the background.
  const Rgb grey = pixel_of(tip_centre(kVirtual0));
  EXPECT_LE(std::abs(int(grey.r) - int(grey.g)), 4) << int(grey.r) << " " << int(grey.g) << " " << int(grey.b);
  EXPECT_LE(std::abs(int(grey.g) - int(grey.b)), 6);
  EXPECT_LT(grey.r, 235);
  // Far from everything: the plain background.
  EXPECT_EQ(img.at(2, 2), RenderStyle{}.background);
}

TEST(Render, TissueIsShadedAndFramesDiffer) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o;
  o.width = 200;
  o.height = 200;
  o.camera = "top";
  const RenderSummary r = render_replay(s / "r.h5", s / "out", o);
  ASSERT_EQ(r.files.size(), 3u);
  const Image a = read_png(r.files[0]), b = read_png(r.files[1]), c = read_png(r.files[2]);
  // A corner of the patch, away from the tools: the tissue's pink.
  const auto q = project(r.camera, 200, 200, {0.7 * kHalf, 0.7 * kHalf, 0});
  const Rgb t = a.at(int((*q)[0]), int((*q)[1]));
  EXPECT_GT(t.r, t.g + 30) << int(t.r) << " " << int(t.g) << " " << int(t.b);
  EXPECT_NE(t, RenderStyle{}.background);
  EXPECT_NE(a.rgb, b.rgb);  // the tools moved and the patch dented
  // Frames 1 and 2 hold the same state at different times: they differ only in the time bar.
  const int bar = std::max(2, 200 / 150);
  for (int row = 0; row < 200 - bar; ++row)
    for (int col = 0; col < 200; ++col) ASSERT_EQ(b.at(col, row), c.at(col, row)) << col << "," << row;
  // The PNG names the GL renderer that drew it (frames are the same bytes for one renderer only).
  std::ifstream in(r.files[0], std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(bytes.find(std::string("Source") + '\0' + "OSMesa "), std::string::npos);
}

TEST(Render, SizeAndCameraAreHonoured) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o;
  o.width = 160;
  o.height = 90;
  o.every = 2;
  o.camera = "side";
  const RenderSummary side = render_replay(s / "r.h5", s / "side", o);
  ASSERT_EQ(side.files.size(), 2u);  // frames 0 and 2
  const Image a = read_png(side.files[0]);
  EXPECT_EQ(a.width, 160);
  EXPECT_EQ(a.height, 90);
  o.camera = "iso";
  const Image b = read_png(render_replay(s / "r.h5", s / "iso", o).files[0]);
  EXPECT_NE(a.rgb, b.rgb);
  o.camera = "fisheye";
  EXPECT_THROW(render_replay(s / "r.h5", s / "bad", o), InputError);
  o.camera = "iso";
  o.width = 5;
  EXPECT_THROW(render_replay(s / "r.h5", s / "bad", o), InputError);
}

// A scene camera that sees none of the tissue (here looking away from it) rendered background-only
// frames without a word; the frames are still written, and one warning counts them and says what
// to check. A camera that sees the tissue gives no such warning.
TEST(Render, FramesThatShowNoTissueAreCountedInAWarning) {
  REQUIRE_OSMESA();
  Scratch s;
  SyntheticOptions o;
  const std::string cube = std::string(EBH_TEST_DATA_DIR) + "/scene/cube.yaml";
  o.scene_yaml = resolved_scene_yaml(load_scene_spec(cube, {"camera.target=[0, -200, 50]"}));  // eye (0, -100, 50) mm
  write_synthetic(s / "away.h5", o);
  const RenderSummary away = render_replay(s / "away.h5", s / "away", small_frames());
  EXPECT_EQ(away.files.size(), 3u);
  ASSERT_EQ(away.warnings.size(), 1u);
  EXPECT_EQ(away.warnings[0], s / "away.h5" + ": 3 of 3 frames show no tissue: the camera (scene " + s / "away.h5" +
                                  ":scene_yaml) sees none of the virtual mesh; check camera.eye, camera.target and "
                                  "camera.fov_deg");
  o.scene_yaml = resolved_scene_yaml(load_scene_spec(cube));  // looking at the patch
  write_synthetic(s / "seen.h5", o);
  EXPECT_TRUE(render_replay(s / "seen.h5", s / "seen", small_frames()).warnings.empty());
}

// Positions and poses no replay writes (a damaged or edited file, a run that blew up) are left out
// of what is drawn, with one warning for each kind naming the dataset and the first vertex or row,
// and the camera and the displacement colours stay those of the rest: a rest vertex at 1e30 m
// framed a box 1e30 m across (the tissue a dot), a frame's vertex there put the colour map's top at
// 1e30 m (all the tissue at rest's blue), and a NaN quaternion drew the tool unrotated.
TEST(Render, PositionsAndPosesNotFiniteOrFarOffTheMeshAreLeftOutAndSaid) {
  REQUIRE_OSMESA();
  Scratch s;
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  write_synthetic(s / "clean.h5");
  SyntheticOptions o;
  o.edit_rest = [](std::vector<double>& rest) {
    rest[3 * 5] = nan;    // vertex 5, (0, -0.02, 0)
    rest[3 * 7] = 1e30;   // vertex 7, (0.008, -0.02, 0)
  };
  o.edit_frames = [](std::vector<float>& q, std::vector<double>& poses) {
    q[3 * (2 * kGrid * kGrid + 9)] = 1e30f;  // frame 2, vertex 9
    poses[14 * 1 + 7] = nan;                 // frame 1, the virtual tool's x
    poses[14 * 2 + 3] = nan;                 // frame 2, the physical tool's quaternion's w
  };
  write_synthetic(s / "bad.h5", o);
  RenderOptions r = small_frames();
  r.camera = "iso";
  r.color_by = ColorBy::Displacement;
  const RenderSummary clean = render_replay(s / "clean.h5", s / "clean", r);
  const RenderSummary bad = render_replay(s / "bad.h5", s / "bad", r);
  ASSERT_EQ(bad.files.size(), 3u);
  const std::string file = s / "bad.h5";
  const std::vector<std::string> expected = {
      file + ": /mesh/virtual_rest: vertex 5 at (nan, -0.02, 0) m is not finite: the camera frames the mesh and the "
             "displacement colours are measured without it",
      file + ": /mesh/virtual_rest: vertex 7 at (1e+30, -0.02, 0) m lies more than 1000 times the mesh's median "
             "distance from its centre (",
      file + ": /frames/virtual_positions: 1 frame holds positions more than 1000 times the mesh's median distance from "
             "its centre (a damaged file or a run that blew up; the first: frame 2, vertex 9 at (1e+30, -0.02, 0) m): "
             "their triangles were left out, and the displacement colours measured without them",
      file + ": /frames/tool_poses: 2 rows hold no pose (a value that is not finite, or a zero quaternion; the first: "
             "frame 1, row 1 (the virtual tool) at (nan, 0, 0.008) m, quaternion (0, 1, 0, 0)): the tool is left out of "
             "the frame where its pose is"};
  for (const std::string& e : expected) {
    const bool said = std::any_of(bad.warnings.begin(), bad.warnings.end(),
                                  [&](const std::string& w) { return w.rfind(e, 0) == 0; });
    EXPECT_TRUE(said) << "no warning starting '" << e << "' among:\n"
                      << ::testing::PrintToString(bad.warnings);
  }
  for (const std::string& w : bad.warnings) EXPECT_EQ(w.find('\n'), std::string::npos) << w;
  // The clean file says only that its scene is missing; the damaged one that and the four above.
  EXPECT_EQ(clean.warnings.size(), 1u) << ::testing::PrintToString(clean.warnings);
  EXPECT_EQ(bad.warnings.size(), clean.warnings.size() + expected.size()) << ::testing::PrintToString(bad.warnings);
  // The camera frames the plausible rest mesh (its corners are all there), the colours span the dent.
  EXPECT_EQ(bad.camera.eye, clean.camera.eye);
  EXPECT_EQ(bad.camera.target, clean.camera.target);
  EXPECT_EQ(bad.camera.z_far, clean.camera.z_far);
  EXPECT_NEAR(bad.displacement_range, kDent, 1e-9);
  // Frame 0 holds nothing left out: drawn as the clean file's.
  EXPECT_EQ(read_file(bad.files[0]), read_file(clean.files[0]));
}

TEST(Render, IsDeterministic) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o;
  o.width = 240;
  o.height = 180;
  o.camera = "iso";
  const RenderSummary a = render_replay(s / "r.h5", s / "a", o);
  const RenderSummary b = render_replay(s / "r.h5", s / "b", o);
  ASSERT_EQ(a.files.size(), b.files.size());
  for (std::size_t i = 0; i < a.files.size(); ++i) EXPECT_EQ(read_file(a.files[i]), read_file(b.files[i])) << i;
}

TEST(Render, DisplacementColouringStatesItsRangeAndDrawsALegend) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o;
  o.width = 300;
  o.height = 200;
  o.camera = "top";
  o.color_by = ColorBy::Displacement;
  const RenderSummary r = render_replay(s / "r.h5", s / "out", o);
  // The dent is the largest displacement; stored as float32 (relative rounding ~6e-8).
  EXPECT_NEAR(r.displacement_range, kDent, 1e-9);
  const Image img = read_png(r.files[1]);
  // The legend's column: its top is the map's top (red), its bottom the map's bottom (blue);
  // colours within 1 unit of the exact map (8-bit rounding).
  const int bw = std::max(6, 300 / 60), margin = std::max(4, 300 / 80), col = 300 - margin - bw / 2;
  const Rgb top = img.at(col, 200 / 5), bottom = img.at(col, 200 - 200 / 5 - 1);
  const auto hi = colormap(1.0), lo = colormap(0.0);
  EXPECT_NEAR(top.r, 255 * hi[0], 1.0);
  EXPECT_NEAR(top.g, 255 * hi[1], 1.0);
  EXPECT_NEAR(bottom.b, 255 * lo[2], 1.0);
  // A tissue pixel at rest in the corner is blue-ish now, not pink.
  const auto q = project(r.camera, 300, 200, {0.7 * kHalf, 0.7 * kHalf, 0});
  const Rgb t = img.at(int((*q)[0]), int((*q)[1]));
  EXPECT_GT(t.b, t.r) << int(t.r) << " " << int(t.g) << " " << int(t.b);
}

TEST(Render, StaleFramesAreRemovedAndOtherFilesKept) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  fs::create_directories(s / "out");
  std::ofstream(s / "out/frame_00099.png") << "old";
  std::ofstream(s / "out/notes.txt") << "mine";
  const RenderOptions o = small_frames();
  render_replay(s / "r.h5", s / "out", o);
  EXPECT_FALSE(fs::exists(s / "out/frame_00099.png"));
  EXPECT_TRUE(fs::exists(s / "out/notes.txt"));
  EXPECT_TRUE(fs::exists(s / "out/frame_00002.png"));
}

// The new frames take the old ones' place only once all are written: an interrupted render keeps
// the previous frames and leaves no hidden folder.
TEST(Render, AnInterruptedRenderKeepsThePreviousFrames) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o = small_frames();
  render_replay(s / "r.h5", s / "out", o);
  const std::string before = slurp_file(s / "out/frame_00001.png");
  o.camera = "top";
  set_interrupted(true);
  EXPECT_THROW(render_replay(s / "r.h5", s / "out", o), InputError);
  set_interrupted(false);
  EXPECT_EQ(slurp_file(s / "out/frame_00001.png"), before);
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(s / "out")) ++entries;
  EXPECT_EQ(entries, 3);  // frame_00000 .. frame_00002, nothing hidden beside them
}

// frame_*.png files in the folder are the render's: a replay named like one is refused, not removed.
TEST(Render, AReplayNamedLikeAFrameIsRefused) {
  REQUIRE_OSMESA();
  Scratch s;
  fs::create_directories(s / "out");
  write_synthetic(s / "out/frame_00003.png");
  try {
    render_replay(s / "out/frame_00003.png", s / "out", RenderOptions{});
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the frames would replace the replay"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(s / "out/frame_00003.png"));
}

// The time bar shows t / t_end of the replayed window: the last of frames at 0, 0.1 and 0.2 s of a
// 0.4 s replay fills half of it (it filled all of it: the frames' own span was the bar's end).
TEST(Render, TheTimeBarIsTheFramesTimeInTheReplayedWindow) {
  REQUIRE_OSMESA();
  Scratch s;
  SyntheticOptions so;
  so.virtual_s = 0.4;
  write_synthetic(s / "r.h5", so);
  RenderOptions o;
  o.width = 200;
  o.height = 150;
  const RenderSummary r = render_replay(s / "r.h5", s / "out", o);
  ASSERT_EQ(r.files.size(), 3u);
  const Image last = read_png(r.files[2]);
  auto bar = [&](int x) {
    const Rgb p = last.at(x, last.height - 1);
    return p.r == kTimeBarColour.r && p.g == kTimeBarColour.g && p.b == kTimeBarColour.b;
  };
  EXPECT_TRUE(bar(95));
  EXPECT_FALSE(bar(105));
  EXPECT_FALSE(bar(199));
}

// A folder named like a frame is the user's: refused before rendering, not deleted with the old frames.
TEST(Render, AFolderNamedLikeAFrameIsRefusedAndKept) {
  REQUIRE_OSMESA();
  Scratch s;
  write_synthetic(s / "r.h5");
  fs::create_directories(s / "out/frame_00001.png/sub");
  std::ofstream(s / "out/frame_00001.png/sub/data.txt") << "precious";
  std::ofstream(s / "out/frame_00099.png") << "old";
  const RenderOptions o = small_frames();
  try {
    render_replay(s / "r.h5", s / "out", o);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), s / "out/frame_00001.png" +
                                         ": named like a frame but a folder: `ebh render` replaces the frame_*.png "
                                         "files of its folder; move it away or render into another folder");
  }
  EXPECT_EQ(slurp_file(s / "out/frame_00001.png/sub/data.txt"), "precious");
  EXPECT_EQ(slurp_file(s / "out/frame_00099.png"), "old");
}

// `--video vid.avi` wrote an MP4 under an .avi name (ffmpeg is told -f mp4): another extension is
// refused before anything is rendered, with or without ffmpeg.
TEST(Render, AVideoNotNamedMp4IsRefused) {
  Scratch s;
  write_synthetic(s / "r.h5");
  RenderOptions o = small_frames();
  o.video = s / "vid.avi";
  try {
    render_replay(s / "r.h5", s / "out", o);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--video " + s / "vid.avi" + ": the video is written as MP4 (H.264); name it FILE.mp4");
  }
  EXPECT_FALSE(fs::exists(s / "out"));
  EXPECT_FALSE(fs::exists(s / "vid.avi"));
}

TEST(Render, VideoWithoutFfmpegIsAClearError) {
  Scratch s;
  write_synthetic(s / "r.h5");
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  setenv("PATH", s.dir.c_str(), 1);  // an empty directory: no ffmpeg
  RenderOptions o;
  o.video = s / "v.mp4";
  try {
    render_replay(s / "r.h5", s / "out", o);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ffmpeg was not found on the PATH"), std::string::npos) << e.what();
  }
  setenv("PATH", saved.c_str(), 1);
  EXPECT_FALSE(fs::exists(s / "v.mp4"));
}

}  // namespace
}  // namespace ebh
