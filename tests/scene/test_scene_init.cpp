// `ebh scene init` (scene/scene_init.hpp): the scene it makes for a mesh in cm keeps the tool in
// mm, pins the lowest layer of vertices when no region is given, looks at the mesh, and loads back
// to what it checked.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "../mesh/test_util.hpp"
#include "mesh/mesh_io.hpp"
#include "scene/scene_init.hpp"

namespace ebh {
namespace {

using test::data;
using test::replace;
using test::write_temp;

constexpr double kTol = 1e-15;  // a few ulps of lengths <= 0.33 m scaled from the file's unit

/// A 4 x 3 x 2 box of 5 tets without physical groups, as a segmentation exports it.
std::filesystem::path box_mesh(const std::string& name = "box.msh") {
  return write_temp(name,
                    "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n1 0 0 0\n2 4 0 0\n3 0 3 0\n4 4 3 0\n"
                    "5 0 0 2\n6 4 0 2\n7 0 3 2\n8 4 3 2\n$EndNodes\n$Elements\n5\n1 4 0 1 2 3 5\n2 4 0 4 3 2 8\n"
                    "3 4 0 6 5 8 2\n4 4 0 7 8 5 3\n5 4 0 2 3 5 8\n$EndElements\n");
}

/// The box's scene beside it, with forceps, its file in `unit`.
SceneInitOptions box_forceps(const std::string& unit, const std::string& scene_file) {
  SceneInitOptions o;
  o.mesh = box_mesh();
  o.out = o.mesh.parent_path() / scene_file;
  o.unit = unit;
  o.tool = "forceps";
  return o;
}

// The command in the scene's first line reads back in a shell: a pin with a space is quoted.
TEST(SceneInit, TheCommandInTheHeaderIsQuotedForTheShell) {
  SceneInitOptions o = box_forceps("cm", "quoted.yaml");
  o.pins = {"box:-1,-1,-1,5,4,0.1"};
  o.tissue = "liver";
  std::string text = make_scene(o).yaml;
  EXPECT_NE(text.find("--tissue liver --tool forceps --pin box:-1,-1,-1,5,4,0.1`"), std::string::npos) << text.substr(0, 300);
  o.out = o.mesh.parent_path() / "with space.yaml";
  text = make_scene(o).yaml;
  EXPECT_NE(text.find(" -o '" + o.out.string() + "' --unit cm"), std::string::npos) << text.substr(0, 300);
}

// A mesh of several labelled parts (the TetGen cube: regions 1 and 2) gets the commented example of
// a part of its own stiffness, which uncommented gives that part its k_vol.
TEST(SceneInit, AMeshOfSeveralGroupsIsShownHowToStiffenOne) {
  SceneInitOptions o;
  o.mesh = data("mesh/cube.1.ele");
  o.out = write_temp("labels.yaml", "").parent_path() / "labels.yaml";
  o.unit = "cm";
  const std::string text = make_scene(o).yaml;
  EXPECT_NE(text.find("  # The mesh's tets are in 2 groups (1: 2 tets, 2: 3 tets):\n"), std::string::npos) << text;
  const std::string example = "  # regions:\n  #   - {group: NAME, k_vol: 15000}";
  ASSERT_NE(text.find(example), std::string::npos) << text;
  // beside labels.yaml (write_temp's folder), so that its mesh path holds
  const Scene s = load_scene(write_temp("stiff.yaml", replace(text, example, "  regions:\n    - {group: 2, k_vol: 15000}")));
  EXPECT_EQ(s.tet_k_vol, (std::vector<double>{3000, 3000, 15000, 15000, 15000}));
  // A mesh of one group gets no such lines.
  EXPECT_EQ(make_scene(box_forceps("cm", "one.yaml")).yaml.find("regions:"), std::string::npos);
}

TEST(SceneInit, ACentimetreMeshGetsAMillimetreToolAndItsBottomPinned) {
  SceneInitOptions o = box_forceps("cm", "box.yaml");
  o.tissue = "liver";
  const SceneInit made = make_scene(o);
  const SceneSpec& s = made.scene.spec;
  EXPECT_TRUE(made.scene.warnings.empty()) << made.scene.warnings.front();
  EXPECT_EQ(s.mesh_unit_name, "cm");
  EXPECT_NEAR(made.scene.physical.vertices[7].x, 0.04, kTol);  // node 8 at (4, 3, 2) cm
  // a 5 mm instrument whatever the mesh's unit
  EXPECT_EQ(s.tool.unit_name, "mm");
  EXPECT_EQ(s.tool.kind, ToolSpec::Kind::Forceps);
  EXPECT_NEAR(s.tool.shaft_radius, 0.0025, kTol);
  EXPECT_NEAR(s.tool.shaft_length, 0.33, kTol);
  EXPECT_NEAR(s.tool.forceps.jaw_length, 0.02, kTol);
  EXPECT_TRUE(s.stages.grasp);
  // contact against the surface: vertex contact lets a tool through at a hand's speed
  EXPECT_EQ(s.contact, ContactModel::Surface);
  // the liver preset
  const TissuePreset& liver = tissue_presets()[0];
  ASSERT_EQ(liver.name, "liver");
  EXPECT_EQ(s.stiffness.k_vol, liver.k_vol);
  EXPECT_EQ(s.density, liver.density);
  // no --pin: the z = 0 face's four corners (nodes 1-4), as a half-space
  EXPECT_EQ(made.scene.pinned, (std::vector<int>{0, 1, 2, 3}));
  ASSERT_EQ(s.pinned.size(), 1u);
  EXPECT_EQ(s.pinned[0].kind, PinRegion::Kind::Halfspace);
  EXPECT_NE(made.yaml.find("# no --pin given: pinned the lowest 5% of the mesh's height"), std::string::npos);
  EXPECT_NE(made.pin_note.find("4 vertices"), std::string::npos) << made.pin_note;
  // the camera aims at the box's centre from the front and above, the whole box in its 40 degrees
  EXPECT_NEAR(s.camera.target.x, 0.02, 1e-12);
  EXPECT_NEAR(s.camera.target.y, 0.015, 1e-12);
  EXPECT_LT(s.camera.eye.y, s.camera.target.y);
  EXPECT_GT(s.camera.eye.z, s.camera.target.z);
  const double half_diagonal = 0.5 * std::sqrt(0.04 * 0.04 + 0.03 * 0.03 + 0.02 * 0.02);
  EXPECT_GT(norm(s.camera.eye - s.camera.target) * std::tan(20.0 * std::numbers::pi / 180.0), half_diagonal);
  // the mesh path is relative to the scene file, which sits beside it
  EXPECT_NE(made.yaml.find("physical: \"box.msh\""), std::string::npos) << made.yaml;
}

// Virtual mesh edges over 1.5 times the tool's thinnest part (1 mm) are said with how to refine
// them: the box in cm has 10-25 mm edges after virtual_refine's split; the tube's mesh (its
// boundary split, 1.27 mm) is fine enough.
// A 50 x 50 x 10 mm block of 1200 tets with a 1 mm speck of 6 above it: the scene drops the speck
// (mesh.min_part_tets) and says so; a mesh without specks gets no such key.
TEST(SceneInit, SpecksApartFromTheOrganAreDropped) {
  SceneInitOptions o;
  o.mesh = write_temp("specks.msh", msh22_text(test::block_with_a_speck(50)));
  o.out = o.mesh.parent_path() / "specks.yaml";
  const SceneInit made = make_scene(o);
  EXPECT_NE(made.yaml.find("\n  min_part_tets: 7 "), std::string::npos) << made.yaml;
  EXPECT_EQ(made.speck_note, "dropped 1 part of under 1% of the mesh's tets each (specks of a segmentation?): "
                             "mesh.min_part_tets: 7; set 0 to keep them");
  EXPECT_EQ(made.scene.physical.tets.size(), 1200u);
  EXPECT_TRUE(made.scene.free_parts.empty());
  // A pin around the speck alone: the speck is dropped, said so (it cited the bounding box of the
  // mesh without it).
  o.pins = {"box:19.5,19.5,19.5,21.5,21.5,21.5"};
  try {
    make_scene(o);
    FAIL() << "the pin holds only the dropped speck";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--pin box:19.5,19.5,19.5,21.5,21.5,21.5: the region holds only vertices of the parts "
                                     "apart from the organ that scene init drops as specks (1 part of under 1% of the "
                                     "mesh's tets each: mesh.min_part_tets: 7): pin a region of the organ, or keep the "
                                     "parts (mesh.min_part_tets: 0 in the scene written)");
  }
  o.pins.clear();
  o.mesh = box_mesh();
  o.out = o.mesh.parent_path() / "box.yaml";
  const SceneInit clean = make_scene(o);
  EXPECT_EQ(clean.yaml.find("min_part_tets"), std::string::npos);
  EXPECT_EQ(clean.speck_note, "");
}

TEST(SceneInit, AVirtualMeshCoarseForTheToolIsSaid) {
  SceneInitOptions o = box_forceps("cm", "coarse.yaml");
  const std::string note = make_scene(o).resolution_note;
  EXPECT_EQ(note.rfind("the virtual mesh's edges (median ", 0), 0u) << note;
  EXPECT_NE(note.find(" cm) are "), std::string::npos) << note;
  EXPECT_NE(note.find("times the tool's thinnest part (0.1 cm)"), std::string::npos) << note;
  EXPECT_NE(note.find("`ebh scene refine " + o.out.string() + " -o " + (o.out.parent_path() / "coarse_l1.yaml").string() +
                      "` halves them"),
            std::string::npos)
      << note;
  SceneInitOptions tube;
  tube.mesh = std::filesystem::path(EBH_SOURCE_DIR) / "scenarios" / "tube.msh";
  tube.out = write_temp("tube_init.yaml", "").parent_path() / "tube_init.yaml";
  EXPECT_EQ(make_scene(tube).resolution_note, "");
}

// The same file declared in mm is a 5 mm speck next to 20 mm jaws: the scene is still written,
// and its load says which keys to check.
TEST(SceneInit, AMeshInTheWrongUnitWarns) {
  const SceneInit made = make_scene(box_forceps("mm", "box_mm.yaml"));
  EXPECT_NEAR(made.scene.spec.tool.shaft_radius, 0.0025, kTol);
  ASSERT_FALSE(made.scene.warnings.empty());
  EXPECT_NE(made.scene.warnings[0].find("tool.forceps.jaw_length = 20 mm is larger than the physical mesh's bounding-box diagonal (5.38516 mm)"),
            std::string::npos) << made.scene.warnings[0];
}

// A mesh file whose name holds a line break loads from the scene: the name is written escaped
// ("a\nb.msh"), not raw, which YAML folded to "a b.msh", a file nobody wrote.
TEST(SceneInit, AMeshFileNameWithALineBreakIsEscaped) {
  SceneInitOptions o;
  o.mesh = box_mesh("a\nb\t.msh");
  o.out = o.mesh.parent_path() / "nl.yaml";
  const SceneInit made = make_scene(o);
  EXPECT_NE(made.yaml.find("  physical: \"a\\nb\\t.msh\"\n"), std::string::npos) << made.yaml;
  EXPECT_EQ(made.scene.spec.physical_mesh, o.mesh.lexically_normal());
  EXPECT_EQ(made.scene.physical.tets.size(), 5u);
  EXPECT_EQ(made.yaml.find("a\nb"), std::string::npos) << made.yaml;  // in the command's comment too
}

// Names the scene must hold exactly but cannot, not being UTF-8 text (Latin-1, as an old Windows
// tool writes it): refused naming the mesh file or the group, not the scene file never written
// ("NAME.yaml:1: byte 0xe9 is not UTF-8 text: save the scene file as UTF-8"). A group named so
// that is not pinned is only shown, escaped, in a comment.
TEST(SceneInit, ANameThatIsNotUtf8IsRefusedNamingIt) {
  SceneInitOptions o;
  o.mesh = box_mesh("f\xe9.msh");
  o.out = o.mesh.parent_path() / "fe.yaml";
  try {
    (void)make_scene(o);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), (o.mesh.parent_path() / "f\\xe9.msh").string() +
                                         ": the mesh file's name is not UTF-8 text (byte 0xe9, a Latin-1 name?), which "
                                         "a scene file cannot hold: rename it");
  }
  // the box in two groups, the first named in Latin-1
  o.mesh = write_temp("latin1.msh",
                      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n3 1 \"l\xe9sion\"\n3 2 \"organ\"\n"
                      "$EndPhysicalNames\n$Nodes\n8\n1 0 0 0\n2 4 0 0\n3 0 3 0\n4 4 3 0\n5 0 0 2\n6 4 0 2\n7 0 3 2\n"
                      "8 4 3 2\n$EndNodes\n$Elements\n5\n1 4 2 1 1 1 2 3 5\n2 4 2 2 1 4 3 2 8\n3 4 2 2 1 6 5 8 2\n"
                      "4 4 2 2 1 7 8 5 3\n5 4 2 2 1 2 3 5 8\n$EndElements\n");
  o.out = o.mesh.parent_path() / "latin1.yaml";
  const SceneInit made = make_scene(o);
  EXPECT_NE(made.yaml.find("  # The mesh's tets are in 2 groups (l\\xe9sion: 1 tets, organ: 4 tets):\n"), std::string::npos)
      << made.yaml;
  o.pins = {"group:l\xe9sion"};
  try {
    (void)make_scene(o);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--pin group:l\\xe9sion: the group's name is not UTF-8 text (byte 0xe9, a Latin-1 "
                                     "name?), which a scene file cannot hold: rename the group in " +
                                         o.mesh.string() + " (or pin a box or sphere)");
  }
}

// A mesh far from the origin (100 km, or 1000 km, from it in mm: 1000 times its size and more)
// gets its bottom pinned and a camera on it: the pin's cut and the camera's points rounded to 4
// digits of the coordinate once put the cut at 1e+05, below the mesh ("no layer of vertices at
// the bottom to pin"), and the eye at the target ("camera.eye and camera.target are the same point").
TEST(SceneInit, AMeshFarFromTheOriginGetsItsBottomPinnedAndACamera) {
  for (const double z : {100001.3, 1e9}) {
    SCOPED_TRACE(z);
    char nodes[400];
    std::snprintf(nodes, sizeof nodes, "1 0 0 %.17g\n2 4 0 %.17g\n3 0 3 %.17g\n4 4 3 %.17g\n5 0 0 %.17g\n6 4 0 %.17g\n"
                  "7 0 3 %.17g\n8 4 3 %.17g\n", z, z, z, z, z + 2, z + 2, z + 2, z + 2);
    SceneInitOptions o;
    o.mesh = write_temp("far.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n" + std::string(nodes) +
                                       "$EndNodes\n$Elements\n5\n1 4 0 1 2 3 5\n2 4 0 4 3 2 8\n3 4 0 6 5 8 2\n"
                                       "4 4 0 7 8 5 3\n5 4 0 2 3 5 8\n$EndElements\n");
    o.out = o.mesh.parent_path() / "far.yaml";
    const SceneInit made = make_scene(o);
    EXPECT_EQ(made.scene.pinned, (std::vector<int>{0, 1, 2, 3}));  // the z face's four corners
    // the camera on the box's centre (to 1/1000 of its 5.4 mm diagonal), from the front and above
    const Camera& c = made.scene.spec.camera;
    EXPECT_NEAR(c.target.z, (z + 1) * 1e-3, 5.4e-6);
    EXPECT_LT(c.eye.y, c.target.y);
    EXPECT_GT(c.eye.z, c.target.z);
    EXPECT_GT(norm(c.eye - c.target) * std::tan(20.0 * std::numbers::pi / 180.0), 0.5 * 5.385e-3);
  }
}

// A stray vertex below the organ holds the bottom of the 5% band alone: the band widens until it
// reaches the organ's own bottom layer, which may hold much of it, and that is said (one node of a
// 40 mm cube pulled 30 mm down pinned 196 of its 343 vertices without a word).
TEST(SceneInit, APinBandWidenedPastAStrayVertexIsSaid) {
  SceneInitOptions o;
  o.mesh = write_temp("stray.msh", replace(test::slurp(box_mesh()), "1 0 0 0\n", "1 0 0 -2\n"));
  o.out = o.mesh.parent_path() / "stray.yaml";
  const SceneInit made = make_scene(o);
  EXPECT_EQ(made.scene.pinned, (std::vector<int>{0, 1, 2, 3}));  // the lowest 80%: the stray node and the z = 0 face
  ASSERT_FALSE(made.scene.warnings.empty());
  EXPECT_EQ(made.scene.warnings.back(),
            o.mesh.string() + ": no --pin given: the lowest 5% of the mesh's height holds 1 vertex (the lowest, "
                              "vertex 0, at z = -2 mm: a stray vertex or a spike below the organ?), so the pinned band "
                              "was widened to the lowest 80%: 4 of 8 vertices held still; give --pin to choose");
  // The box as it is: its bottom face in the first band, nothing said.
  o.mesh = box_mesh();
  o.out = o.mesh.parent_path() / "box.yaml";
  for (const std::string& w : make_scene(o).scene.warnings) EXPECT_EQ(w.find("was widened"), std::string::npos) << w;
}

// A tet soup (each element's nodes written apart) is all specks: said as such, not as a
// mesh.min_part_tets the user never wrote that drops every part.
TEST(SceneInit, ATetSoupIsSaidToFallApart) {
  // 120 tets side by side, each with its own four nodes: every one under 1% of the mesh.
  std::string nodes, elements;
  for (int t = 0; t < 120; ++t) {
    const int x = 2 * t;
    for (const auto& [dx, dy, dz] : {std::array<int, 3>{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}})
      nodes += std::to_string(4 * t + 1 + dx + 2 * dy + 3 * dz) + " " +
               std::to_string(x + dx) + " " + std::to_string(dy) + " " + std::to_string(dz) + "\n";
    elements += std::to_string(t + 1) + " 4 0 " + std::to_string(4 * t + 1) + " " + std::to_string(4 * t + 2) + " " +
                std::to_string(4 * t + 3) + " " + std::to_string(4 * t + 4) + "\n";
  }
  SceneInitOptions o;
  o.mesh = write_temp("soup.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n480\n" + nodes +
                                      "$EndNodes\n$Elements\n120\n" + elements + "$EndElements\n");
  o.out = o.mesh.parent_path() / "soup.yaml";
  try {
    make_scene(o);
    FAIL() << "a soup has no organ";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), o.mesh.string() + ": its 120 tets fall apart into 120 parts of at most 1 tet, none "
                                                       "an organ (no two tets share a vertex: each element's nodes were "
                                                       "written apart; merge the coincident nodes, e.g. Gmsh's Coherence)");
  }
}

TEST(SceneInit, PinsAreCheckedAgainstTheMesh) {
  SceneInitOptions o;
  o.mesh = data("mesh/cube22.msh");
  o.out = write_temp("marker", "").parent_path() / "cube.yaml";
  o.pins = {"group:bottom", "sphere:10,10,10,0.5"};
  const SceneInit made = make_scene(o);
  EXPECT_EQ(made.scene.pinned, (std::vector<int>{1, 2, 3, 4, 6}));  // bottom's 4 corners and node 55
  o.pins = {"group:bottm"};
  EXPECT_THROW(make_scene(o), InputError);
  o.pins = {"box:0,0,0,10,10,10"};
  EXPECT_THROW(make_scene(o), InputError);  // every vertex
  o.pins = {"halfspace:0,0,0,0,0,1"};
  EXPECT_THROW(make_scene(o), InputError);  // not a --pin form
}

}  // namespace
}  // namespace ebh
