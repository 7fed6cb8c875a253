// degrade_mesh_quality: the worst tet reaches the target and goes no lower, the boundary and the
// fixed vertices do not move, no tet inverts, the same seed gives the same mesh; msh22_text writes
// such a mesh so that read_msh gets the same bits back.
#include <gtest/gtest.h>

#include <filesystem>

#include "mesh/boundary.hpp"
#include "mesh/degrade.hpp"
#include "mesh/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "test_util.hpp"

namespace ebh {
namespace {

/// A structured 5 x 5 x 5 block of unit cubes, 6 tets each (positively oriented).
TetMesh cube_block() {
  TetMesh m;
  const int n = 6;
  auto id = [&](int i, int j, int k) { return (k * n + j) * n + i; };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) m.vertices.push_back(Vec3d{double(i), double(j), double(k)});
  for (int k = 0; k + 1 < n; ++k)
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        const int v[8] = {id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k),
                          id(i, j, k + 1), id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        const int t[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
        for (const auto& c : t) m.tets.push_back(Tet{v[c[0]], v[c[1]], v[c[2]], v[c[3]]});
      }
  orient_tets(m);
  return m;
}

TEST(Degrade, ReachesTheTargetQualityWithoutInvertingOrMovingTheBoundary) {
  for (double target : {0.05, 0.02, 0.01}) {
    TetMesh m = cube_block();
    const TetMesh before = m;
    std::vector<std::uint8_t> fixed(m.vertices.size(), 0);
    fixed[m.vertices.size() / 2] = 1;
    DegradeOptions o;
    o.target_quality = target;
    o.tets = 6;
    const DegradeReport r = degrade_mesh_quality(m, fixed, o);
    EXPECT_EQ(r.caps + r.slivers + r.needles, 6) << target;
    EXPECT_GT(r.caps + r.slivers, 0);  // a cube's tets have right angles: no foot falls strictly inside
    EXPECT_GT(r.needles, 0);
    // The bisection stops within 2^-60 of the move that reaches the target; 1e-6 is far above
    // that and far below any other tet's quality.
    EXPECT_NEAR(r.worst_quality, target, 1e-6) << target;
    const MeshReport v = validate_mesh(m);
    EXPECT_FALSE(v.fatal()) << v.fatal_message(m);
    EXPECT_NEAR(v.quality_worst, target, 1e-6);
    std::vector<int> boundary;
    extract_boundary(before, &boundary);
    for (int b : boundary) EXPECT_EQ(m.vertices[b], before.vertices[b]);
    EXPECT_EQ(m.vertices[m.vertices.size() / 2], before.vertices[m.vertices.size() / 2]);
    TetMesh again = before;
    degrade_mesh_quality(again, fixed, o);
    EXPECT_EQ(again.vertices, m.vertices);  // deterministic
  }
}

}  // namespace
}  // namespace ebh

namespace ebh {
namespace {

TEST(WriteMsh, ADegradedSceneMeshReadsBackToTheSameBits) {
  TetMesh m = read_msh(std::filesystem::path(EBH_SOURCE_DIR) / "scenarios" / "tube.msh");
  DegradeOptions o;
  o.target_quality = 0.02;
  degrade_mesh_quality(m, {}, o);
  const TetMesh back = read_msh(test::write_temp("tube_q0.02.msh", msh22_text(m)));
  test::expect_same_elements(back, m);
  EXPECT_NEAR(validate_mesh(back).quality_worst, 0.02, 1e-9);
}

}  // namespace
}  // namespace ebh
