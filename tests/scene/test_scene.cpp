// Scene loader: a valid file loads with every length in metres; each kind of bad key or value
// is rejected with the dotted key named; meshes are validated; pinned regions resolve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../mesh/test_util.hpp"
#include "mesh/boundary.hpp"
#include "mesh/box_mesh.hpp"
#include "mesh/mesh_io.hpp"
#include "scene/scene.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;
using test::data;
using test::replace;
using test::slurp;
using test::write_temp;

// Exact comparisons of scaled lengths are avoided: 6 * 0.001 is not the double nearest 0.006.
constexpr double kTol = 1e-15;  // a few ulps of the lengths involved (<= 0.3 m)

TEST(SceneSpec, EveryKeyRead) {
  const SceneSpec s = load_scene_spec(data("scene/cube.yaml"));
  EXPECT_EQ(s.name, "test-cube");
  EXPECT_EQ(s.description, "small cube for the scene loader tests");
  EXPECT_EQ(s.unit_name, "mm");
  EXPECT_EQ(s.unit, 0.001);
  EXPECT_EQ(s.mesh_unit_name, "mm");
  EXPECT_EQ(s.mesh_unit, 0.001);
  EXPECT_TRUE(s.mesh_transform.identity());
  EXPECT_EQ(s.tool.unit_name, "mm");
  EXPECT_EQ(s.tool.unit, 0.001);
  EXPECT_EQ(s.physical_mesh, data("mesh/cube22.msh").lexically_normal());
  EXPECT_FALSE(s.virtual_mesh.has_value());
  EXPECT_EQ(s.virtual_refine, 1);
  EXPECT_EQ(s.density, 1100.0);  // SI: not scaled
  EXPECT_EQ(s.stiffness.k_vol, 2500.0);
  EXPECT_EQ(s.stiffness.k_s, 25.0);
  EXPECT_EQ(s.stiffness.k_svc, 55.0);
  EXPECT_EQ(s.stiffness.k_con, 450.0);
  EXPECT_EQ(s.stiffness.k_vcs, 320.0);
  EXPECT_EQ(s.stiffness.k_vct, 0.35);
  EXPECT_EQ(s.gravity, Vec3d(0, 0, -9.81));  // SI: not scaled
  EXPECT_EQ(s.damping, 0.05);
  ASSERT_EQ(s.pinned.size(), 2u);
  EXPECT_EQ(s.pinned[0].kind, PinRegion::Kind::Group);
  EXPECT_EQ(s.pinned[0].group, "bottom");
  EXPECT_EQ(s.pinned[1].kind, PinRegion::Kind::Box);
  EXPECT_NEAR(s.pinned[1].b.z, 0.011, kTol);
  EXPECT_EQ(s.tool.kind, ToolSpec::Kind::Forceps);
  EXPECT_NEAR(s.tool.shaft_radius, 0.0025, kTol);
  EXPECT_NEAR(s.tool.shaft_length, 0.3, kTol);
  EXPECT_FALSE(s.tool.other_kind_keys);
  EXPECT_NEAR(s.tool.forceps.jaw_length, 0.008, kTol);
  EXPECT_NEAR(s.tool.forceps.jaw_width, 0.005, kTol);
  EXPECT_NEAR(s.tool.forceps.jaw_thickness, 0.002, kTol);
  EXPECT_EQ(s.tool.forceps.jaw_max_angle_deg, 30.0);  // degrees stay degrees
  EXPECT_EQ(s.tool.forceps.grasp_threshold, 0.2);
  EXPECT_NEAR(s.tool.forceps.soft_margin, 0.002, kTol);
  EXPECT_EQ(s.tool.forceps.eta, 1.5);
  EXPECT_EQ(s.tool.force_limit, 3.3);  // newtons: not scaled
  EXPECT_EQ(s.tool.newton_iterations, 3);
  EXPECT_NEAR(s.tool.max_step, 0.0005, kTol);
  EXPECT_EQ(s.tool.max_step_rotation_deg, 2.0);
  EXPECT_EQ(s.haptic_hz, 1000.0);
  EXPECT_EQ(s.physical_hz, 50.0);
  EXPECT_EQ(s.solver.method, SolverSpec::Method::Jacobi);
  EXPECT_EQ(s.solver.physical_iterations, 20);
  EXPECT_EQ(s.solver.virtual_iterations, 5);
  EXPECT_EQ(s.solver.chebyshev_rho, 0.9);
  EXPECT_FALSE(s.solver.chebyshev_rho_auto);
  EXPECT_NEAR(s.camera.eye.y, -0.1, kTol);
  EXPECT_NEAR(s.camera.target.x, 0.005, kTol);
  EXPECT_EQ(s.camera.up, Vec3d(0, 0, 1));  // a direction: normalised, not scaled
  EXPECT_EQ(s.camera.fov_deg, 45.0);
  EXPECT_TRUE(s.stages.grasp);
  EXPECT_TRUE(s.stages.frames);
}

TEST(SceneSpec, DefaultsAndNameFromStem) {
  const auto p = write_temp("minimal.yaml", "mesh: {physical: " + data("mesh/cube22.msh").string() + "}\n");
  const SceneSpec s = load_scene_spec(p);
  EXPECT_EQ(s.name, "minimal");
  EXPECT_EQ(s.unit, 1.0);
  EXPECT_EQ(s.mesh_unit, 1.0);  // mesh.unit and tool.unit default to unit
  EXPECT_EQ(s.tool.unit, 1.0);
  EXPECT_TRUE(s.mesh_transform.identity());
  EXPECT_EQ(s.tool.hook.tip_length, SceneSpec{}.tool.hook.tip_length);  // defaults are metres already
  EXPECT_TRUE(s.pinned.empty());
  EXPECT_EQ(s.solver.recovery, SolverSpec::Recovery::Direct);
  EXPECT_EQ(s.solver.recovery_residual, 100.0);
  EXPECT_EQ(s.solver.physical_tolerance, 0.002);
  EXPECT_EQ(s.solver.physical_max_iterations, 64);
  EXPECT_FALSE(s.solver.chebyshev_rho_auto);
  EXPECT_EQ(s.solver.virtual_damping, 250.0);  // 1/s
  EXPECT_EQ(s.stiffness.k_det, 0.0);            // E_det off: the paper's model
}

TEST(Scene, LoadsInMetresAndPins) {
  const Scene s = load_scene(data("scene/cube.yaml"));
  EXPECT_TRUE(s.warnings.empty());
  ASSERT_EQ(s.physical.vertices.size(), 8u);
  EXPECT_NEAR(s.physical.vertices[0].x, 0.010, kTol);  // node 101 at (10, 0, 10) mm
  EXPECT_NEAR(s.physical.vertices[0].z, 0.010, kTol);
  EXPECT_EQ(s.virtual_surface.vertices.size(), 8u);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  // group bottom: the z = 0 corners (nodes 7, 3, 1000, 9 -> vertices 1, 3, 4, 6); the box around
  // (0, 0, 10) mm: node 250 -> vertex 7
  EXPECT_EQ(s.pinned, (std::vector<int>{1, 3, 4, 6, 7}));
}

TEST(Scene, AGroupOfAnEntityInTwoGroupsPins) {
  // the bottom surface is in "bottom" and "fixed", the volume in "tissue" and "liver"
  const TetMesh m = read_msh(data("mesh/cube41_two_groups.msh"));
  auto group = [](const std::string& name) { return PinRegion{PinRegion::Kind::Group, name, {}, {}}; };
  EXPECT_EQ(region_vertices(m, group("fixed")), (std::vector<int>{1, 3, 4, 6}));
  EXPECT_EQ(region_vertices(m, group("fixed")), region_vertices(m, group("bottom")));
  EXPECT_EQ(region_vertices(m, group("liver")).size(), 8u);
}

TEST(Scene, AnUnnamedGroupIsPinnedByItsNumber) {
  // cube22.msh without the name of its bottom group (Gmsh: Physical Surface(2) = {...})
  std::string mesh = replace(slurp(data("mesh/cube22.msh")), "$PhysicalNames\n4\n", "$PhysicalNames\n3\n");
  mesh = replace(mesh, "2 2 \"bottom\"\n", "");
  const fs::path msh = write_temp("unnamed.msh", mesh);
  const TetMesh m = read_msh(msh);
  auto group = [](const std::string& name) { return PinRegion{PinRegion::Kind::Group, name, {}, {}}; };
  EXPECT_EQ(region_vertices(m, group("2")), (std::vector<int>{1, 3, 4, 6}));
  EXPECT_TRUE(region_vertices(m, group("1")).empty());  // tag 1 has a name: "tissue"
  EXPECT_EQ(known_group_names(m), (std::vector<std::string>{"tissue", "top", "2"}));
  const std::string yaml = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", msh.string());
  const Scene s = load_scene(write_temp("unnamed.yaml", replace(yaml, "group: bottom", "group: 2")));
  EXPECT_EQ(s.pinned, (std::vector<int>{1, 3, 4, 6, 7}));
  try {
    load_scene(write_temp("unknown.yaml", replace(yaml, "group: bottom", "group: 5")));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown group '5' (known groups in " + msh.string() + ": tissue, top, 2 (unnamed))"),
              std::string::npos)
        << e.what();
  }
}

TEST(Scene, ATetgenMeshsFilesAreEachAnInputAndItsGroupsPin) {
  // the scene of cube.yaml on the TetGen cube (named by its .node): the .ele and the .face are read
  // too, so a replay records each with its digest; the bottom's faces (marker 3) pin as surface_3
  const std::string yaml = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube.1.node").string());
  const fs::path file = write_temp("tetgen.yaml", replace(yaml, "group: bottom", "group: surface_3"));
  const Scene s = load_scene(file);
  EXPECT_EQ(s.physical.tets.size(), 5u);
  std::vector<std::string> keys;
  for (const SceneInputFile& f : scene_input_files(s.spec)) keys.push_back(f.key + " " + f.path.filename().string());
  EXPECT_EQ(keys, (std::vector<std::string>{"scene_file tetgen.yaml", "physical_mesh cube.1.node", "physical_mesh_ele cube.1.ele",
                                            "physical_mesh_face cube.1.face"}));
  const TetMesh m = read_tet_mesh(data("mesh/cube.1.node"));
  auto group = [](const std::string& name) { return PinRegion{PinRegion::Kind::Group, name, {}, {}}; };
  EXPECT_EQ(region_vertices(m, group("surface_3")), (std::vector<int>{0, 1, 2, 3}));  // z = 0
  EXPECT_EQ(region_vertices(m, group("surface_1")), (std::vector<int>{4, 5, 6, 7}));  // z = 10
}

// What `ebh scene info` lists: each group by the number its mesh file gives it (a TetGen face
// marker, a Medit triangle reference, a Gmsh surface group's number that a volume group of another
// name has too), not the tag a reader moved it to so that it stays apart from a volume group.
TEST(Scene, MeshGroupsAreListedByTheirNumbersInTheFile) {
  auto listed = [](const TetMesh& m) {  // "tag file_tag name tets triangles"
    std::vector<std::string> out;
    for (const MeshGroup& g : mesh_groups(m))
      out.push_back(std::to_string(g.tag) + " " + std::to_string(g.file_tag) + " " + g.name + " " + std::to_string(g.tets) + " " +
                    std::to_string(g.triangles));
    return out;
  };
  // the tets' regions 1 and 2; the faces' markers (references) 1 and 3, on tags 3 and 4
  const std::vector<std::string> surface_n = {"1 1  2 0", "2 2  3 0", "3 1 surface_1 0 2", "4 3 surface_3 0 2"};
  EXPECT_EQ(listed(read_tet_mesh(data("mesh/cube.1.ele"))), surface_n);
  EXPECT_EQ(listed(read_tet_mesh(data("mesh/cube.mesh"))), surface_n);
  // as loaded in a scene (what scene info reads)
  const std::string yaml = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube.1.ele").string());
  EXPECT_EQ(listed(load_scene(write_temp("tetgen.yaml", replace(yaml, "group: bottom", "group: surface_3"))).physical), surface_n);
  // cube22.msh with its top on Physical Surface("top", 1), the number of the volume "tissue"
  std::string text = replace(slurp(data("mesh/cube22.msh")), "2 3 \"top\"", "2 1 \"top\"");
  text = replace(replace(text, "7 2 2 3 2", "7 2 2 1 2"), "8 2 2 3 2", "8 2 2 1 2");
  EXPECT_EQ(listed(read_msh(write_temp("clash.msh", text))),
            (std::vector<std::string>{"1 1 tissue 5 0", "2 2 bottom 0 2", "3 1 top 0 2"}));
  // groups a reader keeps on the file's numbers, and the elements of none (tag 0)
  EXPECT_EQ(listed(read_tet_mesh(data("mesh/cube_ascii.vtk"))), (std::vector<std::string>{"1 1  2 0", "2 2  3 0"}));
  EXPECT_EQ(listed(read_tet_mesh(data("mesh/cube51.vtk"))), (std::vector<std::string>{"0 0  5 0"}));
}

TEST(Scene, PartsTouchingNoPinnedVertexAreFoundByTheirSharedVertices) {
  TetMesh m;
  m.vertices.resize(15);
  // three parts: 0-3; 4-7; 8-14, two tets sharing vertex 11
  m.tets = {{0, 1, 2, 3}, {4, 5, 6, 7}, {8, 9, 10, 11}, {11, 12, 13, 14}};
  using Parts = std::vector<std::pair<int, int>>;
  EXPECT_EQ(unpinned_parts(m, std::vector<int>{1}), (Parts{{4, 4}, {8, 7}}));
  EXPECT_EQ(unpinned_parts(m, std::vector<int>{1, 13}), (Parts{{4, 4}}));
  EXPECT_EQ(unpinned_parts(m, std::vector<int>{}), (Parts{{0, 4}, {4, 4}, {8, 7}}));
  EXPECT_EQ(unpinned_parts(m, std::vector<int>{3, 6, 14}), Parts{});
}

/// A part pinned at one vertex or along one edge can turn about it (the tool feels the coupling's
/// drag); a face of pins holds it.
TEST(Scene, PinsOnALineOrAtAPointWarn) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const std::string pins = "pinned:\n  - group: bottom\n  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n";
  const auto warned = [](const Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find(": they can turn about") != std::string::npos) return w;
    return std::string();
  };
  const Scene corner = load_scene(write_temp("corner.yaml", replace(good, pins, "pinned:\n  - box: {min: [-1, -1, -1], max: [1, 1, 1]}\n")));
  EXPECT_NE(warned(corner).find("pinned at 1 vertex: they can turn about it"), std::string::npos)
      << ::testing::PrintToString(corner.warnings);
  const Scene edge = load_scene(write_temp("edge.yaml", replace(good, pins, "pinned:\n  - box: {min: [-1, -1, -1], max: [11, 1, 1]}\n")));
  EXPECT_NE(warned(edge).find("pinned at 2 vertices on one line: they can turn about that line"), std::string::npos)
      << ::testing::PrintToString(edge.warnings);
  EXPECT_EQ(warned(load_scene(write_temp("face.yaml", good))), "");
  const Scene face = load_scene(write_temp("face3.yaml", replace(good, pins, "pinned:\n  - box: {min: [-1, -1, -1], max: [11, 1, 11]}\n")));
  EXPECT_EQ(warned(face), "");
}

/// A slender part (a vessel 200 x 2 x 2 mm) clamped across its end face spans a face of it, not a
/// line; pins along one of its long edges are a line. The tolerance is a share of the part's
/// thickness: of its box's diagonal (200 mm), it took the whole 2 mm end face for a line.
TEST(Scene, PinsAcrossASlenderPartsEndAreAFace) {
  for (const Vec3d dir : {Vec3d{1, 0, 0}, Vec3d{1, 1, 1}}) {  // along an axis, and turned off the axes
    TetMesh m = make_box_tets({0, 0, 0}, {0.2, 0.002, 0.002}, 100, 1, 1);
    const Vec3d x = dir / norm(dir), y = cross(x, Vec3d{0, 0, 1}) / norm(cross(x, Vec3d{0, 0, 1})), z = cross(x, y);
    for (Vec3d& v : m.vertices) v = v.x * x + v.y * y + v.z * z;
    const auto index = [](int i, int j, int k) { return i + 101 * (j + 2 * k); };
    const std::vector<int> end{index(0, 0, 0), index(0, 1, 0), index(0, 0, 1), index(0, 1, 1)};
    EXPECT_TRUE(parts_pinned_on_a_line(m, end).empty());
    std::vector<int> edge;
    for (int i = 0; i <= 100; ++i) edge.push_back(index(i, 0, 0));
    EXPECT_EQ(parts_pinned_on_a_line(m, edge), (std::vector<std::pair<int, int>>{{0, 101}}));
  }
}

/// A tissue stiffer than its coupling can carry: the rendered force stops following k_vol.
TEST(Scene, ATissueStifferThanItsCouplingWarns) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const auto warned = [](const Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find("the coupling, not the tissue, sets what the tool feels") != std::string::npos) return true;
    return false;
  };
  EXPECT_FALSE(warned(load_scene(write_temp("soft.yaml", good))));  // 2500 Pa x ~12 mm against 55 N/m
  const Scene stiff = load_scene(write_temp("stiff.yaml", replace(good, "k_vol: 2500", "k_vol: 1e5")));
  EXPECT_TRUE(warned(stiff)) << ::testing::PrintToString(stiff.warnings);
  EXPECT_FALSE(warned(load_scene(write_temp("held.yaml", replace(replace(good, "k_vol: 2500", "k_vol: 1e5"), "k_svc: 55", "k_svc: 2000")))));
}

/// A Newton call that may move the virtual tool far beyond a tick of hand motion looks for contacts
/// that far at every step: the ticks slow down for nothing, said with the keys that set it. A turn
/// limit so small that it caps the step's translation too is said as well.
TEST(Scene, ANewtonReachFarBeyondATicksMotionOrATinyTurnLimitWarns) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const auto warned = [](const Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find("each Newton call of the virtual tool looks for contacts that far") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(warned(load_scene(write_temp("reach.yaml", good))), "");  // 3 x 0.5 mm
  // 3 x 6 mm = 18 mm, within 20 ticks of 1 m/s at 1 kHz; 3 x 7 mm = 21 mm beyond them.
  EXPECT_EQ(warned(load_scene(write_temp("reach18.yaml", replace(good, "max_step: 0.5", "max_step: 6")))), "");
  const Scene far = load_scene(write_temp("reach21.yaml", replace(good, "max_step: 0.5", "max_step: 7")));
  EXPECT_NE(warned(far).find("reach21.yaml: tool.newton_iterations x tool.max_step = 3 x 7 mm = 21 mm"), std::string::npos)
      << ::testing::PrintToString(far.warnings);
  // At 100 Hz a tick of hand motion is 10 mm: 21 mm a call is what the device may move.
  EXPECT_EQ(warned(load_scene(write_temp("reach21slow.yaml", replace(replace(good, "max_step: 0.5", "max_step: 7"),
                                                                     "haptic_hz: 1000", "haptic_hz: 100")))),
            "");
  // A turn limit so small that it caps the step's translation too.
  const Scene turning = load_scene(write_temp("turn.yaml", good).string(), {"tool.max_step_rotation_deg=0.001"});
  const auto turn = std::find_if(turning.warnings.begin(), turning.warnings.end(),
                                 [](const std::string& w) { return w.find("caps its translation too") != std::string::npos; });
  ASSERT_NE(turn, turning.warnings.end()) << ::testing::PrintToString(turning.warnings);
  EXPECT_EQ(turn->rfind("--set 'tool.max_step_rotation_deg=0.001': tool.max_step_rotation_deg = 0.001: a Newton step", 0), 0u);
  const Scene set = load_scene(write_temp("reach_set.yaml", good).string(), {"tool.newton_iterations=50"});
  EXPECT_EQ(warned(set).rfind("--set 'tool.newton_iterations=50': tool.newton_iterations x tool.max_step = 50 x 0.5 mm = 25 mm", 0), 0u)
      << ::testing::PrintToString(set.warnings);
}

/// A minimum of physical iterations above the stopping rule's maximum runs every step that long
/// for nothing the tolerance asked.
TEST(Scene, AMinimumOfPhysicalIterationsAboveTheMaximumWarns) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const auto slow = [&](const std::vector<std::string>& sets) {
    for (const std::string& w : load_scene(write_temp("slow.yaml", good).string(), sets).warnings)
      if (w.find("is the fewest iterations a physical step runs") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(slow({"solver.physical_iterations=64"}), "");
  EXPECT_EQ(slow({"solver.physical_iterations=1000", "solver.physical_tolerance=0"}), "");  // exactly 1000, as asked
  EXPECT_EQ(slow({"solver.physical_iterations=1000"}).rfind("--set 'solver.physical_iterations=1000': solver.physical_iterations "
                                                            "= 1000 is the fewest", 0), 0u);
}

/// A scene whose pins hold only some of its mesh's parts, all of it or none of it says so (a part
/// the tool pushes away, a rigid body); under gravity a free part stops the settling with one line.
TEST(Scene, PinsHoldingSomePartsAllOrNoneOfTheMeshWarn) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  auto has = [](const Scene& s, const std::string& needle) {
    for (const std::string& w : s.warnings)
      if (w.find(needle) != std::string::npos) return true;
    return false;
  };
  const Scene all = load_scene(write_temp("all.yaml", replace(good, "  - group: bottom\n", "  - group: tissue\n")));
  EXPECT_TRUE(has(all, "pinned: every vertex of the physical mesh is pinned")) << ::testing::PrintToString(all.warnings);
  const Scene none = load_scene(write_temp(
      "none.yaml", replace(good, "pinned:\n  - group: bottom\n  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n", "pinned: []\n")));
  EXPECT_TRUE(has(none, "pinned: nothing is pinned, so the physical mesh floats free, held only by its coupling")) << ::testing::PrintToString(none.warnings);
  // Under gravity a replay refuses it (settle_under_gravity): said here too, not "it sinks slowly" alone.
  EXPECT_TRUE(has(none, "; a replay refuses it under gravity, with no static equilibrium to start from"))
      << ::testing::PrintToString(none.warnings);
  const Scene weightless = load_scene(write_temp(
      "weightless.yaml", replace(replace(good, "pinned:\n  - group: bottom\n  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n", "pinned: []\n"),
                                 "gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]")));
  EXPECT_FALSE(has(weightless, "a replay refuses it")) << ::testing::PrintToString(weightless.warnings);

  // cube22.msh twice, the copy 20 mm higher (node ids + 2000, element ids + 100): only the lower
  // cube's bottom is pinned
  std::string msh = slurp(data("mesh/cube22.msh"));
  const std::size_t n0 = msh.find("$Nodes\n8\n") + 9, n1 = msh.find("$EndNodes");
  const std::size_t e0 = msh.find("$Elements\n13\n") + 13, e1 = msh.find("$EndElements");
  std::string nodes = msh.substr(n0, n1 - n0), elements = msh.substr(e0, e1 - e0), more_nodes, more_elements;
  std::istringstream ns(nodes), es(elements);
  for (std::string line; std::getline(ns, line);) {
    std::istringstream l(line);
    long id;
    double x, y, z;
    l >> id >> x >> y >> z;
    more_nodes += std::to_string(id + 2000) + " " + std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z + 20) + "\n";
  }
  for (std::string line; std::getline(es, line);) {
    std::istringstream l(line);
    std::vector<long> f;
    for (long v; l >> v;) f.push_back(v);
    if (f[1] != 4) continue;  // the tets only
    more_elements += std::to_string(f[0] + 100) + " 4 2 1 1";
    for (int k = 5; k < 9; ++k) more_elements.append(" ").append(std::to_string(f[k] + 2000));
    more_elements += "\n";
  }
  msh = msh.substr(0, n0 - 2) + "16\n" + nodes + more_nodes + msh.substr(n1, e0 - 3 - n1) + "18\n" + elements +
        more_elements + msh.substr(e1);
  const fs::path two = write_temp("two_cubes.msh", msh);
  const std::string two_yaml = replace(replace(good, data("mesh/cube22.msh").string(), two.string()),
                                       "  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n", "");
  const Scene parts = load_scene(write_temp("two.yaml", two_yaml));
  EXPECT_EQ(parts.free_parts, (std::vector<std::pair<int, int>>{{8, 8}}));
  EXPECT_TRUE(has(parts, "pinned: 1 part(s) of the physical mesh (8 of its 16 vertices; the first holds vertex 8 (node id 2101) and 8 "
                         "vertices) touch no pinned vertex"))
      << ::testing::PrintToString(parts.warnings);
  EXPECT_TRUE(load_scene(write_temp("one.yaml", replace(good, "  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n", "")))
                  .free_parts.empty());
}

/// A block of 1200 tets with a speck of 6 beside it (a segmentation's noise): the free parts'
/// warning offers mesh.min_part_tets, which drops the speck; a value above every part is refused.
TEST(Scene, MinPartTetsDropsTheSpecksApartFromTheOrgan) {
  const TetMesh mesh = test::block_with_a_speck(0.05);
  const int nv = 11 * 11 * 3;  // the block's vertices: the speck's follow
  const std::string file = write_temp("speck.msh", msh22_text(mesh)).string();
  const std::string yaml = "mesh: {physical: " + file + "MIN}\ngravity: [0, 0, 0]\npinned:\n  - box: {min: [-1, -1, -1], max: [1, 1, 0.001]}\n";
  auto load = [&](const std::string& min) { return load_scene(write_temp("speck.yaml", replace(yaml, "MIN", min))); };
  const Scene kept = load("");
  ASSERT_EQ(kept.free_parts.size(), 1u);
  EXPECT_NE(kept.warnings.back().find("touch no pinned vertex"), std::string::npos);
  EXPECT_NE(kept.warnings.back().find("; 1 of them hold under 1% of the mesh's tets each (a segmentation's specks?): "
                                      "mesh.min_part_tets: 7 drops them"),
            std::string::npos)
      << kept.warnings.back();
  EXPECT_EQ(speck_parts(kept.physical), (std::vector<std::pair<int, int>>{{nv, 6}}));

  const Scene dropped = load(", min_part_tets: 7");
  EXPECT_EQ(dropped.physical.tets.size(), 1200u);
  EXPECT_EQ(dropped.physical.vertices.size(), static_cast<std::size_t>(nv));
  EXPECT_TRUE(dropped.free_parts.empty());
  ASSERT_FALSE(dropped.warnings.empty());
  EXPECT_NE(dropped.warnings.front().find("mesh.min_part_tets 7: dropped 1 part of " + file + " (6 tets; the largest 6), kept 1"),
            std::string::npos)
      << dropped.warnings.front();
  EXPECT_EQ(load(", min_part_tets: 6").physical.tets.size(), 1206u);  // the speck has 6: kept
  try {
    load(", min_part_tets: 1201");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'mesh.min_part_tets': 1201 drops every part of " + file +
                                         " (its largest holds 1200 tets)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Scene, ObjVirtualSurfaceSphereAndHalfspaceInCentimetres) {
  const Scene s = load_scene(data("scene/cube_obj.yaml"));
  EXPECT_EQ(s.spec.virtual_mesh, data("mesh/cube.obj").lexically_normal());
  EXPECT_NEAR(s.physical.vertices[2].y, 0.1, kTol);  // node 55 at (10, 10, 10) cm
  ASSERT_EQ(s.virtual_surface.vertices.size(), 8u);
  EXPECT_NEAR(s.virtual_surface.vertices[7].z, 0.1, kTol);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  // sphere of 0.5 cm at the origin: vertex 1; half-space x >= 10 cm: vertices 0, 2, 4, 6
  EXPECT_EQ(s.pinned, (std::vector<int>{0, 1, 2, 4, 6}));
}

// The cube's surface as an STL, ASCII or binary (.STL in capitals too): the OBJ's surface in metres,
// its corners one vertex each without a warning of merged vertices.
TEST(Scene, StlVirtualSurfaceIsTheObjs) {
  const Scene obj = load_scene(data("scene/cube_obj.yaml"));
  for (const char* name : {"cube_ascii.stl", "cube_binary.stl"}) {
    SCOPED_TRACE(name);
    const std::filesystem::path copy = write_temp(std::string(name) == "cube_binary.stl" ? "CUBE.STL" : name,
                                                  slurp(data(std::string("mesh/") + name)));
    const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube.obj", copy.string()),
                                     "../mesh/cube41.msh", data("mesh/cube41.msh").string());
    const Scene stl = load_scene(write_temp("stl.yaml", yaml));
    ASSERT_EQ(stl.virtual_surface.vertices.size(), 8u);
    ASSERT_EQ(stl.virtual_surface.triangles.size(), obj.virtual_surface.triangles.size());
    for (std::size_t f = 0; f < obj.virtual_surface.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(stl.virtual_surface.vertices[stl.virtual_surface.triangles[f][k]],
                  obj.virtual_surface.vertices[obj.virtual_surface.triangles[f][k]]);
    EXPECT_EQ(stl.warnings, obj.warnings);
  }
}

// The cube's surface as PLY (ASCII, binary) and VTK polydata (legacy, XML): the OBJ's surface in
// metres, the same warnings (the polydata's +x face is a strip: the same corners, split otherwise).
TEST(Scene, PlyAndVtkPolydataVirtualSurfacesAreTheObjs) {
  const Scene obj = load_scene(data("scene/cube_obj.yaml"));
  for (const char* name : {"cube.ply", "cube_be.ply", "cube_poly.vtk", "cube_poly_vtk9.vtp"}) {
    SCOPED_TRACE(name);
    const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube.obj", data(std::string("mesh/") + name).string()),
                                     "../mesh/cube41.msh", data("mesh/cube41.msh").string());
    const Scene other = load_scene(write_temp("surface.yaml", yaml));
    ASSERT_EQ(other.virtual_surface.vertices.size(), 8u);
    for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(other.virtual_surface.vertices[i], obj.virtual_surface.vertices[i]);
    ASSERT_EQ(other.virtual_surface.triangles.size(), 12u);
    for (std::size_t f = 0; f < 10; ++f) EXPECT_EQ(other.virtual_surface.triangles[f], obj.virtual_surface.triangles[f]);
    EXPECT_EQ(other.warnings, obj.warnings);
  }
}

TEST(Scene, ObjTriangleSoupIsMergedWithAWarning) {
  // cube.obj's 12 triangles, each with its own 3 corners (as an STL converted to OBJ has them)
  const SurfaceMesh cube = read_obj(data("mesh/cube.obj"));
  std::string soup;
  for (const Tri& t : cube.triangles)
    for (int v : t) {
      const Vec3d& p = cube.vertices[v];
      soup += "v " + std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
    }
  for (int f = 0; f < 12; ++f)
    soup += "f " + std::to_string(3 * f + 1) + " " + std::to_string(3 * f + 2) + " " + std::to_string(3 * f + 3) + "\n";
  write_temp("soup.obj", soup);
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", "soup.obj");
  const fs::path p = write_temp("soup.yaml", yaml);
  const Scene s = load_scene(p);
  ASSERT_EQ(s.warnings.size(), 1u) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(s.warnings[0], (p.parent_path() / "soup.obj").string() + ": merged 28 vertices at the position of another");
  // the cube again: its 8 corners, in the order the soup first names them, and the same faces
  const Scene plain = load_scene(data("scene/cube_obj.yaml"));
  ASSERT_EQ(s.virtual_surface.vertices.size(), 8u);
  ASSERT_EQ(s.virtual_surface.triangles.size(), 12u);
  for (std::size_t f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(s.virtual_surface.vertices[s.virtual_surface.triangles[f][k]],
                plain.virtual_surface.vertices[plain.virtual_surface.triangles[f][k]]);
  EXPECT_EQ(s.virtual_surface.triangles[0], (Tri{0, 1, 2}));
}

// A face given twice (here once flipped) would count twice in surface contact: removed, warned.
TEST(Scene, RepeatedObjFacesAreRemovedWithAWarning) {
  write_temp("twice.obj", slurp(data("mesh/cube.obj")) + "f 1 3 4\nf 4 3 1\n");
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", "twice.obj");
  const fs::path p = write_temp("twice.yaml", yaml);
  const Scene s = load_scene(p);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  ASSERT_EQ(s.warnings.size(), 1u) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(s.warnings[0], (p.parent_path() / "twice.obj").string() +
                               ": removed 2 faces that repeat another's vertices (surface contact would count them twice)");
}

// Faces with no area (corners on one line, as a mesh tool's fill along an edge leaves): removed
// and said, not read as a hole (their edges are each one face's); a surface of nothing but such
// faces is refused.
TEST(Scene, ObjFacesWithNoAreaAreRemovedWithAWarning) {
  // two points on the cube's edge from vertex 1 (0,0,0) to 2 (10,0,0), and two flat faces on it
  write_temp("flat.obj", slurp(data("mesh/cube.obj")) + "v 5 0 0\nv 2.5 0 0\nf 1 9 2\nf 1 10 9\n");
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", "flat.obj");
  const fs::path p = write_temp("flat.yaml", yaml);
  const Scene s = load_scene(p);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  EXPECT_EQ(s.virtual_surface.vertices.size(), 8u);
  ASSERT_EQ(s.warnings.size(), 2u) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(s.warnings[0], (p.parent_path() / "flat.obj").string() +
                               ": removed 2 faces with no area (corners on one line): they cover nothing, and their "
                               "edges would read as a hole");
  EXPECT_EQ(s.warnings[1], (p.parent_path() / "flat.obj").string() + ": removed 2 vertices used by no face");
  write_temp("line.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  try {
    (void)load_scene(write_temp("line.yaml", replace(yaml, "flat.obj", "line.obj")));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line.obj: every face has no area (its corners on one line)"), std::string::npos)
        << e.what();
  }
}

TEST(Scene, StrayObjVerticesAreRemovedWithAWarning) {
  write_temp("stray.obj", slurp(data("mesh/cube.obj")) + "v 50 50 50\nv 60 60 60\n");
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", "stray.obj");
  const fs::path p = write_temp("stray.yaml", yaml);
  const Scene s = load_scene(p);
  EXPECT_EQ(s.virtual_surface.vertices.size(), 8u);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  ASSERT_EQ(s.warnings.size(), 1u) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(s.warnings[0], (p.parent_path() / "stray.obj").string() + ": removed 2 vertices used by no face");
}

// A face's corner far off the physical mesh (one stray point 2 km off, or an exporter's 1e300 for a
// point it could not place) is no surface of it: refused naming where the corner lies, before the
// weld. The corner's bounding box once set the weld's tolerance: 2 km off a 100 mm surface, 506
// of its 530 vertices merged (the stray one among them) and the scene loaded; at 1e300 every
// face lost a corner ("every face has a repeated vertex").
TEST(Scene, AVirtualVertexFarOffThePhysicalMeshIsRefused) {
  for (const auto& [far, said] : {std::pair{"2e5", "2e+03 m off the physical mesh (the virtual vertex at 2000, 0.1, 0.1 m "},
                                  std::pair{"1e300", "1e+298 m off the physical mesh (the virtual vertex at 1e+298, 0.1, 0.1 m "}}) {
    SCOPED_TRACE(far);  // cm, cube_obj.yaml's unit
    write_temp("far.obj", replace(slurp(data("mesh/cube.obj")), "v 10 10 10\r\n", std::string("v ") + far + " 10 10\r\n"));
    const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                             data("mesh/cube41.msh").string()),
                                     "../mesh/cube.obj", "far.obj");
    const fs::path p = write_temp("far.yaml", yaml);
    try {
      (void)load_scene(p);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), (p.parent_path() / "far.obj").string() +
                                           ": mesh.virtual: the virtual mesh lies up to " + said +
                                           "lies that far outside its bounding box), more than 10 times its diagonal "
                                           "(0.173 m): it is not a surface of this mesh; is it in mesh.unit and the "
                                           "physical mesh's frame (mesh.transform places both)?");
    }
  }
}

// A stray corner within that limit (5 diagonals off) does not widen the weld either: a seam 5 um
// apart, welded at 1e-5 of the cube's 173 mm diagonal (1.7 um), stays open; the stray corner's
// 1 m box once welded it at 10 um.
TEST(Scene, AStrayVirtualVertexDoesNotWidenTheWeld) {
  const SurfaceMesh cube = read_obj(data("mesh/cube.obj"));
  std::string obj;
  for (Vec3d p : cube.vertices) {
    if (p == Vec3d{10, 10, 10}) p = {100, 10, 10};  // cm
    char line[96];
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
    obj += line;
  }
  obj += "v 0.0005 0 0\n";  // vertex 9: vertex 1's copy in the first face, a seam 5 um apart
  for (std::size_t f = 0; f < cube.triangles.size(); ++f) {
    obj += "f";
    for (const int v : cube.triangles[f]) obj += ' ' + std::to_string(f == 0 && v == 0 ? 9 : v + 1);
    obj += "\n";
  }
  write_temp("seam.obj", obj);
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", "seam.obj");
  const Scene s = load_scene(write_temp("seam.yaml", yaml));
  EXPECT_EQ(s.virtual_surface.vertices.size(), 9u);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("merged"), std::string::npos) << w;
}

TEST(Scene, ImplausibleTissueValuesAreShownAsGiven) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const std::string p =
      write_temp("tiny.yaml", replace(replace(good, "density: 1100", "density: 1e-30"), "k_vol: 2500", "k_vol: 2.5e9"))
          .string();
  const Scene s = load_scene(p);
  EXPECT_EQ(s.warnings.at(0), p + ": stiffness.k_vol = 2.5e+09 Pa is outside soft tissue's 10 Pa .. 100 MPa");
  EXPECT_EQ(s.warnings.at(1), p + ": material.density = 1e-30 kg/m^3 is outside soft tissue's 100 .. 3000 kg/m^3");
  // A value a larger unit puts in range is named in it: g/cm^3 written as kg/m^3, kPa as Pa.
  const Scene units = load_scene(p, {"material.density=1.06", "stiffness.k_vol=5"});
  EXPECT_EQ(units.warnings.at(0), "--set 'stiffness.k_vol=5': stiffness.k_vol = 5 Pa is outside soft tissue's 10 Pa .. "
                                  "100 MPa (in kPa? 5 kPa is 5000 Pa)");
  EXPECT_EQ(units.warnings.at(1), "--set 'material.density=1.06': material.density = 1.06 kg/m^3 is outside soft "
                                  "tissue's 100 .. 3000 kg/m^3 (in g/cm^3? 1.06 g/cm^3 is 1060 kg/m^3)");
  // A volume stiffness so far above k_vol that the tissue is all but incompressible (the physical
  // solve makes little headway); the scenes' 3 times k_vol is quiet.
  const std::string q = write_temp("stiff.yaml", good).string();
  const Scene incompressible = load_scene(q, {"stiffness.k_det=1e6"});
  ASSERT_FALSE(incompressible.warnings.empty());
  EXPECT_EQ(incompressible.warnings[0].rfind("--set 'stiffness.k_det=1e6': stiffness.k_det = 1e+06 Pa is 400 times k_vol "
                                             "(Poisson's ratio 0.499376; tissue's is 0.45-0.49",
                                             0),
            0u)
      << incompressible.warnings[0];
  EXPECT_TRUE(load_scene(q, {"stiffness.k_det=7500"}).warnings.empty());
}

// Tissue too soft to carry its own weight (density g height / k_vol above 1) has no static
// equilibrium near its rest shape: warned with the strain and the height it is taken over; the
// same tissue without gravity is quiet.
TEST(Scene, TissueTooSoftForItsOwnWeightWarns) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const std::string soft = replace(good, "k_vol: 2500", "k_vol: 50");
  const std::string p = write_temp("soft.yaml", soft).string();
  const Scene s = load_scene(p);
  ASSERT_EQ(s.warnings.size(), 1u) << ::testing::PrintToString(s.warnings);
  // 1100 kg/m^3 x 9.81 m/s^2 x 0.01 m / 50 Pa
  EXPECT_EQ(s.warnings[0].rfind(p + ": the tissue is too soft to carry its own weight: material.density x |gravity| x "
                                    "the mesh's height along gravity (0.01 m) / stiffness.k_vol = 2.1582 (above 1", 0), 0u)
      << s.warnings[0];
  EXPECT_TRUE(too_soft_for_own_weight(load_scene(write_temp("stiff.yaml", good))).empty());
  EXPECT_TRUE(load_scene(write_temp("floating.yaml", replace(soft, "gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]")))
                  .warnings.empty());
}

// The tool's springs, the virtual mesh's and the device's force limit warn outside a wide range
// around what a haptic device renders: a denormal or an absurd value is a typing error.
TEST(Scene, ImplausibleToolAndSurfaceStiffnessesWarn) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  EXPECT_TRUE(load_scene(write_temp("plausible.yaml", good)).warnings.empty());
  std::string bad = replace(good, "k_s: 25, k_svc: 55, k_con: 450, k_vcs: 320, k_vct: 0.35",
                            "k_s: 5e-324, k_svc: 2e6, k_con: 5e-324, k_vcs: 1e6, k_vct: 1e12");
  bad = replace(bad, "force_limit: 3.3", "force_limit: 5e-324");
  const std::string p = write_temp("implausible.yaml", bad).string();
  const Scene s = load_scene(p);
  // The tool's stiffnesses are the replay's to warn about (replays that differ only in them share
  // a scene); the surface springs and the force limit are the scene's.
  const std::vector<std::string> tool = tool_stiffness_warnings(s.spec);
  ASSERT_EQ(tool.size(), 3u) << ::testing::PrintToString(tool);
  EXPECT_EQ(tool[0], p + ": stiffness.k_con = 4.94066e-324 N/m is outside 100 .. 100000 N/m, the range of a haptic "
                         "device's stiffness (about 0.1 .. 10 kN/m)");
  EXPECT_EQ(tool[1], p + ": stiffness.k_vcs = 1e+06 N/m is outside 100 .. 100000 N/m, the range of a haptic "
                         "device's stiffness (about 0.1 .. 10 kN/m)");
  EXPECT_EQ(tool[2], p + ": stiffness.k_vct = 1e+12 N m/rad is outside 0.0001 .. 100 N m/rad, the range of a "
                         "haptic device's rotational stiffness");
  ASSERT_EQ(s.warnings.size(), 3u) << ::testing::PrintToString(s.warnings);
  EXPECT_NE(s.warnings[0].find("stiffness.k_s = 4.94066e-324 N/m is outside 0.01 .. 1e+06 N/m"), std::string::npos);
  EXPECT_NE(s.warnings[1].find("stiffness.k_svc = 2e+06 N/m is outside 0.01 .. 1e+06 N/m"), std::string::npos);
  EXPECT_EQ(s.warnings[2], p + ": tool.force_limit = 4.94066e-324 N is outside 0.01 .. 100 N, the range of a haptic "
                               "device's force (a Geomagic Touch: 3.3 N)");
  // Soft enough to render next to nothing (the tool sinks into the tissue) is warned too.
  const std::string q = write_temp("plausible.yaml", good).string();
  const std::vector<std::string> soft = tool_stiffness_warnings(load_scene_spec(q, {"stiffness={k_con: 10, k_vcs: 99}"}));
  ASSERT_EQ(soft.size(), 2u) << ::testing::PrintToString(soft);
  EXPECT_NE(soft[0].find("stiffness.k_con = 10 N/m is outside 100 .. 100000 N/m"), std::string::npos) << soft[0];
  EXPECT_NE(soft[1].find("stiffness.k_vcs = 99 N/m is outside 100 .. 100000 N/m"), std::string::npos) << soft[1];
  // Stabilisation springs many times the coupling hold the virtual tool back from the device.
  EXPECT_TRUE(tool_stiffness_warnings(load_scene_spec(q, {"tool.stabilization={translation: 3200, rotation: 3.5}"})).empty());
  const std::vector<std::string> held =
      tool_stiffness_warnings(load_scene_spec(q, {"tool.stabilization={translation: 320000, rotation: 35}"}));
  ASSERT_EQ(held.size(), 2u) << ::testing::PrintToString(held);
  EXPECT_EQ(held[0], "--set 'tool.stabilization={translation: 320000, rotation: 35}': tool.stabilization.translation = "
                     "320000 is 1000 times stiffness.k_vcs: the virtual tool moves about 1/1001 of the way to the device a "
                     "tick and lags behind a moving device, rendered as force");
  EXPECT_NE(held[1].find("tool.stabilization.rotation = 35 is 100 times stiffness.k_vct"), std::string::npos) << held[1];
}

// A warning about a value an override gave names the override, as its errors do; the file's own
// values still name the file.
TEST(Scene, WarningsNameTheOverrideThatGaveTheValue) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const std::string p = write_temp("named.yaml", replace(good, "density: 1100", "density: 1e-30")).string();
  const Scene s = load_scene(p, {"stiffness={k_vol: 2.5e9}", "stiffness.k_con=1e9"});
  ASSERT_EQ(s.warnings.size(), 3u) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(s.warnings[0], "--set 'stiffness={k_vol: 2.5e9}': stiffness.k_vol = 2.5e+09 Pa is outside soft tissue's "
                           "10 Pa .. 100 MPa");
  EXPECT_EQ(s.warnings[1], p + ": material.density = 1e-30 kg/m^3 is outside soft tissue's 100 .. 3000 kg/m^3");
  EXPECT_EQ(s.warnings[2].rfind("--set 'stiffness={k_vol: 2.5e9}': stiffness.k_vol x the virtual mesh's mean edge", 0), 0u)
      << s.warnings[2];
  EXPECT_EQ(tool_stiffness_warnings(s.spec).at(0).rfind("--set 'stiffness.k_con=1e9': stiffness.k_con = 1e+09 N/m", 0), 0u);
  // An error of a placement an override gave names the override.
  try {
    (void)load_scene(p, {"mesh.transform.scale=1e-300"});
    FAIL();
  } catch (const OverrideError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--set 'mesh.transform.scale=1e-300': key 'mesh.transform.scale': ", 0), 0u)
        << e.what();
  }
}

TEST(Scene, TheOtherToolKindsKeysAreReadAndWarnedAsUnused) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  // a hook scene's own block is read in tool.unit; an empty block of the other kind gives no key
  const std::string forceps_block = "forceps: {jaw_length: 8, jaw_width: 5, jaw_thickness: 2, jaw_max_angle_deg: 30,\n"
                                    "            grasp_threshold: 0.2, soft_margin: 2, eta: 1.5}";
  ASSERT_NE(good.find(forceps_block), std::string::npos);
  const SceneSpec hook = load_scene_spec_text(
      replace(replace(good, "kind: forceps", "kind: hook\n  hook: {tip_length: 6, tip_radius: 1.0}"), forceps_block, "forceps: {}"),
      "hook.yaml");
  EXPECT_NEAR(hook.tool.hook.tip_length, 0.006, kTol);
  EXPECT_NEAR(hook.tool.hook.tip_radius, 0.001, kTol);
  EXPECT_FALSE(hook.tool.other_kind_keys);
  // a forceps scene with a hook block (copied from a hook scene): read, unused, warned
  const std::string p = write_temp("both.yaml", replace(good, "kind: forceps", "kind: forceps\n  hook: {tip_length: 6}")).string();
  const Scene both = load_scene(p);
  EXPECT_NEAR(both.spec.tool.hook.tip_length, 0.006, kTol);
  ASSERT_EQ(both.warnings.size(), 1u) << ::testing::PrintToString(both.warnings);
  EXPECT_EQ(both.warnings[0], p + ": tool.hook is given, but tool.kind is forceps: its keys are not used");
  // the resolved scene writes the kind's block only, and loads without the warning
  const std::string resolved = resolved_scene_yaml(both.spec);
  EXPECT_EQ(resolved.find("hook:"), std::string::npos) << resolved;
  EXPECT_NE(resolved.find("forceps:"), std::string::npos) << resolved;
  EXPECT_TRUE(build_scene(load_scene_spec_text(resolved, "resolved.yaml")).warnings.empty());
  // an override that gives a forceps key to a hook scene is named
  const std::string cube = write_temp("cube.yaml", good).string();
  const Scene hooked = load_scene(cube, {"tool.kind=hook", "tool.forceps.release_threshold=0.3"});
  ASSERT_EQ(hooked.warnings.size(), 1u) << ::testing::PrintToString(hooked.warnings);
  EXPECT_EQ(hooked.warnings[0], "--set 'tool.forceps.release_threshold=0.3': tool.forceps is given, but tool.kind is "
                                "hook: its keys are not used");
}

TEST(Scene, UnitsScaleEveryLength) {
  const std::string mm = slurp(data("scene/cube.yaml"));
  std::string m = mm;
  for (int i = 0; i < 3; ++i) m = replace(m, "unit: mm", "unit: m");  // unit, mesh.unit, tool.unit
  m = replace(m, "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const Scene a = load_scene(data("scene/cube.yaml"));
  const Scene b = load_scene(write_temp("cube_m.yaml", m));
  for (std::size_t v = 0; v < a.physical.vertices.size(); ++v)
    EXPECT_NEAR(a.physical.vertices[v].x * 1000.0, b.physical.vertices[v].x, 1e-12);  // rounding of * 0.001
  EXPECT_NEAR(a.spec.tool.shaft_length * 1000.0, b.spec.tool.shaft_length, 1e-12);
  EXPECT_EQ(a.spec.tool.forceps.jaw_max_angle_deg, b.spec.tool.forceps.jaw_max_angle_deg);
  EXPECT_EQ(a.spec.stiffness.k_vol, b.spec.stiffness.k_vol);
}

// ---- mesh.unit, mesh.transform, tool.unit ------------------------------------------------------

/// A scene on cube22.msh (a 10-unit cube; node 101 at (10, 0, 10), vertex 0) with `extra` YAML.
fs::path cube_scene(const std::string& name, const std::string& extra) {
  // k_svc for a coupling as stiff as the tissue at its 10 cm edges when the scene is in cm
  return write_temp(name, "mesh: {physical: " + data("mesh/cube22.msh").string() +
                              "}\npinned: [{group: bottom}]\nstiffness: {k_svc: 200}\n" + extra);
}

// A mesh from a CAD export in inches, the tool in inches too: node 101 at (10, 0, 10) in lands at
// 0.254 m, the shaft's 0.1 in radius is 2.54 mm; the resolved scene writes them back in inches.
TEST(MeshTransform, AnInchMeshAndToolAreReadInInches) {
  const Scene s = load_scene(cube_scene("inches.yaml", "unit: in\ntool: {kind: hook, shaft_radius: 0.1, shaft_length: 12}\n"));
  EXPECT_EQ(s.spec.mesh_unit_name, "in");
  EXPECT_EQ(s.spec.tool.unit_name, "in");
  // One product by 0.0254 each: a rounding or two of ~3e-17 (0.254) and ~4e-19 (0.00254).
  EXPECT_NEAR(s.physical.vertices[0].x, 0.254, 1e-15);
  EXPECT_NEAR(s.spec.tool.shaft_radius, 0.00254, 1e-15);
  EXPECT_NE(resolved_scene_yaml(s.spec).find("unit: in"), std::string::npos);
}

// The mesh file in cm, scaled by 2, turned a quarter turn about +z and moved by (1, 2, 3) cm; the
// rest of the scene (pins, tool) in mm. Node 101 at (10, 0, 10) cm = (0.1, 0, 0.1) m -> scale
// (0.2, 0, 0.2) -> R_z(90) (0, 0.2, 0.2) -> + (0.01, 0.02, 0.03) = (0.01, 0.22, 0.23) m.
TEST(MeshTransform, ACentimetreMeshLandsWhereItsTransformPutsIt) {
  const std::string obj = data("mesh/cube.obj").string();
  const auto p = write_temp("placed.yaml", "unit: mm\n"
                                           "mesh:\n  physical: " + data("mesh/cube22.msh").string() + "\n"
                                           "  virtual: " + obj + "\n"
                                           "  unit: cm\n"
                                           "  transform: {scale: 2, rotvec_deg: [0, 0, 90], translate: [1, 2, 3]}\n"
                                           "pinned:\n  - box: {min: [9, 219, 229], max: [11, 221, 231]}\n"
                                           "stiffness: {k_svc: 300}\n"
                                           "tool: {kind: hook, shaft_radius: 2.5, shaft_length: 330}\n");
  const Scene s = load_scene(p);
  EXPECT_EQ(s.spec.mesh_unit_name, "cm");
  EXPECT_EQ(s.spec.mesh_transform.scale, 2.0);
  EXPECT_EQ(s.spec.mesh_transform.rotvec_deg, Vec3d(0, 0, 90));
  EXPECT_NEAR(s.spec.mesh_transform.translate.y, 0.02, kTol);  // mesh.unit, in metres
  // sin and cos of a quarter turn are exact to ~1e-17; the lengths are ~0.2 m
  const Vec3d v0 = s.physical.vertices[0];
  EXPECT_NEAR(v0.x, 0.01, 1e-15);
  EXPECT_NEAR(v0.y, 0.22, 1e-15);
  EXPECT_NEAR(v0.z, 0.23, 1e-15);
  // the box pin is in world mm, after the transform: it holds node 101 alone
  EXPECT_EQ(s.pinned, (std::vector<int>{0}));
  // the OBJ virtual mesh is placed by the same transform: its (10, 0, 10) corner (vertex 5) too
  EXPECT_NEAR(s.virtual_surface.vertices[5].y, 0.22, 1e-15);
  EXPECT_NEAR(s.virtual_surface.vertices[5].z, 0.23, 1e-15);
  // the tool stays in the scene's mm: the mesh's unit does not rescale it
  EXPECT_NEAR(s.spec.tool.shaft_radius, 0.0025, kTol);
  EXPECT_NEAR(s.spec.tool.shaft_length, 0.33, kTol);
  ASSERT_EQ(s.warnings.size(), 1u) << ::testing::PrintToString(s.warnings);  // the one pinned vertex, said
  EXPECT_NE(s.warnings[0].find("pinned at 1 vertex: they can turn about it"), std::string::npos) << s.warnings[0];
  // the same point through MeshTransform's own functions, and back
  const Vec3d back = s.spec.mesh_transform.inverse(v0);
  EXPECT_NEAR(back.x, 0.1, 1e-15);
  EXPECT_NEAR(back.y, 0.0, 1e-15);
  EXPECT_NEAR(back.z, 0.1, 1e-15);
}

// A scene that does not use the new keys, or gives them their default values, loads to the same
// bits: the committed scenes' replays do not change.
TEST(MeshTransform, OldScenesAndDefaultValuesGiveTheSameBits) {
  for (const auto& e : fs::directory_iterator(fs::path(EBH_SOURCE_DIR) / "scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    const Scene a = load_scene(e.path());
    const std::string u = a.spec.unit_name;
    const Scene b = load_scene(e.path(), {"mesh.unit=" + u, "tool.unit=" + u,
                                          "mesh.transform={scale: 1, rotvec_deg: [0, 0, 0], translate: [0, 0, 0]}"});
    ASSERT_EQ(a.physical.vertices.size(), b.physical.vertices.size());
    for (std::size_t v = 0; v < a.physical.vertices.size(); ++v)
      ASSERT_EQ(a.physical.vertices[v], b.physical.vertices[v]) << e.path() << " vertex " << v;
    EXPECT_EQ(a.pinned, b.pinned);
    EXPECT_EQ(a.spec.tool.shaft_radius, b.spec.tool.shaft_radius);
    EXPECT_EQ(a.spec.tool.shaft_length, b.spec.tool.shaft_length);
    EXPECT_EQ(a.spec.tool.forceps.jaw_length, b.spec.tool.forceps.jaw_length);
    EXPECT_EQ(a.spec.tool.max_step, b.spec.tool.max_step);
    EXPECT_TRUE(a.warnings.empty()) << e.path() << ": " << a.warnings.front();
    // the resolved scene names the units it used
    EXPECT_EQ(resolved_scene_yaml(a.spec), resolved_scene_yaml(b.spec));
  }
}

// tool.unit is independent of unit and mesh.unit: the same tool in mm whatever the mesh's unit.
TEST(ToolUnit, ToolSizesKeepTheirOwnUnit) {
  const Scene cm = load_scene(cube_scene("cm.yaml", "unit: cm\ntool: {unit: mm, kind: forceps, shaft_radius: 2.5, "
                                                    "shaft_length: 330, max_step: 0.5, forceps: {jaw_length: 8, soft_margin: 2}}\n"));
  const SceneSpec mm = load_scene_spec(cube_scene("mm.yaml", "unit: mm\ntool: {kind: forceps, shaft_radius: 2.5, "
                                                             "shaft_length: 330, max_step: 0.5, forceps: {jaw_length: 8, soft_margin: 2}}\n"));
  const ToolSpec& a = cm.spec.tool;
  EXPECT_EQ(a.unit_name, "mm");
  EXPECT_EQ(a.shaft_radius, mm.tool.shaft_radius);
  EXPECT_EQ(a.shaft_length, mm.tool.shaft_length);
  EXPECT_EQ(a.max_step, mm.tool.max_step);
  EXPECT_EQ(a.forceps.jaw_length, mm.tool.forceps.jaw_length);
  EXPECT_EQ(a.forceps.soft_margin, mm.tool.forceps.soft_margin);
  EXPECT_NEAR(cm.physical.vertices[0].x, 0.1, kTol);  // the mesh in cm
  EXPECT_TRUE(cm.warnings.empty()) << cm.warnings.front();
}

bool has_warning(const Scene& s, const std::string& needle) {
  for (const auto& w : s.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

// A scene switched to a cm mesh with its tool sizes still written as mm numbers: a 3 m shaft,
// 2.5 cm shaft radius, 20 cm jaws next to a 17 cm cube. Each implausible size is a warning naming
// its key and the unit keys; declaring tool.unit: mm clears them.
TEST(SizeWarnings, AMisdeclaredToolUnitIsNamed) {
  const std::string tool = "kind: forceps, shaft_radius: 2.5, shaft_length: 300, forceps: {jaw_length: 20}";
  const auto p = cube_scene("misdeclared.yaml", "unit: cm\ntool: {" + tool + "}\n");
  const Scene bad = load_scene(p);
  ASSERT_EQ(bad.warnings.size(), 3u) << bad.warnings.front();
  for (const auto& w : bad.warnings) {
    EXPECT_EQ(w.rfind(p.string() + ": tool.", 0), 0u) << w;
    EXPECT_NE(w.find("is tool.unit (cm)"), std::string::npos) << w;
    EXPECT_EQ(w.find('\n'), std::string::npos) << w;
  }
  EXPECT_TRUE(has_warning(bad, "tool.forceps.jaw_length = 20 cm is larger than the physical mesh's bounding-box diagonal (17.3205 cm)"));
  EXPECT_TRUE(has_warning(bad, "tool.shaft_radius = 2.5 cm (25 mm): laparoscopic shafts are 3-12 mm across, and this one is over 20 mm; is tool.unit (cm) right?"));
  EXPECT_TRUE(has_warning(bad, "tool.shaft_length = 300 cm (3 m): laparoscopic shafts are about 0.3-0.45 m long"));
  const Scene good = load_scene(cube_scene("declared.yaml", "unit: cm\ntool: {unit: mm, " + tool.substr(0) + "}\n"));
  EXPECT_TRUE(good.warnings.empty()) << good.warnings.front();
  // In mm already, the size is said once.
  const Scene wide = load_scene(cube_scene("wide.yaml", "unit: cm\ntool: {unit: mm, kind: hook, shaft_radius: 15}\n"));
  EXPECT_TRUE(has_warning(wide, "tool.shaft_radius = 15 mm: laparoscopic shafts are 3-12 mm across, and this one is over 20 mm"));
  const Scene needle = load_scene(cube_scene("needle.yaml", "unit: cm\ntool: {unit: mm, kind: hook, shaft_radius: 0.4}\n"));
  EXPECT_TRUE(has_warning(needle, "tool.shaft_radius = 0.4 mm: laparoscopic shafts are 3-12 mm across, and this one is "
                                  "under 1 mm; is tool.unit (mm) right? (a needle or a micro-instrument of this size "
                                  "needs no change)"));
}

TEST(SizeWarnings, AMeshInTheWrongUnit) {
  // the 10-unit cube read as metres: a 17 m organ
  const std::string mesh = "mesh: {physical: " + data("mesh/cube22.msh").string();
  const Scene big = load_scene(write_temp("big.yaml", "unit: mm\n" + mesh + ", unit: m}\ntool: {kind: hook}\n"));
  ASSERT_FALSE(big.warnings.empty());
  EXPECT_NE(big.warnings[0].find("the physical mesh's bounding-box diagonal is 17.3205 m: organs are 1 mm .. 2 m across; is mesh.unit (m) right?"),
            std::string::npos) << big.warnings[0];
  // a tool size below a thousandth of the diagonal: the 1 mm hook tip radius next to a 17 m mesh
  EXPECT_TRUE(has_warning(big, "tool.hook.tip_radius = 1 mm is below 1/1000 of the physical mesh's bounding-box diagonal (17320.5 mm)"));
  // the transform's scale counts: scaled by 1e-5 it is a 0.17 mm speck
  const Scene small =
      load_scene(write_temp("small.yaml", "unit: mm\n" + mesh + ", transform: {scale: 1e-2}}\ntool: {kind: hook}\n"));
  EXPECT_TRUE(has_warning(small, "bounding-box diagonal is 0.173205 mm (0.000173205 m)"));
  // ... and the warnings name it beside the units when it is not 1
  EXPECT_TRUE(has_warning(small, "is mesh.unit (mm) or mesh.transform.scale (0.01) right?"));
  EXPECT_TRUE(has_warning(small, "is tool.unit (mm), mesh.unit (mm) or mesh.transform.scale (0.01) right?"));
  EXPECT_FALSE(has_warning(big, "mesh.transform.scale"));
}

// ---- bad keys and values -----------------------------------------------------------------------

struct BadScene : ::testing::Test {
  std::string good;
  BadScene() {
    good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  }
  /// Loads `text` as a scene; expects InputError "FILE: <needle>...".
  void expect(const std::string& text, const std::string& needle, bool full_load = false) {
    const auto p = write_temp("bad.yaml", text);
    try {
      if (full_load) {
        load_scene(p);
      } else {
        load_scene_spec(p);
      }
      ADD_FAILURE() << "no InputError (expected '" << needle << "')";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(p.string() + ":", 0), 0u) << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << "message: " << msg << "\nexpected: " << needle;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  }
};

TEST_F(BadScene, NotANumber) {
  // the other kind's block is read as strictly as the tool's own
  expect(replace(good, "  force_limit: 3.3", "  hook: {tip_length: abc}\n  force_limit: 3.3"),
         ": key 'tool.hook.tip_length': expected a positive number, got 'abc'");
}
TEST_F(BadScene, NotPositive) {
  expect(replace(good, "  force_limit: 3.3", "  hook: {tip_length: -6}\n  force_limit: 3.3"),
         "key 'tool.hook.tip_length': expected a positive number, got '-6'");
}
TEST_F(BadScene, NotFinite) { expect(replace(good, "density: 1100", "density: .nan"), "key 'material.density': expected a positive number, got '.nan'"); }
TEST_F(BadScene, MapForNumber) { expect(replace(good, "density: 1100", "density: {a: 1}"), "key 'material.density': expected a positive number, got a map"); }
TEST_F(BadScene, UnknownTopKey) { expect(good + "colour: red\n", "key 'colour': unknown key (known: name, description, unit"); }
TEST_F(BadScene, UnknownNestedKey) { expect(replace(good, "k_s: 25", "k_x: 25"), "key 'stiffness.k_x': unknown key (known: k_vol, k_s"); }
TEST_F(BadScene, VolumeStiffness) {
  expect(replace(good, "k_s: 25", "k_s: 25, k_det: -1"), "key 'stiffness.k_det': expected a number >= 0, got '-1'");
  expect(replace(good, "k_s: 25", "k_s: 25, k_det: 2e12"), "key 'stiffness.k_det': 2e+12 is beyond 1e12");
}
TEST_F(BadScene, BadEnum) { expect(replace(good, "kind: forceps", "kind: scalpel"), "key 'tool.kind': expected one of hook, forceps, got 'scalpel'"); }
TEST_F(BadScene, BadUnit) { expect(replace(good, "unit: mm", "unit: inch"), "key 'unit': expected one of m, cm, mm, in, got 'inch'"); }
TEST_F(BadScene, OutOfRange) { expect(replace(good, "damping: 0.05", "damping: 1.0"), "key 'damping': expected a number in [0, 1), got '1.0'"); }
TEST_F(BadScene, NotWhole) {
  expect(replace(good, "newton_iterations: 3", "newton_iterations: 2.5"), "key 'tool.newton_iterations': expected a whole number in [1, 100], got '2.5'");
}
TEST_F(BadScene, NewtonCalls) {
  // cube.yaml has solver.virtual_iterations: 5
  expect(replace(good, "newton_iterations: 3", "newton_iterations: 3\n  newton_calls: 6"),
         "key 'tool.newton_calls': expected all or at most solver.virtual_iterations (5), got 6");
  expect(replace(good, "newton_iterations: 3", "newton_iterations: 3\n  newton_calls: 0"),
         "key 'tool.newton_calls': expected all or a whole number in [1, 100000], got '0'");
  expect(replace(good, "newton_iterations: 3", "newton_iterations: 3\n  newton_calls: some"),
         "key 'tool.newton_calls': expected all or a whole number in [1, 100000], got 'some'");
}
TEST_F(BadScene, RefineRange) { expect(replace(good, "virtual_refine: 1", "virtual_refine: 2"), "key 'mesh.virtual_refine': expected a whole number in [0, 1]"); }
TEST_F(BadScene, BadRecovery) {
  expect(replace(good, "method: jacobi", "method: jacobi\n  recovery: restart"),
         "key 'solver.recovery': expected one of direct, none, got 'restart'");
  expect(replace(good, "method: jacobi", "method: jacobi\n  recovery_residual: 0"),
         "key 'solver.recovery_residual': expected a number in (0, 10000], got '0'");
}
TEST_F(BadScene, BadChebyshevRho) {
  expect(replace(good, "chebyshev_rho: 0.9", "chebyshev_rho: 1.5"),
         "key 'solver.chebyshev_rho': expected auto or a number in (0, 1), got '1.5'");
  expect(replace(good, "chebyshev_rho: 0.9", "chebyshev_rho: automatic"),
         "key 'solver.chebyshev_rho': expected auto or a number in (0, 1), got 'automatic'");
}
TEST_F(BadScene, BadStoppingRule) {
  expect(replace(good, "method: jacobi", "method: jacobi\n  physical_tolerance: -1"),
         "key 'solver.physical_tolerance': expected a number in [0, 10000], got '-1'");
  expect(replace(good, "method: jacobi", "method: jacobi\n  physical_max_iterations: 0"),
         "key 'solver.physical_max_iterations': expected a whole number in [1, 100000], got '0'");
  expect(replace(good, "method: jacobi", "method: jacobi\n  virtual_damping: -1"),
         "key 'solver.virtual_damping': expected a number in [0, 1e+06], got '-1'");
  expect(replace(good, "method: jacobi", "method: jacobi\n  virtual_damping: strong"),
         "key 'solver.virtual_damping': expected a number in [0, 1e+06], got 'strong'");
}
TEST_F(BadScene, NotBool) { expect(replace(good, "grasp: true", "grasp: maybe"), "key 'stages.grasp': expected true or false, got 'maybe'"); }
TEST_F(BadScene, ShortVector) { expect(replace(good, "gravity: [0, 0, -9.81]", "gravity: [0, 0]"), "key 'gravity': expected a list of 3 numbers"); }
TEST_F(BadScene, VectorElement) { expect(replace(good, "gravity: [0, 0, -9.81]", "gravity: [0, x, 0]"), "key 'gravity[1]': expected a number, got 'x'"); }
TEST_F(BadScene, ZeroUp) { expect(replace(good, "up: [0, 0, 2]", "up: [0, 0, 0]"), "key 'camera.up': expected a non-zero vector"); }
TEST_F(BadScene, MissingMeshFile) { expect(replace(good, "cube22.msh\n", "nope.msh\n"), "key 'mesh.physical': file not found: "); }
// A folder given as the mesh or the scene file is said to be one, not reported missing.
TEST_F(BadScene, FolderAsMeshOrScene) {
  const auto folder = write_temp("x", "").parent_path() / "folder.msh";
  std::filesystem::create_directories(folder);
  expect(replace(good, data("mesh/cube22.msh").string(), folder.string()),
         "key 'mesh.physical': " + folder.string() + " is a folder, not a file");
  try {
    load_scene_spec(folder);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), folder.string() + ": is a folder, not a file");
  }
  try {
    resolve_scene_path(folder.string());
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), folder.string() + ": is a folder, not a file");
  }
}
TEST_F(BadScene, MissingMeshSection) {
  std::string text = good;
  text.erase(text.find("mesh:"), text.find("material:") - text.find("mesh:"));
  expect(text, "key 'mesh': missing");
}
TEST_F(BadScene, MissingPhysical) {
  std::string text = good;
  const auto at = text.find("  physical:");
  text.erase(at, text.find('\n', at) + 1 - at);
  expect(text, "key 'mesh.physical': missing (required)");
}
TEST_F(BadScene, VirtualNotASurfaceFile) {
  expect(replace(good, "virtual: boundary", "virtual: cube.msh"),
         "key 'mesh.virtual': expected 'boundary' or a surface file (.obj, .stl, .ply, .vtk, .vtp), got 'cube.msh'");
}
TEST_F(BadScene, RateRatio) {
  expect(replace(good, "physical_hz: 50", "physical_hz: 300"), "key 'time.physical_hz': haptic_hz / physical_hz must be a whole number");
}
TEST_F(BadScene, TwoKindsInOneRegion) {
  expect(replace(good, "- group: bottom", "- {group: bottom, sphere: {center: [0, 0, 0], radius: 1}}"),
         "key 'pinned[0]': expected exactly one of group, box, sphere, halfspace");
}
TEST_F(BadScene, BoxMinAboveMax) { expect(replace(good, "max: [1, 1, 11]", "max: [1, -2, 11]"), "key 'pinned[1].box.max': expected max >= min"); }
TEST_F(BadScene, RegionMissingKey) { expect(replace(good, "min: [-1, -1, 9], ", ""), "key 'pinned[1].box.min': missing"); }
// A NUL would end the file name where the system reads it (loading the file before it).
TEST_F(BadScene, NulInAPath) {
  expect(replace(good, "physical: " + data("mesh/cube22.msh").string(),
                 "physical: \"" + data("mesh/cube22.msh").string() + "\\0x\""),
         "key 'mesh.physical': contains a NUL byte");
}
TEST_F(BadScene, DuplicateKey) { expect(replace(good, "damping: 0.05", "damping: 0.05\ndamping: 0.1"), "key 'damping': given twice"); }
// yaml-cpp stops at its nesting limit (its message "bad file"); 100000 levels of lists, maps or
// block lists are that one-line error naming the file, never a stack overflow; so is such a --set value.
TEST_F(BadScene, NestedTooDeeply) {
  const std::string nested = "nested too deeply (over 500 levels of lists and maps, yaml-cpp's limit";
  expect("gravity: " + std::string(100000, '['), nested);
  std::string maps;
  for (int i = 0; i < 100000; ++i) maps += "{a: ";
  expect(maps, nested);
  std::string block;
  for (int i = 0; i < 100000; ++i) block += "- ";
  expect(block, nested);
  std::string indented;  // 600 levels of block maps, one a line: the line yaml-cpp stopped at
  for (int i = 0; i < 600; ++i) indented += std::string(static_cast<std::size_t>(i), ' ') + "a:\n";
  expect(indented, nested);
  try {
    (void)load_scene_spec(data("scene/cube.yaml"), {"gravity=" + std::string(100000, '[')});
    ADD_FAILURE() << "a nested --set value was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),  // the value cut to 80 characters
              "--set 'gravity=" + std::string(72, '[') + "...': in the value: " + nested + "; ebh's files nest a few)");
  }
}
TEST_F(BadScene, YamlSyntax) { expect(replace(good, "gravity: [0, 0, -9.81]", "gravity: [0, 0, -9.81"), "YAML syntax error"); }
TEST_F(BadScene, NotAMap) { expect("- 1\n- 2\n", "not a scene file: a scene is a YAML map of keys (mesh, tool, ...), this file holds a list"); }
TEST_F(BadScene, Empty) { expect("# nothing\n", "empty scene file"); }
TEST_F(BadScene, BadMeshUnit) { expect(replace(good, "  unit: mm\n  transform", "  unit: inch\n  transform"), "key 'mesh.unit': expected one of m, cm, mm, in, got 'inch'"); }
TEST_F(BadScene, BadToolUnit) { expect(replace(good, "tool:\n  unit: mm", "tool:\n  unit: 3"), "key 'tool.unit': expected one of m, cm, mm, in, got '3'"); }
TEST_F(BadScene, ZeroScale) { expect(replace(good, "scale: 1,", "scale: 0,"), "key 'mesh.transform.scale': expected a positive number, got '0'"); }
TEST_F(BadScene, NegativeScale) { expect(replace(good, "scale: 1,", "scale: -2,"), "key 'mesh.transform.scale': expected a positive number, got '-2'"); }
TEST_F(BadScene, NonFiniteScale) { expect(replace(good, "scale: 1,", "scale: .inf,"), "key 'mesh.transform.scale': expected a positive number, got '.inf'"); }
TEST_F(BadScene, RotationArity) {
  expect(replace(good, "rotvec_deg: [0, 0, 0]", "rotvec_deg: [0, 90]"), "key 'mesh.transform.rotvec_deg': expected a list of 3 numbers");
}
TEST_F(BadScene, NonFiniteRotation) {
  expect(replace(good, "rotvec_deg: [0, 0, 0]", "rotvec_deg: [0, .nan, 0]"), "key 'mesh.transform.rotvec_deg[1]': expected a number, got '.nan'");
}
TEST_F(BadScene, OverflowingCoordinates) {
  // a scale that puts the 10 mm cube 1e148 m across; a file coordinate of 1e300
  expect(replace(good, "scale: 1,", "scale: 1e150,"),
         "key 'mesh.transform.scale': 1e+150 makes the physical mesh's size 1.73205e+148 m (17.3205 mm in the file): "
         "expected 1e-30 .. 1e+30 m, where its tets' volumes neither underflow nor overflow",
         true);
  const fs::path msh = write_temp("huge.msh", replace(slurp(data("mesh/cube22.msh")), "101 10 0 10\n", "101 1e300 0 10\n"));
  try {
    load_scene(write_temp("huge.yaml", replace(good, data("mesh/cube22.msh").string(), msh.string())));
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), msh.string() + ": vertex 0 (node 101) has a coordinate of 1e+300: beyond 1e+100, "
                                                    "where the tets' volumes overflow");
  }
}
TEST_F(BadScene, RotationPastATurn) {
  expect(replace(good, "rotvec_deg: [0, 0, 0]", "rotvec_deg: [0, 0, 1e300]"),
         "key 'mesh.transform.rotvec_deg': the rotation vector's angle is inf degrees; give one of at most 360");
}
TEST_F(BadScene, TranslateNotANumber) {
  expect(replace(good, "translate: [0, 0, 0]", "translate: [0, 0, up]"), "key 'mesh.transform.translate[2]': expected a number, got 'up'");
}
TEST_F(BadScene, UnknownTransformKey) {
  expect(replace(good, "scale: 1,", "shear: 1,"), "key 'mesh.transform.shear': unknown key (known: scale, rotvec_deg, translate)");
}
// The scene reader holds the tool to the tool model's ranges, so the error names the file and the
// key (not "tool: ... got 0.000000" from build_tool), and a length that is 0 in metres is refused.
TEST_F(BadScene, ToolValuesTheToolModelRefuses) {
  expect(replace(good, "soft_margin: 2", "soft_margin: 0"), "key 'tool.forceps.soft_margin': expected a positive number, got '0'");
  expect(replace(good, "jaw_max_angle_deg: 30", "jaw_max_angle_deg: 90"),
         "key 'tool.forceps.jaw_max_angle_deg': expected a number in (0, 90), got '90'");
  expect(replace(good, "max_step: 0.5", "max_step: 5e-324"), "key 'tool.max_step': '5e-324' is 0 m: expected a length a double carries, 2.22507e-308 .. 1.79769e+308 m");
  expect(replace(good, "soft_margin: 2", "soft_margin: 1e-310"), "key 'tool.forceps.soft_margin': '1e-310' is 1e-313 m: expected a length");
}
// A placement that loses the mesh: a scale under which its tets' volumes underflow, or a
// translation so far that round-off swallows its shape, is refused naming the key.
TEST_F(BadScene, PlacementThatLosesTheMesh) {
  expect(replace(good, "scale: 1,", "scale: 1e-300,"),
         "key 'mesh.transform.scale': 1e-300 makes the physical mesh's size", true);
  expect(replace(good, "scale: 1,", "scale: 1e300,"), "expected 1e-30 .. 1e+30 m, where its tets' volumes", true);
  expect(replace(good, "translate: [0, 0, 0]", "translate: [1e300, 0, 0]"),
         "key 'mesh.transform.translate': moves the physical mesh 1e+297 m away", true);
}
/// cube22.msh (a 10 mm cube) with every node moved by `f`, written to 17 digits.
template <class F>
std::string cube22_moved(F f) {
  const std::string text = slurp(data("mesh/cube22.msh"));
  const std::size_t from = text.find("$Nodes\n8\n") + 9, to = text.find("$EndNodes");
  std::istringstream nodes(text.substr(from, to - from));
  std::string moved;
  int id;
  Vec3d p;
  while (nodes >> id >> p.x >> p.y >> p.z) {
    const Vec3d q = f(p);
    char line[128];
    std::snprintf(line, sizeof line, "%d %.17g %.17g %.17g\n", id, q.x, q.y, q.z);
    moved += line;
  }
  return text.substr(0, from) + moved + text.substr(to);
}
// A mesh whose own coordinates lie far from the origin (a segmentation left in its scanner's
// frame) is refused naming its file and its distance, not a translation the scene does not give
// or one that brings it back. Where mesh.unit rounds those coordinates before any translation
// applies the fix is in the file; where nothing does, the translation to the origin, which loads.
TEST_F(BadScene, MeshFarFromTheOriginInItsFile) {
  const fs::path far = write_temp("far.msh", cube22_moved([](Vec3d p) { return p + Vec3d{1e13, 1e13, 1e13}; }));  // 1e10 m
  const std::string scene = replace(good, data("mesh/cube22.msh").string(), far.string());
  for (const std::string translate : {"[0, 0, 0]", "[-10000000000005, -10000000000005, -10000000000005]"}) {
    try {
      load_scene(write_temp("far.yaml", replace(scene, "translate: [0, 0, 0]", "translate: " + translate)));
      ADD_FAILURE() << "no InputError (translate " << translate << ")";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()),
                far.string() + ": the mesh's vertices lie 1.73205e+10 m from the origin (its centre), where the "
                               "coordinates' round-off changes its size from 0.0173205 to 0.0173209 m: move it near the "
                               "origin in its file (subtract its centre [10000000000005, 10000000000005, 10000000000005] "
                               "mm from every vertex): mesh.unit (mm) rounds the file's coordinates before "
                               "mesh.transform.translate applies, so no translation keeps its shape")
          << "translate " << translate;
    }
  }
  // A 1 mm cube in metres at 2^33 m (8.6e6 km), where a double's step doubles: a translation of
  // 0.3 mm rounds its two sides apart; the one the message names loads it whole.
  const fs::path across = write_temp("across.msh", cube22_moved([](Vec3d p) {
    return Vec3d{8589934592.0 + (p.x - 5) * 1e-4, p.y * 1e-4, p.z * 1e-4};
  }));
  std::string metres = replace(replace(good, data("mesh/cube22.msh").string(), across.string()), "  unit: mm\n  transform",
                               "  unit: m\n  transform");
  metres = replace(metres, "  - box: {min: [-1, -1, 9], max: [1, 1, 11]}\n", "");
  try {
    load_scene(write_temp("across.yaml", replace(metres, "translate: [0, 0, 0]", "translate: [0.0003, 0, 0]")));
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              across.string() + ": the mesh's vertices lie 8.58993e+09 m from the origin (its centre), where the "
                                "coordinates' round-off changes its size from 0.00173173 to 0.00173118 m: move it near the "
                                "origin (mesh.transform.translate: [-8589934592, -0.0005, -0.0005], in m)");
  }
  const Scene s = load_scene(
      write_temp("across.yaml", replace(metres, "translate: [0, 0, 0]", "translate: [-8589934592, -0.0005, -0.0005]")));
  EXPECT_LT(norm(bounding_box(s.physical.vertices).centre()), 1e-9);
}
TEST_F(BadScene, UnknownGroup) {
  expect(replace(good, "group: bottom", "group: bottm"),
         "key 'pinned[0].group': unknown group 'bottm' (known groups in " + data("mesh/cube22.msh").lexically_normal().string() +
             ": bottom, tissue, top)",
         true);
}
TEST_F(BadScene, RegionPinsNothing) {
  expect(replace(good, "max: [1, 1, 11]", "max: [1, 1, 9.5]"), "key 'pinned[1].box': the box pins no vertex", true);
}

TEST(SceneFile, Missing) {
  try {
    load_scene_spec("/nonexistent/scene.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/scene.yaml: scene file not found");
  }
}

TEST(SceneFile, UnreadableSaysWhy) {
  const fs::path p = write_temp("unreadable.yaml", "name: x\n");
  const auto message = test::error_when_unreadable(p, [](const fs::path& f) { (void)load_scene_spec(f); });
  if (!message) GTEST_SKIP() << "the file opens all the same (run as root)";
  EXPECT_EQ(*message, p.string() + ": cannot open scene file: Permission denied");
}

// ---- mesh checks at load -----------------------------------------------------------------------

TEST(SceneMesh, MixedOrientationFlippedPerTetWithWarning) {
  const std::string msh = replace(slurp(data("mesh/cube22.msh")), "22 4 2 1 1 101 250 55 1000", "22 4 2 1 1 250 101 55 1000");
  const auto mesh = write_temp("mixed.msh", msh);
  const Scene s = load_scene(write_temp("mixed.yaml", "unit: mm\nmesh: {physical: mixed.msh}\npinned: [{group: bottom}]\n"));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0], mesh.string() +
                               ": 1 of 5 tets were negatively oriented (their vertex order differs from the others'), "
                               "the first: tet 2 (element id 22); flipped them one by one");
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
  for (const Tet& t : s.physical.tets)
    EXPECT_GT(signed_volume(s.physical.vertices[t[0]], s.physical.vertices[t[1]], s.physical.vertices[t[2]],
                            s.physical.vertices[t[3]]),
              0.0);
}

TEST(SceneMesh, TangledMeshRefusedAfterFlipping) {
  // node 7, the corner (0, 0, 0), moved through its tet's opposite face
  const std::string msh = replace(slurp(data("mesh/cube22.msh")), "\n7 0 0 0\n", "\n7 5 5 5\n");
  const auto mesh = write_temp("tangled.msh", msh);
  const auto scene = write_temp("tangled.yaml", "mesh: {physical: tangled.msh}\n");
  try {
    load_scene(scene);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              mesh.string() +
                  ": 1 pair of tets on the same side of the face they share (one overlaps the other: a tet inside another, "
                  "or a fold), the first: tet 0 (element id 20) and tet 4 (element id 24) (after flipping the 1 "
                  "negatively oriented tets: tets inside out among their neighbours, a tangled mesh)");
  }
}

TEST(SceneMesh, NegativeOrientationFlippedWithWarning) {
  std::string msh = slurp(data("mesh/cube22.msh"));
  for (const char* tet : {"7 1000 3 250", "9 3 1000 55", "101 250 55 1000", "42 55 250 3", "1000 3 250 55"}) {
    std::string t = tet;
    const auto a = t.find(' '), b = t.find(' ', a + 1);
    const std::string swapped = t.substr(a + 1, b - a - 1) + " " + t.substr(0, a) + t.substr(b);
    msh = replace(msh, "1 1 " + t, "1 1 " + swapped);
  }
  write_temp("neg.msh", msh);
  const Scene s = load_scene(write_temp("neg.yaml", "unit: mm\nmesh: {physical: neg.msh}\npinned: [{group: bottom}]\n"));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("flipped"), std::string::npos);
  EXPECT_EQ(s.virtual_surface.triangles.size(), 12u);
}

TEST(SceneMesh, UnreferencedVertexRemovedWithWarning) {
  const std::string msh = replace(slurp(data("mesh/cube22.msh")), "$Nodes\n8\n", "$Nodes\n9\n77 5 5 5\n");
  write_temp("extra.msh", msh);
  const Scene s = load_scene(write_temp("extra.yaml", "unit: mm\nmesh: {physical: extra.msh}\npinned: [{group: bottom}]\n"));
  EXPECT_EQ(s.physical.vertices.size(), 8u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("removed 1 vertices used by no tet"), std::string::npos);
}

// A pinned surface group whose only triangle uses a vertex of no tet: the triangle goes with the
// vertex, the group pins nothing, and the error says why (the removal's warning comes only with a
// scene that loads).
TEST(SceneMesh, GroupOfARemovedVertexSaysWhyItPinsNothing) {
  const std::string msh = replace(replace(replace(slurp(data("mesh/cube22.msh")), "$Nodes\n8\n", "$Nodes\n9\n77 5 5 5\n"),
                                          "$PhysicalNames\n4\n", "$PhysicalNames\n5\n2 4 \"loose\"\n"),
                                  "$Elements\n13\n", "$Elements\n14\n30 2 2 4 4 77 7 1000\n");
  const fs::path mesh = write_temp("loose.msh", msh);
  const fs::path scene = write_temp("loose.yaml", "unit: mm\nmesh: {physical: loose.msh}\npinned: [{group: loose}]\n");
  try {
    (void)load_scene(scene);
    FAIL() << "a group that pins nothing was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), scene.string() + ": key 'pinned[0].group': the group 'loose' pins no vertex of the "
                                         "physical mesh: its triangles use node 77, which belongs to no tet, and were "
                                         "removed with it (" + mesh.string() + ": removed 1 vertices used by no tet)");
  }
  // Beside a group that pins vertices of tets, the same triangle costs nothing but the warning.
  const Scene s = load_scene(write_temp("loose_and_bottom.yaml", "unit: mm\nmesh: {physical: loose.msh}\n"
                                                                 "pinned: [{group: bottom}]\n"));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("removed 1 vertices used by no tet"), std::string::npos);
}

// ---- scene names -------------------------------------------------------------------------------

TEST(ResolveScenePath, NameInDataDir) {
  const auto root = write_temp("marker", "").parent_path();
  fs::create_directories(root / "scenarios");
  std::ofstream(root / "scenarios" / "zz_test_scene.yaml") << "# empty\n";
  ::setenv("EBH_DATA_DIR", root.c_str(), 1);
  EXPECT_EQ(resolve_scene_path("zz_test_scene"), root / "scenarios" / "zz_test_scene.yaml");
  ::unsetenv("EBH_DATA_DIR");
}

/// A recording names its scene by name or by the scene file's path relative to the recording's
/// folder (what `ebh import --scene FILE` writes), so the two move together.
TEST(ResolveScenePath, ARecordingsSceneIsFoundBesideIt) {
  const fs::path root = write_temp("marker", "").parent_path();
  fs::create_directories(root / "data" / "out");
  const fs::path scene = root / "data" / "organ.yaml", rec = root / "data" / "out" / "press.h5";
  std::ofstream(scene) << "# a scene\n";
  EXPECT_EQ(scene_attribute_for("organ.yaml", scene, rec), "../organ.yaml");
  EXPECT_EQ(scene_attribute_for("tube", resolve_scene_path("tube"), rec), "tube");  // a name stays one
  EXPECT_EQ(resolve_recording_scene("../organ.yaml", rec.string()), scene);
  EXPECT_EQ(resolve_recording_scene("tube", rec.string()), resolve_scene_path("tube"));
  // Read through a link from another folder: beside the file written, the link's target (it was
  // looked for beside the link, root/organ.yaml).
  const fs::path link = root / "press_link.h5";
  fs::remove(link);
  fs::create_symlink(rec, link);
  EXPECT_EQ(resolve_recording_scene("../organ.yaml", link.string()).lexically_normal(), scene);
  // Not beside the recording: refused naming where it looked, even with a file of that name in the
  // working folder (another scene: a validation replayed a copy with other stiffnesses silently).
  const fs::path cwd = fs::current_path();
  fs::current_path(root / "data");  // holds an organ.yaml
  try {
    resolve_recording_scene("organ.yaml", rec.string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), rec.string() + ": its scene attribute 'organ.yaml': no such file beside the "
                                     "recording (" + (root / "data" / "out" / "organ.yaml").string() +
                                     "): move the scene there, or replay the recording with the scene named");
  }
  fs::current_path(cwd);
  try {
    resolve_recording_scene("", rec.string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), rec.string() + ": its scene attribute is empty: the recording names no scene "
                                     "(`ebh import LOG -o REC --scene SCENE` records it)");
  }
}

/// A synthesis plan names a scene file relative to itself; the recording names the same file
/// relative to its own folder, wherever it is written.
TEST(ResolveScenePath, APlansSceneIsStoredRelativeToTheRecording) {
  const fs::path root = write_temp("marker", "").parent_path() / "plan_scene";
  fs::create_directories(root / "mesh");
  fs::create_directories(root / "plans");
  fs::create_directories(root / "out" / "sub" / "deeper");
  std::ofstream(root / "mesh" / "organ.yaml") << "# a scene\n";
  const fs::path plans = root / "plans", rec = root / "out" / "sub" / "deeper" / "press.h5";
  const std::string stored = scene_attribute_from("../mesh/organ.yaml", plans, rec);
  EXPECT_EQ(stored, "../../../mesh/organ.yaml");
  EXPECT_EQ(resolve_recording_scene(stored, rec.string()), (root / "mesh" / "organ.yaml").lexically_normal());
  EXPECT_EQ(scene_attribute_from("../mesh/organ.yaml", plans, plans / "press.h5"), "../mesh/organ.yaml");
  EXPECT_EQ(scene_attribute_from((root / "mesh" / "organ.yaml").string(), plans, rec), "../../../mesh/organ.yaml");
  EXPECT_EQ(scene_attribute_from("tube", plans, rec), "tube");          // a name stays one
  EXPECT_EQ(scene_attribute_from("own", plans, rec), "own");            // not looked up
  try {
    scene_attribute_from("organ.yaml", plans, rec);  // a path, and not beside the plan
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), (plans / "organ.yaml").string() + ": scene file not found");
  }
}

TEST(ResolveScenePath, Errors) {
  EXPECT_EQ(resolve_scene_path(data("scene/cube.yaml").string()), data("scene/cube.yaml"));
  try {
    resolve_scene_path("no_such_scene_zz");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no_such_scene_zz: no such scene (looked for ", 0), 0u) << e.what();
  }
  EXPECT_THROW(resolve_scene_path("/nonexistent/x.yaml"), InputError);
}

// A name is looked up in the data folders, never read from the working folder: a folder or a file
// of that name there is said (a folder given as the recording read as 'no such recording').
TEST(ResolveScenePath, WhatIsHereOfThatNameIsSaid) {
  const fs::path dir = write_temp("marker_here", "").parent_path() / "names_here";
  fs::create_directories(dir / "folder_zz");
  std::ofstream(dir / "file_zz") << "x";
  const fs::path old = fs::current_path();
  fs::current_path(dir);
  std::string folder_msg = "no error", file_msg = "no error";
  try {
    resolve_scene_path("folder_zz");
  } catch (const InputError& e) {
    folder_msg = e.what();
  }
  try {
    resolve_scene_path("file_zz");
  } catch (const InputError& e) {
    file_msg = e.what();
  }
  fs::current_path(old);
  EXPECT_NE(folder_msg.find("folder_zz: no such scene (looked for "), std::string::npos) << folder_msg;
  EXPECT_NE(folder_msg.find("); folder_zz in the working folder is a folder"), std::string::npos) << folder_msg;
  EXPECT_NE(file_msg.find("); a name is looked up there: give the file in the working folder as ./file_zz"), std::string::npos)
      << file_msg;
}

// The replay output's scene_yaml: every committed scene (hook and forceps, every region kind they
// use, mm and cm units), written resolved and loaded again, is the same scene bit for bit (the
// resolved text of both is equal, and it prints every double with 17 digits).
TEST(Scene, ResolvedYamlReloadsToTheSameScene) {
  const fs::path tmp = fs::temp_directory_path() / "ebh_test_resolved_scene.yaml";
  for (const auto& e : fs::directory_iterator(fs::path(EBH_SOURCE_DIR) / "scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    const SceneSpec spec = load_scene_spec(e.path(), {"stiffness.k_con=512.5", "tool.max_step=0.3"});
    const std::string yaml = resolved_scene_yaml(spec);
    std::ofstream(tmp) << yaml;
    const SceneSpec again = load_scene_spec(tmp);
    EXPECT_EQ(resolved_scene_yaml(again), yaml) << e.path();
    EXPECT_EQ(again.name, spec.name);
    EXPECT_EQ(again.stiffness.k_con, 512.5);
    EXPECT_EQ(again.tool.max_step, spec.tool.max_step) << e.path();
    EXPECT_EQ(again.tool.shaft_radius, spec.tool.shaft_radius) << e.path();
    // Every key of the tool's kind with its value in effect: a forceps' release threshold too when
    // it defaults to the grasp threshold.
    if (spec.tool.kind == ToolSpec::Kind::Forceps) {
      EXPECT_NE(yaml.find("release_threshold: " + std::to_string(spec.tool.forceps.release()).substr(0, 3)), std::string::npos)
          << e.path();
    }
    EXPECT_EQ(again.physical_mesh, fs::absolute(spec.physical_mesh).lexically_normal());
    ASSERT_EQ(again.pinned.size(), spec.pinned.size());
    for (std::size_t i = 0; i < spec.pinned.size(); ++i) {
      EXPECT_EQ(again.pinned[i].a, spec.pinned[i].a) << e.path() << " region " << i;
      EXPECT_EQ(again.pinned[i].b, spec.pinned[i].b) << e.path() << " region " << i;
    }
  }
  fs::remove(tmp);
}

// tool.newton_calls: `all` (the default, 0) or a count up to solver.virtual_iterations, checked
// after every override (so a plan may lower both together); written back as it was given.
TEST(Scene, NewtonCallsDefaultToAllAndReloadAsGiven) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  const SceneSpec all = load_scene_spec(file);
  EXPECT_EQ(all.tool.newton_calls, 0);
  EXPECT_EQ(newton_calls_per_tick(all), all.solver.virtual_iterations);
  const SceneSpec paper = load_scene_spec(file, {"solver.virtual_iterations=3", "tool.newton_calls=1"});
  EXPECT_EQ(newton_calls_per_tick(paper), 1);
  EXPECT_EQ(load_scene_spec(file, {"tool.newton_calls=all"}).tool.newton_calls, 0);
  const fs::path tmp = fs::temp_directory_path() / "ebh_test_newton_calls.yaml";
  for (const SceneSpec* spec : {&all, &paper}) {
    std::ofstream(tmp) << resolved_scene_yaml(*spec);
    EXPECT_EQ(load_scene_spec(tmp).tool.newton_calls, spec->tool.newton_calls);
  }
  fs::remove(tmp);
  EXPECT_THROW(load_scene_spec(file, {"solver.virtual_iterations=2", "tool.newton_calls=3"}), InputError);
}

// tool.torque_limit: none (0) by default, in N m, reloaded as given; a negative one is refused.
TEST(Scene, TorqueLimitIsNoneByDefaultAndReloads) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  EXPECT_EQ(load_scene_spec(file).tool.torque_limit, 0.0);
  const SceneSpec limited = load_scene_spec(file, {"tool.torque_limit=0.25"});
  EXPECT_EQ(limited.tool.torque_limit, 0.25);
  const fs::path tmp = fs::temp_directory_path() / "ebh_test_torque_limit.yaml";
  std::ofstream(tmp) << resolved_scene_yaml(limited);
  EXPECT_EQ(load_scene_spec(tmp).tool.torque_limit, 0.25);
  fs::remove(tmp);
  EXPECT_THROW(load_scene_spec(file, {"tool.torque_limit=-1"}), InputError);
}

// An error an override caused names the override (--set KEY=VALUE), not the scene file, which is
// fine: a key nested too deep under an unknown one, a value out of range, a rate that does not
// divide the file's other rate (either one set), a map path through a value; an error of the file
// itself still names the file, whatever the overrides.
TEST(Scene, OverrideErrorsNameTheOverride) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  auto message = [&file](const std::vector<std::string>& overrides) -> std::string {
    try {
      (void)load_scene_spec(file, overrides);
    } catch (const OverrideError& e) {
      return std::string("OverrideError: ") + e.what() + " | " + e.key_message();
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(message({"a.b.c.d=1"}).rfind("OverrideError: --set 'a.b.c.d=1': key 'a': unknown key (known: name, ", 0), 0u)
      << message({"a.b.c.d=1"});
  EXPECT_EQ(message({"stiffness.k_con=-1"}),
            "OverrideError: --set 'stiffness.k_con=-1': key 'stiffness.k_con': expected a positive number, got '-1' | "
            "key 'stiffness.k_con': expected a positive number, got '-1'");
  EXPECT_EQ(message({"solver.virtual_iterations=2", "time.physical_hz=70"}).rfind(
                "OverrideError: --set 'time.physical_hz=70': key 'time.physical_hz': haptic_hz / physical_hz must be a "
                "whole number >= 1, got 1000 / 70 = 14.285714285714286 | ", 0),
            0u);
  EXPECT_EQ(message({"time.haptic_hz=1010"}).rfind(
                "OverrideError: --set 'time.haptic_hz=1010': key 'time.haptic_hz': haptic_hz / physical_hz must be a "
                "whole number >= 1, got 1010 / 100 = 10.1 | ", 0),
            0u);
  EXPECT_EQ(message({"time={haptic_hz: 1000, physical_hz: 70}"}).rfind(
                "OverrideError: --set 'time={haptic_hz: 1000, physical_hz: 70}': key 'time.physical_hz': ", 0),
            0u);
  EXPECT_EQ(message({"solver.virtual_iterations=2", "tool.newton_calls=3"}).rfind(
                "OverrideError: --set 'tool.newton_calls=3': key 'tool.newton_calls': expected all or at most", 0),
            0u);
  EXPECT_EQ(message({"gravity.x=1"}).rfind("OverrideError: --set 'gravity.x=1': key 'gravity': a list, not a map", 0), 0u);
  // Two keys that cannot go together: the one an override gave is named, read with the scene (a
  // sweep checks its configurations before any replay), not when the world is built.
  EXPECT_EQ(message({"solver.physical_region=0.0003", "solver.method=direct"}).rfind(
                "OverrideError: --set 'solver.physical_region=0.0003': key 'solver.physical_region': the direct method "
                "solves for every vertex at once",
                0),
            0u);
  EXPECT_EQ(message({"solver.method=direct"}), "no error");
  // The file's own mistake, with an override beside it: the file.
  const fs::path bad = write_temp("bad_rates.yaml", replace(replace(slurp(file), "physical_hz: 100", "physical_hz: 70"),
                                                             "physical: tube.msh", "physical: " + (file.parent_path() / "tube.msh").string()));
  try {
    (void)load_scene_spec(bad, {"stiffness.k_con=900"});
    FAIL();
  } catch (const OverrideError& e) {
    FAIL() << e.what();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(bad.string() + ": key 'time.physical_hz': haptic_hz / physical_hz", 0), 0u)
        << e.what();
  }
}

// A region of the file that misses a mesh an override moved names that override.
TEST(Scene, APinRegionAMovedMeshLeftSaysWhoMovedIt) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "tests" / "data" / "scene" / "cube_obj.yaml";
  try {
    (void)load_scene(file, {"mesh.transform={translate: [50, 0, 0]}"});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": key 'pinned[0].sphere': the sphere pins no vertex of the "
                                          "physical mesh (the mesh as --set 'mesh.transform={translate: [50, 0, 0]}' gives it)",
                                          0),
              0u)
        << e.what();
  }
}

// A map value merges into the file's section key by key: `--set 'stiffness={k_vol: 500}'` sets k_vol
// and keeps the file's k_s (it reset every stiffness the map left out to its default); a section
// and a key in it, or one key set by two maps, are one key given twice.
TEST(Scene, AMapOverrideMergesIntoTheSection) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  const SceneSpec base = load_scene_spec(file);
  const SceneSpec merged = load_scene_spec(file, {"stiffness={k_vol: 500, k_con: 700}"});
  EXPECT_EQ(merged.stiffness.k_vol, 500);
  EXPECT_EQ(merged.stiffness.k_con, 700);
  EXPECT_EQ(merged.stiffness.k_s, base.stiffness.k_s);
  EXPECT_EQ(merged.stiffness.k_svc, base.stiffness.k_svc);
  EXPECT_EQ(merged.stiffness.k_vcs, base.stiffness.k_vcs);
  const SceneSpec nested = load_scene_spec(file, {"tool={forceps: {jaw_length: 7}}"});
  EXPECT_EQ(nested.tool.kind, base.tool.kind);
  EXPECT_EQ(nested.tool.shaft_radius, base.tool.shaft_radius);
  EXPECT_NE(nested.tool.forceps.jaw_length, base.tool.forceps.jaw_length);
  EXPECT_EQ(nested.tool.forceps.jaw_width, base.tool.forceps.jaw_width);
  auto twice = [&file](const std::vector<std::string>& overrides) -> std::string {
    try {
      (void)load_scene_spec(file, overrides);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(twice({"stiffness.k_vol=400", "stiffness={k_vol: 500}"}),
            "--set 'stiffness={k_vol: 500}': key 'stiffness.k_vol' given twice (also --set 'stiffness.k_vol=400')");
  EXPECT_EQ(twice({"stiffness={k_vol: 500}", "stiffness=3"}),
            "--set 'stiffness=3': key 'stiffness.k_vol' given twice (also --set 'stiffness={k_vol: 500}')");
  EXPECT_EQ(twice({"stiffness={k_vol: 500}", "stiffness={k_s: 30}"}), "no error");
  EXPECT_EQ(twice({"stiffness={k_con: 5, k_con: 6}"}),
            "--set 'stiffness={k_con: 5, k_con: 6}': key 'stiffness.k_con' given twice in the value");
  EXPECT_EQ(twice({"tool={forceps: {jaw_length: 7, jaw_length: 8}}"}),
            "--set 'tool={forceps: {jaw_length: 7, jaw_length: 8}}': key 'tool.forceps.jaw_length' given twice in the "
            "value");
  EXPECT_EQ(override_keys("time={haptic_hz: 500, physical_hz: 50}"),
            (std::vector<std::string>{"time.haptic_hz", "time.physical_hz"}));
  EXPECT_EQ(override_keys("time.haptic_hz=[unclosed"), (std::vector<std::string>{"time.haptic_hz"}));
}

// A scene in another encoding (Latin-1's 0xe9 for an accented e) would carry its bytes into every
// replay output's UTF-8 scene_yaml: named at its line; UTF-8 text in any language is read.
TEST(Scene, ASceneFileThatIsNotUtf8IsNamed) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const fs::path latin1 = write_temp("latin1.yaml", replace(good, "small cube", "small cube, r\xe9sum\xe9"));
  try {
    (void)load_scene_spec(latin1);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), latin1.string() + ":4: byte 0xe9 is not UTF-8 text: save the scene file as UTF-8");
  }
  EXPECT_NO_THROW((void)load_scene_spec(write_temp("utf8.yaml", replace(good, "small cube", "small cube, r\xc3\xa9sum\xc3\xa9"))));
}

// A second YAML document in a scene file would be left unread; a merge key is named as such.
TEST(Scene, ASecondDocumentAndMergeKeysAreRefused) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  const fs::path two = write_temp("two_documents.yaml", good + "---\nname: other\n");
  try {
    (void)load_scene_spec(two);
    FAIL();
  } catch (const InputError& e) {
    const auto line = std::count(good.begin(), good.end(), '\n') + 2;  // the second document's first line
    EXPECT_EQ(std::string(e.what()), two.string() + ":" + std::to_string(line) +
                                         ": a second YAML document (after '---'): a scene file holds one");
  }
  EXPECT_NO_THROW((void)load_scene_spec(write_temp("trailing_marker.yaml", good + "---\n")));
  const fs::path merge =
      write_temp("merge_key.yaml", replace(good, "stiffness: {k_vol: 2500,", "stiffness: {<<: {k_vol: 2000}, k_vol: 2500,"));
  try {
    (void)load_scene_spec(merge);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("merge keys"), std::string::npos) << e.what();
  }
}

// A YAML tag is read by nothing (`k_con: !foo 800` replayed 800 N/m without a word): refused
// naming the file, the line and the key, on a value, a list's item or a key; a quoted value (tag
// "!") and the non-specific tag `!` are plain text as before.
TEST(Scene, YamlTagsAreRefusedWithFileLineAndKey) {
  const std::string good = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  auto message = [](const fs::path& file, const std::vector<std::string>& overrides = {}) -> std::string {
    try {
      (void)load_scene_spec(file, overrides);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const fs::path value = write_temp("tag_value.yaml", replace(good, "k_con: 450", "k_con: !foo 450"));
  EXPECT_EQ(message(value), value.string() + ":14: key 'stiffness.k_con': YAML tag '!foo': ebh reads no tags (each key "
                                             "says what its value is): remove it");
  const fs::path item = write_temp("tag_item.yaml", replace(good, "gravity: [0, 0, -9.81]", "gravity: [0, 0, !!float -9.81]"));
  EXPECT_EQ(message(item).rfind(item.string() + ":15: key 'gravity[2]': YAML tag '!!float': ", 0), 0u) << message(item);
  const fs::path key = write_temp("tag_key.yaml", replace(good, "damping: 0.05", "!foo damping: 0.05"));
  EXPECT_EQ(message(key).rfind(key.string() + ":16: key 'damping': YAML tag '!foo': ", 0), 0u) << message(key);
  const fs::path quoted =
      write_temp("tag_none.yaml", replace(replace(good, "damping: 0.05", "damping: ! 0.05"), "name: test-cube", "name: 'test-cube'"));
  EXPECT_EQ(message(quoted), "no error");
  // An override's value likewise, named by its --set.
  EXPECT_EQ(message(quoted, {"stiffness={k_con: !foo 800}"}),
            "--set 'stiffness={k_con: !foo 800}': key 'stiffness.k_con': YAML tag '!foo': ebh reads no tags (each key "
            "says what its value is): remove it");
}

// A --set value keeps its text: YAML would end a plain value at " #" (a comment) or read one that
// starts with '#' as nothing; numbers, booleans, lists, maps and quoted text are read as before.
TEST(Scene, AnOverrideValueKeepsItsText) {
  const fs::path file = fs::path(EBH_SOURCE_DIR) / "scenarios" / "tube.yaml";
  EXPECT_EQ(load_scene_spec(file, {"name=a #b"}).name, "a #b");
  EXPECT_EQ(load_scene_spec(file, {"description=#3, the stiff one"}).description, "#3, the stiff one");
  EXPECT_EQ(load_scene_spec(file, {"description= padded "}).description, "padded");
  EXPECT_EQ(load_scene_spec(file, {"description='a #b'"}).description, "a #b");
  EXPECT_EQ(load_scene_spec(file, {"description=\"[1, 2]\""}).description, "[1, 2]");
  const SceneSpec s = load_scene_spec(
      file, {"stiffness.k_con=8e2", "gravity=[0,0,-1]", "stages.settle=false", "stiffness={k_vol: 500}", "tool.newton_calls=all"});
  EXPECT_EQ(s.stiffness.k_con, 800);
  EXPECT_EQ(s.gravity, Vec3d(0, 0, -1));
  EXPECT_FALSE(s.stages.settle);
  EXPECT_EQ(s.stiffness.k_vol, 500);
  EXPECT_EQ(override_keys("name=a #b"), (std::vector<std::string>{"name"}));
  EXPECT_EQ(override_keys("time={haptic_hz: 500} # a comment"), (std::vector<std::string>{"time.haptic_hz"}));
}

// The same for a scene whose mesh, tool and world each have their own unit and whose mesh is
// placed by a transform: the resolved file carries mesh.unit, mesh.transform and tool.unit, and
// reloads to the same scene, meshes included, bit for bit.
TEST(Scene, ResolvedYamlKeepsMeshUnitTransformAndToolUnit) {
  const auto p = write_temp("placed.yaml", "unit: mm\n"
                                           "mesh:\n  physical: " + data("mesh/cube22.msh").string() + "\n"
                                           "  unit: cm\n"
                                           "  transform: {scale: 0.7, rotvec_deg: [10, -20, 33.3], translate: [0.1, 2, -3]}\n"
                                           "pinned:\n  - sphere: {center: [70, 0, 70], radius: 80}\n"
                                           "tool: {unit: m, kind: hook, shaft_radius: 0.0025, max_step: 0.0003}\n");
  const Scene a = load_scene(p);
  const std::string yaml = resolved_scene_yaml(a.spec);
  EXPECT_NE(yaml.find("unit: cm"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("rotvec_deg: [10, -20, 33.2"), std::string::npos) << yaml;  // 33.3 printed with 17 digits
  const Scene b = load_scene(write_temp("resolved.yaml", yaml));
  EXPECT_EQ(resolved_scene_yaml(b.spec), yaml);
  EXPECT_EQ(b.spec.mesh_transform.translate, a.spec.mesh_transform.translate);
  EXPECT_EQ(b.spec.tool.max_step, a.spec.tool.max_step);
  ASSERT_EQ(a.physical.vertices.size(), b.physical.vertices.size());
  for (std::size_t v = 0; v < a.physical.vertices.size(); ++v) EXPECT_EQ(a.physical.vertices[v], b.physical.vertices[v]);
  EXPECT_EQ(a.pinned, b.pinned);
  EXPECT_FALSE(a.pinned.empty());
}

}  // namespace
}  // namespace ebh
