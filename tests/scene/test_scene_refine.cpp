// `ebh scene refine` (scene/scene_refine.hpp): the refined scene loads with the same volume and
// mass, its pins and groups carried over, an OBJ virtual mesh refined with it, bit for bit the
// same files on every run, and clear errors for bad levels and sizes over the limit.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "../mesh/test_util.hpp"
#include "mesh/boundary.hpp"
#include "mesh/lumped_masses.hpp"
#include "mesh/mesh_io.hpp"
#include "scene/scene.hpp"
#include "scene/scene_init.hpp"
#include "scene/scene_refine.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;
using test::data;

/// Writes the refined scene's files into a fresh folder of the test and loads it.
Scene write_and_load(const RefinedScene& r) {
  for (const auto& [path, text] : {std::pair{r.mesh_file, &r.mesh_text}, {r.virtual_file, &r.virtual_text},
                                   {r.scene_file, &r.scene_yaml}})
    if (!path.empty()) std::ofstream(path, std::ios::binary) << *text;
  return load_scene(r.scene_file);
}

fs::path out_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) / "ebh_scene_refine" / info->name();
  fs::create_directories(dir);
  return dir;
}

double total_mass(const Scene& s) {
  double m = 0;
  for (double x : lumped_masses(s.physical, s.spec.density)) m += x;
  return m;
}

/// The midpoint vertex of each parent edge (a < b) after one level, read from the corner children
/// (mesh/refine.hpp: child c < 4 of tet t is its corner c with the midpoints of that corner's edges).
std::map<std::pair<int, int>, int> midpoints(const TetMesh& parent, const TetMesh& child) {
  std::map<std::pair<int, int>, int> mid;
  for (std::size_t t = 0; t < parent.tets.size(); ++t) {
    const Tet& p = parent.tets[t];
    const Tet& c0 = child.tets[8 * t];  // (v0, m01, m02, m03)
    const Tet& c1 = child.tets[8 * t + 1];  // (m01, v1, m12, m13)
    const Tet& c2 = child.tets[8 * t + 2];  // (m02, m12, v2, m23)
    const std::pair<int, int> e[6] = {{p[0], p[1]}, {p[0], p[2]}, {p[0], p[3]}, {p[1], p[2]}, {p[1], p[3]}, {p[2], p[3]}};
    const int m[6] = {c0[1], c0[2], c0[3], c1[2], c1[3], c2[3]};
    for (int k = 0; k < 6; ++k) mid[{std::min(e[k].first, e[k].second), std::max(e[k].first, e[k].second)}] = m[k];
  }
  return mid;
}

/// Pinned vertices stay pinned, where they were; the midpoint of two vertices of one pinned region
/// is pinned by it (the test scenes' regions are convex, and their groups' vertices are joined only
/// by edges of the group's triangles). Two vertices of different regions need not be: the union of
/// a region at the bottom and one at the top does not hold the points between them.
void expect_pins_carried(const Scene& before, const Scene& after) {
  const std::set<int> pinned(after.pinned.begin(), after.pinned.end());
  for (int v : before.pinned) {
    EXPECT_TRUE(pinned.count(v)) << "vertex " << v << " is no longer pinned";
    EXPECT_EQ(after.physical.vertices[v], before.physical.vertices[v]) << "vertex " << v << " moved";
  }
  const std::map<std::pair<int, int>, int> mid = midpoints(before.physical, after.physical);
  int checked = 0;
  for (const PinRegion& region : before.spec.pinned) {
    const std::vector<int> old_v = region_vertices(before.physical, region), new_v = region_vertices(after.physical, region);
    const std::set<int> old_in(old_v.begin(), old_v.end()), new_in(new_v.begin(), new_v.end());
    for (const auto& [edge, m] : mid)
      if (old_in.count(edge.first) && old_in.count(edge.second)) {
        EXPECT_TRUE(new_in.count(m)) << describe_pin_region(region) << ": midpoint " << m << " of " << edge.first << "-"
                                     << edge.second;
        ++checked;
      }
  }
  EXPECT_GT(checked, 0) << "no edge joins two vertices of one pinned region";
}

TEST(SceneRefine, GroupAndBoxPinsVolumeMassAndVirtualMesh) {
  const Scene before = load_scene(data("scene/cube.yaml"));
  const RefinedScene r = refine_scene(data("scene/cube.yaml"), 1, out_dir() / "cube_l1.yaml");
  EXPECT_EQ(r.name, "test-cube_l1");
  EXPECT_EQ(r.mesh_file.filename(), "cube_l1.msh");
  EXPECT_TRUE(r.virtual_file.empty());
  const Scene after = write_and_load(r);
  EXPECT_EQ(after.spec.name, "test-cube_l1");
  EXPECT_EQ(after.physical.tets.size(), 8 * before.physical.tets.size());
  EXPECT_EQ(static_cast<std::int64_t>(after.physical.vertices.size()), r.after.vertices);
  EXPECT_NEAR(total_mass(after), total_mass(before), 1e-12 * total_mass(before));
  // The virtual mesh is the refined boundary (virtual_refine applies on top of it as before).
  EXPECT_EQ(after.virtual_surface.triangles.size(), 4 * before.virtual_surface.triangles.size());
  EXPECT_EQ(after.spec.virtual_refine, before.spec.virtual_refine);
  expect_pins_carried(before, after);
  // Every other key is the same: the resolved scenes differ only in the name and the mesh path.
  SceneSpec a = before.spec, b = after.spec;
  b.name = a.name;
  b.physical_mesh = a.physical_mesh;
  EXPECT_EQ(resolved_scene_yaml(a), resolved_scene_yaml(b));
}

TEST(SceneRefine, ObjVirtualMeshSphereAndHalfspacePins) {
  const Scene before = load_scene(data("scene/cube_obj.yaml"));
  const RefinedScene r = refine_scene(data("scene/cube_obj.yaml"), 2, out_dir() / "cube_obj_l2.yaml");
  ASSERT_EQ(r.virtual_file.filename(), "cube_obj_l2.obj");
  const Scene after = write_and_load(r);
  EXPECT_EQ(after.physical.tets.size(), 64 * before.physical.tets.size());
  EXPECT_EQ(after.virtual_surface.triangles.size(), 16 * before.virtual_surface.triangles.size());
  EXPECT_NEAR(total_mass(after), total_mass(before), 1e-12 * total_mass(before));
  // Pins over one level at a time: the midpoint rule holds level by level.
  const Scene middle = write_and_load(refine_scene(data("scene/cube_obj.yaml"), 1, out_dir() / "cube_obj_l1.yaml"));
  expect_pins_carried(before, middle);
  expect_pins_carried(middle, after);
}

TEST(SceneRefine, CommittedTubeGroupPins) {
  const fs::path tube = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  const Scene before = load_scene(tube);
  const Scene after = write_and_load(refine_scene(tube, 1, out_dir() / "tube_l1.yaml"));
  // group 'ends': the annular end faces; their vertices are joined only by the faces' edges.
  expect_pins_carried(before, after);
  EXPECT_NEAR(total_mass(after), total_mass(before), 1e-12 * total_mass(before));
}

TEST(SceneRefine, KeepVirtualRefinesOnlyThePhysicalMesh) {
  // The boundary of the scene before refinement (cube.yaml) and an OBJ (cube_obj.yaml): the refined
  // scene's virtual mesh is the scene's own, vertex for vertex, while the tets grow 64x.
  for (const char* name : {"scene/cube.yaml", "scene/cube_obj.yaml"}) {
    const Scene before = load_scene(data(name));
    const RefinedScene r = refine_scene(data(name), 2, out_dir() / "kept_l2.yaml", kMaxRefinedTets, "", true);
    ASSERT_EQ(r.virtual_file.filename(), "kept_l2.obj") << name;
    EXPECT_NE(r.scene_yaml.find("keeps the scene's resolution"), std::string::npos);
    const Scene after = write_and_load(r);
    EXPECT_EQ(after.physical.tets.size(), 64 * before.physical.tets.size()) << name;
    EXPECT_EQ(after.virtual_surface.triangles, before.virtual_surface.triangles) << name;
    EXPECT_EQ(after.virtual_surface.vertices, before.virtual_surface.vertices) << name;
    EXPECT_EQ(after.spec.virtual_refine, before.spec.virtual_refine) << name;
    expect_pins_carried(before, write_and_load(refine_scene(data(name), 1, out_dir() / "kept_l1.yaml",
                                                            kMaxRefinedTets, "", true)));
  }
  // The boundary kept: each of its vertices is a physical vertex of the refined mesh (refinement
  // keeps the old vertices' bits), so the virtual mesh lies on the refined surface.
  const Scene after = write_and_load(refine_scene(data("scene/cube.yaml"), 2, out_dir() / "kept_l2.yaml",
                                                  kMaxRefinedTets, "", true));
  std::set<std::tuple<double, double, double>> physical;
  for (const Vec3d& x : after.physical.vertices) physical.insert({x.x, x.y, x.z});
  for (const Vec3d& v : after.virtual_surface.vertices) EXPECT_TRUE(physical.count({v.x, v.y, v.z})) << v.x << " " << v.y << " " << v.z;
}

// A scene that drops a segmentation's speck (mesh.min_part_tets, as `scene init` writes it) refines
// its mesh as the scene loads it, without the speck: refined, the 6-tet speck came back as 48
// tets floating free (pinned, where it lay low), and the counts said "from 1206" for a scene of
// 1200 tets.
TEST(SceneRefine, APartThatMinPartTetsDropsStaysDropped) {
  SceneInitOptions o;
  o.mesh = out_dir() / "specks.msh";
  o.out = out_dir() / "specks.yaml";
  std::ofstream(o.mesh, std::ios::binary) << msh22_text(test::block_with_a_speck(50));
  std::ofstream(o.out, std::ios::binary) << make_scene(o).yaml;
  const Scene before = load_scene(o.out);
  ASSERT_EQ(before.physical.tets.size(), 1200u);
  const RefinedScene r = refine_scene(o.out, 1, out_dir() / "specks_l1.yaml");
  EXPECT_EQ(r.before.tets, 1200);
  EXPECT_EQ(r.before.vertices, static_cast<std::int64_t>(before.physical.vertices.size()));
  EXPECT_NE(r.scene_yaml.find(": 9600 tets and " + std::to_string(r.after.vertices) + " vertices, from 1200 and " +
                              std::to_string(before.physical.vertices.size()) + "."),
            std::string::npos) << r.scene_yaml.substr(0, 400);
  const Scene after = write_and_load(r);
  EXPECT_EQ(after.physical.tets.size(), 9600u);
  EXPECT_EQ(after.free_parts, before.free_parts);  // none: the block is pinned at its bottom
  EXPECT_NEAR(total_mass(after), total_mass(before), 1e-12 * total_mass(before));
  expect_pins_carried(before, after);
}

// Written through a link to nothing (-o new.yaml -> store/new.yaml), the scene is refined for the
// link's target (io/atomic.hpp output_target): its meshes beside it there, named by their file
// names, which the scene names from its own folder; it loads through the link as at the target
// (read through the link, its meshes were looked for beside the link).
TEST(SceneRefine, WrittenThroughALinkItsMeshesAreBesideTheTarget) {
  const fs::path dir = out_dir();
  fs::remove_all(dir);
  fs::create_directories(dir / "store");
  fs::create_symlink("store/new.yaml", dir / "new.yaml");
  const RefinedScene r = refine_scene(data("scene/cube_obj.yaml"), 1, dir / "store" / "new.yaml");
  EXPECT_EQ(r.mesh_file, dir / "store" / "new.msh");
  EXPECT_EQ(r.virtual_file, dir / "store" / "new.obj");
  EXPECT_NE(r.scene_yaml.find("physical: new.msh\n"), std::string::npos) << r.scene_yaml;
  EXPECT_NE(r.scene_yaml.find("virtual: new.obj\n"), std::string::npos) << r.scene_yaml;
  const Scene at_target = write_and_load(r);
  const Scene through_link = load_scene(dir / "new.yaml");
  EXPECT_EQ(through_link.spec.physical_mesh, dir / "store" / "new.msh");
  ASSERT_TRUE(through_link.spec.virtual_mesh.has_value());
  EXPECT_EQ(*through_link.spec.virtual_mesh, dir / "store" / "new.obj");
  EXPECT_EQ(through_link.physical.tets.size(), at_target.physical.tets.size());
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir / "new.msh")));
}

TEST(SceneRefine, SameFilesOnEveryRun) {
  const RefinedScene a = refine_scene(data("scene/cube_obj.yaml"), 2, out_dir() / "x.yaml");
  const RefinedScene b = refine_scene(data("scene/cube_obj.yaml"), 2, out_dir() / "x.yaml");
  EXPECT_EQ(a.scene_yaml, b.scene_yaml);
  EXPECT_EQ(a.mesh_text, b.mesh_text);
  EXPECT_EQ(a.virtual_text, b.virtual_text);
}

TEST(SceneRefine, BadLevelAndOverTheLimit) {
  try {
    refine_scene(data("scene/cube.yaml"), 0, out_dir() / "x.yaml");
    ADD_FAILURE() << "level 0 accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--level: expected 1 or more, got 0");
  }
  try {
    refine_scene(data("scene/cube.yaml"), 3, out_dir() / "x.yaml", 2000);
    ADD_FAILURE() << "2560 tets accepted under a limit of 2000";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("level 3 makes 2560 tets"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("over the limit of 2000 tets (--max-tets raises it)"), std::string::npos) << e.what();
  }
  try {  // past INT64_MAX: the counts and the memory as estimates, not the saturated integers
    refine_scene(data("scene/cube.yaml"), 99, out_dir() / "x.yaml");
    ADD_FAILURE() << "level 99 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("level 99 makes 1.27e+90 tets and 2.12e+89 vertices (5 tets x 8^99): about 2.2e+83 GB to write"), std::string::npos) << e.what();
  }
}

/// --max-tets at INT64_MAX lifts the user's limit, not what a mesh can hold: the cube's 5 tets at
/// level 21 make 4.6e19, past INT64_MAX, whose saturated count once equalled the limit and passed
/// (and the refinement then ran until the memory was gone); 5.4e9 at level 10 fit an int64 but not
/// the mesh's 32-bit indices.
TEST(SceneRefine, NoMaxTetsRaisesTheLimitPastWhatAMeshIndexes) {
  constexpr std::int64_t kNoLimit = std::numeric_limits<std::int64_t>::max();
  const TetMesh cube = read_msh(load_scene_spec(data("scene/cube.yaml")).physical_mesh);
  EXPECT_TRUE(refined_within(refined_counts(cube, 9), kNoLimit));  // 671 million tets
  EXPECT_FALSE(refined_within(refined_counts(cube, 9), 671'088'639));
  EXPECT_TRUE(refined_within(refined_counts(cube, 9), 671'088'640));
  // Checked before refine_scene is called: with the old check it would refine.
  for (const int level : {10, 21, 22})
    ASSERT_FALSE(refined_within(refined_counts(cube, level), kNoLimit)) << "level " << level;
  try {
    refine_scene(data("scene/cube.yaml"), 21, out_dir() / "x.yaml", kNoLimit);
    ADD_FAILURE() << "level 21 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("level 21 makes 4.61e+19 tets"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("over the 2147483647 tets or vertices a mesh can index (its indices are 32-bit)"),
              std::string::npos) << e.what();
  }
  try {  // past what a double holds: said in words, and at once whatever the level
    refine_scene(data("scene/cube.yaml"), std::numeric_limits<int>::max(), out_dir() / "x.yaml");
    ADD_FAILURE() << "level INT_MAX accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("makes over 1e308 tets and over 1e308 vertices"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("): over 1e299 GB to write and over 1e299 GB to replay"), std::string::npos) << e.what();
  }
}

}  // namespace
/// Within the counts' limits (--max-tets raised) but past this machine's memory: refused before any
/// refinement, with the sizes (the tube's 2.1 billion tets at level 6, under 2^31 - 1, were written
/// until the out-of-memory killer ended the run, without a word). A machine with the ~115 GB the
/// cube's level 9 takes skips the check.
TEST(SceneRefine, ALevelPastThisMachinesMemoryIsRefused) {
  constexpr std::int64_t kNoLimit = std::numeric_limits<std::int64_t>::max();
  const RefinedCounts within = refined_counts(read_msh(load_scene_spec(data("scene/cube.yaml")).physical_mesh), 9);
  ASSERT_TRUE(refined_within(within, kNoLimit));  // 671 million tets
  const double ram = machine_memory_bytes(), bytes = refine_memory(within).write_bytes;
  if (!(ram > 0 && bytes > ram)) GTEST_SKIP() << "this machine holds " << bytes << " bytes";
  try {
    refine_scene(data("scene/cube.yaml"), 9, out_dir() / "x.yaml", kNoLimit);
    ADD_FAILURE() << "level 9 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("level 9 makes 671 million tets: about 115 GB to write, more than this "
                                         "machine's "),
              std::string::npos) << e.what();
  }
  EXPECT_EQ(gigabytes(2.5e10), "25 GB");
  EXPECT_EQ(gigabytes(3.6e11), "360 GB");
}

}  // namespace ebh
