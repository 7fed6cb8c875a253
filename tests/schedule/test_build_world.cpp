// What build_world says of a scene beyond its file's checks: a virtual mesh from its own file that
// lies off the physical mesh (another unit or frame) is named with how far and where, and one far
// smaller than it (another unit) with its size.
#include <gtest/gtest.h>

#include <array>
#include <sstream>

#include "../mesh/test_util.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/surface.hpp"
#include "schedule/simulation.hpp"

namespace ebh {
namespace {

using test::data;
using test::replace;
using test::slurp;
using test::write_temp;

/// cube_obj.yaml (a 10 cm cube) with the virtual mesh `obj` (OBJ text, in cm) as NAME.obj.
std::vector<std::string> warnings_of(const std::string& name, const std::string& obj) {
  write_temp(name + ".obj", obj);
  const std::string yaml = replace(replace(slurp(data("scene/cube_obj.yaml")), "../mesh/cube41.msh",
                                           data("mesh/cube41.msh").string()),
                                   "../mesh/cube.obj", name + ".obj");
  return build_world(load_scene(write_temp(name + ".yaml", yaml)), 1000, 100)->scene.warnings;
}

/// The same with its OBJ's vertices scaled by `scale` about the origin and moved by `dx` cm along x.
std::vector<std::string> warnings_with_obj(const std::string& name, double scale, double dx) {
  std::istringstream in(slurp(data("mesh/cube.obj")));
  std::string obj;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("v ", 0) == 0) {
      std::istringstream v(line.substr(2));
      double x, y, z;
      v >> x >> y >> z;
      std::ostringstream o;
      o.precision(17);
      o << "v " << scale * x + dx << " " << scale * y << " " << scale * z;
      line = o.str();
    }
    obj += line + "\n";
  }
  return warnings_of(name, obj);
}

bool has(const std::vector<std::string>& warnings, const std::string& needle) {
  for (const std::string& w : warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

TEST(BuildWorld, AVirtualMeshOffThePhysicalMeshIsNamed) {
  // the cube's own surface, and one 0.1% larger (0.17 mm out at a corner, within 1% of the
  // 173 mm diagonal): nothing to say
  EXPECT_FALSE(has(warnings_with_obj("same", 1.0, 0.0), "mesh.virtual"));
  EXPECT_FALSE(has(warnings_with_obj("smoothed", 1.001, -0.005), "mesh.virtual"));
  // 5 cm to the side (a mesh in another frame), ten times larger (mm read as cm)
  const auto moved = warnings_with_obj("moved", 1.0, 5.0);
  // (the 50 mm the far face stands out: each vertex is paired with the closest point of the mesh)
  EXPECT_TRUE(has(moved, "moved.obj: mesh.virtual: the virtual mesh lies up to 50 mm off the physical mesh (the virtual vertex at "))
      << ::testing::PrintToString(moved);
  EXPECT_TRUE(has(moved, "1% of its diagonal is 1.73 mm): its E_svc targets pull it onto the physical mesh"));
  // ten times larger: no surface of this mesh (E_svc dragged the physical mesh out to it, inverting
  // its tets); refused
  try {
    (void)warnings_with_obj("tenfold", 10.0, 0.0);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tenfold.obj: mesh.virtual: the virtual mesh spans 1.73e+03 mm, 10 times the "
                                         "physical mesh's diagonal (173 mm): it is not a surface of this mesh"),
              std::string::npos)
        << e.what();
  }
  // twice its size still loads (warned by the pairing): a surface a few per cent larger is fine
  EXPECT_TRUE(has(warnings_with_obj("twofold", 1.9, 0.0), "twofold.obj: mesh.virtual: the virtual mesh lies up to "));
  // 2 m away, more than 10 diagonals: no surface of this mesh; refused rather than left to make
  // the physical mesh diverge
  try {
    (void)warnings_with_obj("far", 1.0, 200.0);  // cm
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("far.obj: mesh.virtual: the virtual mesh lies up to 2 m off the physical mesh "),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("more than 10 times its diagonal (0.173 m)"), std::string::npos) << e.what();
  }
}

// A virtual mesh with a hole (the cube without its last face) or of unwelded faces is not closed:
// a tool that passes through an opening feels nothing, with either contact model.
TEST(BuildWorld, AnOpenVirtualMeshIsNamed) {
  std::string cube = slurp(data("mesh/cube.obj"));
  const std::string holed = cube.substr(0, cube.rfind("f "));  // without the last quad
  EXPECT_TRUE(has(warnings_of("holed", holed), "holed.obj: mesh.virtual: the virtual mesh is not closed: 4 of its edges "
                                               "belong to one face only (a hole, a cut patch): "))
      << ::testing::PrintToString(warnings_of("holed", holed));
  // Where the hole is: the box its rim lies in (the missing quad's four edges).
  EXPECT_TRUE(has(warnings_of("holed", holed),
                  "feels nothing there (the open edges lie within (100, 0, 0) .. (100, 100, 100) mm)"))
      << ::testing::PrintToString(warnings_of("holed", holed));
  // Two triangles of one face with their shared corners 0.01 cm apart (farther than a weld):
  // faces that share no edge, along a seam never welded.
  const std::string soup = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 10 0 0.01\nv 0 10 0.01\nv 10 10 0\nf 1 3 2\nf 4 5 6\n";
  const std::vector<std::string> unwelded = warnings_of("soup", soup);
  EXPECT_TRUE(has(unwelded, "2 of its 2 faces share no edge with another: corners that differ by round-off, never welded; "
                            "2 of the open edges lie along another, up to 0.1 mm apart: a seam never welded"))
      << ::testing::PrintToString(unwelded);
  // A round-off apart (1e-9 cm): welded, the square's two faces share their edge.
  const std::string roundoff = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 10 0 1e-9\nv 0 10 1e-9\nv 10 10 0\nf 1 3 2\nf 4 5 6\n";
  const std::vector<std::string> welded = warnings_of("roundoff", roundoff);
  EXPECT_TRUE(has(welded, "roundoff.obj: merged 2 vertices at the position of another (2 of them a round-off apart"))
      << ::testing::PrintToString(welded);
  EXPECT_FALSE(has(welded, "share no edge")) << ::testing::PrintToString(welded);
  EXPECT_FALSE(has(welded, "a seam never welded")) << ::testing::PrintToString(welded);
  // A wall inside the cube (its diagonal plane as two triangles): edges of three faces.
  const std::string wall = cube + "f 1 7 8\nf 1 8 2\n";
  EXPECT_TRUE(has(warnings_of("wall", wall), "wall.obj: mesh.virtual: the virtual mesh has "))
      << ::testing::PrintToString(warnings_of("wall", wall));
  EXPECT_TRUE(has(warnings_of("wall", wall), " edges of three faces or more (a wall inside the surface"));
  EXPECT_FALSE(has(warnings_of("holed", holed), "three faces"));
  EXPECT_FALSE(has(warnings_of("holed", holed), "T-junction"));
  // The top face split at the midpoint of its front edge, which the front face runs past: closed
  // in space, the edge's two halves and the front face's edge are open.
  const std::string tee = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 10 10 0\nv 0 0 10\nv 10 0 10\nv 0 10 10\nv 10 10 10\n"
                          "v 5 0 10\nf 1 3 4 2\nf 5 9 8\nf 9 6 8\nf 5 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  EXPECT_TRUE(has(warnings_of("tee", tee), "tee.obj: mesh.virtual: the virtual mesh is not closed: 3 of its edges belong "
                                           "to one face only (a hole, a cut patch; 1 vertex lies inside another face's "
                                           "edge (T-junctions: no gap there, but no edge joins the faces on either side"))
      << ::testing::PrintToString(warnings_of("tee", tee));
}

// An OBJ far finer than the physical boundary (cube41's, 114 mm on average): its vertices' springs
// per area set the rendered force. Warned under 1/8 of the boundary's mean edge (the same cube
// refined four times: 1/16); refined twice (1/4, as the scenes' virtual_refine) it is not.
TEST(BuildWorld, AVirtualMeshFarFinerThanTheBoundaryIsNamed) {
  const auto refined_cube = [](int levels) {
    SurfaceMesh s = read_obj(data("mesh/cube.obj"));
    std::vector<std::array<int, 2>> parent;
    for (int i = 0; i < levels; ++i) s = refine_surface(s, parent);
    std::ostringstream o;
    o.precision(17);
    for (const Vec3d& v : s.vertices) o << "v " << v.x << " " << v.y << " " << v.z << "\n";
    for (const Tri& t : s.triangles) o << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
    return o.str();
  };
  const auto finer = [](const std::vector<std::string>& w) {
    for (const std::string& line : w)
      if (line.find("as refined) are 1/") != std::string::npos) return line;
    return std::string();
  };
  const std::string fine = finer(warnings_of("fine4", refined_cube(4)));
  EXPECT_NE(fine.find("fine4.obj: mesh.virtual: the virtual mesh's edges (7.11 mm on average, as refined) are 1/16 of "),
            std::string::npos) << fine;
  EXPECT_EQ(finer(warnings_of("fine2", refined_cube(2))), "");
}

TEST(BuildWorld, AVirtualMeshInAnotherUnitIsNamed) {
  // A mesh in m read as cm: 1/100 of the cube, inside it, paired without error; the tool would
  // never meet it. Half the cube (a patch-sized surface) says nothing.
  const auto tiny = warnings_with_obj("tiny", 0.01, 0.0);
  EXPECT_TRUE(has(tiny, "tiny.obj: mesh.virtual: the virtual mesh spans 1.73 mm, 1/100 of the physical mesh's "
                        "diagonal (173 mm): is it in mesh.unit"))
      << ::testing::PrintToString(tiny);
  const auto half = warnings_with_obj("half", 0.5, 0.0);
  EXPECT_FALSE(has(half, "spans")) << ::testing::PrintToString(half);
  // (it covers none of the physical mesh's surface: a tool pressed in meets it 2.5 cm deep)
  EXPECT_TRUE(has(half, "covers part of the physical mesh only")) << ::testing::PrintToString(half);
  EXPECT_FALSE(has(half, "another unit")) << ::testing::PrintToString(half);
  // An OBJ in cm beside a mesh in mm: 1/10 of the cube, which it covers nowhere: the unit is named.
  const auto tenth = warnings_with_obj("tenth", 0.1, 0.0);
  EXPECT_TRUE(has(tenth, "passes through the physical mesh unfelt; it spans 1/10 of the physical mesh's diagonal: is it "
                         "in another unit than mesh.unit"))
      << ::testing::PrintToString(tenth);
  // The same size elsewhere (a surface of one small part of the body): no unit makes it the cube.
  const auto part = warnings_with_obj("small_part", 0.1, 4.0);
  EXPECT_TRUE(has(part, "covers part of the physical mesh only")) << ::testing::PrintToString(part);
  EXPECT_FALSE(has(part, "another unit")) << ::testing::PrintToString(part);
}

// A closed virtual mesh over half the physical mesh (one lobe of a segmentation): a tool pressed
// into the other half meets no virtual vertex there and renders next to nothing. The cube's own
// surface, as finely triangulated, says nothing.
TEST(BuildWorld, AVirtualMeshOverPartOfThePhysicalMeshIsNamed) {
  // The surface of the box [0, x1] x [0, 10] x [0, 10] cm, each face a grid of 1 cm squares.
  auto box_obj = [](int x1) {
    std::ostringstream o;
    int base = 0;
    auto face = [&](auto point, int nu, int nv) {
      for (int v = 0; v <= nv; ++v)
        for (int u = 0; u <= nu; ++u) {
          const auto [x, y, z] = point(u, v);
          o << "v " << x << " " << y << " " << z << "\n";
        }
      for (int v = 0; v < nv; ++v)
        for (int u = 0; u < nu; ++u) {
          const int a = base + v * (nu + 1) + u + 1;
          o << "f " << a << " " << a + 1 << " " << a + nu + 2 << " " << a + nu + 1 << "\n";
        }
      base += (nu + 1) * (nv + 1);
    };
    using P = std::array<int, 3>;
    face([](int u, int v) { return P{u, v, 0}; }, x1, 10);
    face([](int u, int v) { return P{u, v, 10}; }, x1, 10);
    face([](int u, int v) { return P{u, 0, v}; }, x1, 10);
    face([](int u, int v) { return P{u, 10, v}; }, x1, 10);
    face([](int u, int v) { return P{0, u, v}; }, 10, 10);
    face([&](int u, int v) { return P{x1, u, v}; }, 10, 10);
    return o.str();
  };
  const auto whole = warnings_of("whole_box", box_obj(10));
  EXPECT_FALSE(has(whole, "covers part")) << ::testing::PrintToString(whole);
  const auto half = warnings_of("half_box", box_obj(5));
  EXPECT_TRUE(has(half, "half_box.obj: mesh.virtual: the virtual mesh covers part of the physical mesh only: "))
      << ::testing::PrintToString(half);
  EXPECT_TRUE(has(half, "lie more than 8.66 mm from its surface"));  // 5% of the cube's 173 mm diagonal
  // The same half as a coarse box of 12 triangles (no vertex near the middle of its faces) is
  // warned too; the whole cube's surface with its corners rounded off by 3 mm (a smoothed
  // segmentation, refined finely) is not.
  const std::string coarse_half = "v 0 0 0\nv 5 0 0\nv 0 10 0\nv 5 10 0\nv 0 0 10\nv 5 0 10\nv 0 10 10\nv 5 10 10\n"
                                  "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  EXPECT_TRUE(has(warnings_of("coarse_half", coarse_half), "covers part of the physical mesh only"));
  std::string rounded = box_obj(10);
  {
    std::istringstream in(rounded);
    std::ostringstream out;
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("v ", 0) == 0) {  // pulled towards the centre along each axis within 0.3 cm of two faces
        std::istringstream v(line.substr(2));
        double x, y, z;
        v >> x >> y >> z;
        auto pull = [](double c) { return c < 0.3 ? 0.3 - 0.3 * (1 - c / 0.3) * 0.4 : c > 9.7 ? 9.7 + 0.3 * (1 - (10 - c) / 0.3) * 0.4 : c; };
        const int near = (x < 0.3 || x > 9.7) + (y < 0.3 || y > 9.7) + (z < 0.3 || z > 9.7);
        if (near >= 2) x = pull(x), y = pull(y), z = pull(z);
        out << "v " << x << " " << y << " " << z << "\n";
      } else {
        out << line << "\n";
      }
    }
    rounded = out.str();
  }
  const auto smooth = warnings_of("rounded_box", rounded);
  EXPECT_FALSE(has(smooth, "covers part")) << ::testing::PrintToString(smooth);
}

// With vertex contact a tool part narrower than the gaps between the virtual vertices passes
// through the surface touching none: a needle-thin hook tip (0.3 mm) on the gap's block (median
// circumradius 0.80 mm) is named with both numbers; not with surface contact, nor on a committed
// scene (their tools 0.66 .. 1.4 times their meshes' circumradius).
TEST(BuildWorld, AToolPartBetweenTheVirtualVerticesIsNamed) {
  auto warned = [](const std::string& scene, const std::vector<std::string>& overrides) {
    const auto world = build_world(load_scene(resolve_scene_path(scene), overrides), 1000, 100);
    for (const std::string& w : world->scene.warnings)
      if (w.find("circumradius") != std::string::npos) return w;
    return std::string();
  };
  const std::string needle = warned("gap", {"tool.hook.tip_radius=0.3"});
  EXPECT_NE(needle.find("gap.yaml: the tool's thinnest part (0.3 mm: tool.hook.tip_radius or "
                        "tool.shaft_radius) is under half the virtual mesh's typical triangle circumradius (0.804 mm, "
                        "the median)"), std::string::npos) << needle;
  EXPECT_EQ(warned("gap", {"tool.hook.tip_radius=0.3", "contact=surface"}), "");
  EXPECT_EQ(warned("gap", {"tool.hook.tip_radius=0.45"}), "");
  for (const char* scene : {"tube", "tube_forceps", "gap", "gap_forceps", "gynaecology", "cholecystectomy"})
    EXPECT_EQ(warned(scene, {}), "") << scene;
}

}  // namespace
}  // namespace ebh
