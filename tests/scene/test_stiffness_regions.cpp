// stiffness.regions: parts of the physical mesh with their own k_vol (a tumour in an organ), by
// group or by the tets' centroids in a box, sphere or half-space; the last region holding a tet
// sets it; a region that holds no tet is refused with its key; the resolved scene keeps them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "../mesh/test_util.hpp"
#include "scene/scene.hpp"

namespace ebh {
namespace {

namespace fs = std::filesystem;
using test::data;
using test::replace;
using test::slurp;
using test::write_temp;

/// tests/data/scene/cube.yaml (cube22.msh: the 5 tets of make_test_meshes.py in its order, group
/// "tissue" holding all of them, "top" and "bottom" only triangles) with `regions` in its stiffness.
std::string cube_with_regions(const std::string& regions) {
  std::string yaml = replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh", data("mesh/cube22.msh").string());
  return replace(yaml, "stiffness: {k_vol: 2500, k_s: 25, k_svc: 55, k_con: 450, k_vcs: 320, k_vct: 0.35}",
                 "stiffness:\n  k_vol: 2500\n  k_s: 25\n  k_svc: 55\n  k_con: 450\n  k_vcs: 320\n  k_vct: 0.35\n  regions:\n" +
                     regions);
}

TEST(StiffnessRegions, TheLastRegionHoldingATetSetsItsKvol) {
  // The tets' centroids (mm): z = 2.5, 2.5, 7.5, 7.5, 5; the box z <= 5 holds tets 0, 1 and 4.
  const Scene s = load_scene(write_temp("regions.yaml", cube_with_regions("    - group: tissue\n      k_vol: 7000\n"
                                                                          "    - box: {min: [0, 0, 0], max: [10, 10, 5]}\n"
                                                                          "      k_vol: 5000\n")));
  ASSERT_EQ(s.spec.stiffness_regions.size(), 2u);
  EXPECT_EQ(s.spec.stiffness_regions[0].region.kind, PinRegion::Kind::Group);
  EXPECT_EQ(s.spec.stiffness_regions[1].region.b.z, 0.005);
  EXPECT_EQ(s.tet_k_vol, (std::vector<double>{5000, 5000, 7000, 7000, 5000}));
  EXPECT_EQ(region_tets(s.physical, s.spec.stiffness_regions[1].region), (std::vector<int>{0, 1, 4}));
  // Without regions, every tet has stiffness.k_vol.
  const Scene plain = load_scene(write_temp("plain.yaml", replace(slurp(data("scene/cube.yaml")), "../mesh/cube22.msh",
                                                                   data("mesh/cube22.msh").string())));
  EXPECT_EQ(plain.tet_k_vol, std::vector<double>(5, 2500));
}

TEST(StiffnessRegions, ARegionThatHoldsNoTetOrIsMalformedIsRefusedWithItsKey) {
  struct Case {
    std::string regions, needle;
  };
  const std::vector<Case> cases = {
      {"    - group: liver\n      k_vol: 7000\n",
       "key 'stiffness.regions[0].group': unknown group 'liver' (known groups in "},
      {"    - group: top\n      k_vol: 7000\n",
       "key 'stiffness.regions[0].group': the group 'top' holds no tet of the physical mesh (a surface group"},
      {"    - sphere: {center: [50, 50, 50], radius: 1}\n      k_vol: 7000\n",
       "key 'stiffness.regions[0].sphere': no tet of the physical mesh has its centroid in the sphere"},
      {"    - group: tissue\n", "key 'stiffness.regions[0]': expected k_vol (Pa), the part's stiffness"},
      {"    - group: tissue\n      box: {min: [0, 0, 0], max: [1, 1, 1]}\n      k_vol: 1\n",
       "key 'stiffness.regions[0]': expected exactly one of group, box, sphere, halfspace beside k_vol"},
      {"    - group: tissue\n      k_vol: -3\n", "key 'stiffness.regions[0].k_vol'"},
      {"    - group: tissue\n      k_vol: 3\n      k_det: 1\n", "key 'stiffness.regions[0].k_det': unknown key"},
      {"    group: tissue\n", "key 'stiffness.regions': expected a list of parts (a region and its k_vol)"},
      // checked against the same bound as stiffness.k_vol (1e308 made the step's numbers NaN)
      {"    - group: tissue\n      k_vol: 1e308\n", "key 'stiffness.regions[0].k_vol': 1e+308 is beyond 1e12 (Pa)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.regions);
    try {
      load_scene(write_temp("bad.yaml", cube_with_regions(c.regions)));
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
}

TEST(StiffnessRegions, APartOutsideSoftTissuesRangeIsWarnedWithItsKey) {
  const fs::path p = write_temp("bone.yaml", cube_with_regions("    - group: tissue\n      k_vol: 7000\n"
                                                               "    - box: {min: [0, 0, 0], max: [10, 10, 5]}\n"
                                                               "      k_vol: 2e9\n"));
  const Scene s = load_scene(p);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0], p.string() + ": stiffness.regions[1].k_vol = 2e+09 Pa is outside soft tissue's 10 Pa .. 100 MPa");
}

TEST(StiffnessRegions, TheResolvedSceneKeepsThemBitForBit) {
  const SceneSpec spec = load_scene_spec(write_temp("regions.yaml", cube_with_regions(
                                                                        "    - halfspace: {point: [0, 0, 5], normal: [0, 0, 1]}\n"
                                                                        "      k_vol: 12345.5\n"
                                                                        "    - sphere: {center: [1, 2, 3], radius: 4.5}\n"
                                                                        "      k_vol: 800\n")));
  const std::string yaml = resolved_scene_yaml(spec);
  const fs::path again_file = write_temp("again.yaml", yaml);
  const SceneSpec again = load_scene_spec(again_file);
  EXPECT_EQ(resolved_scene_yaml(again), yaml);
  ASSERT_EQ(again.stiffness_regions.size(), 2u);
  EXPECT_EQ(again.stiffness_regions[0].k_vol, 12345.5);
  EXPECT_EQ(again.stiffness_regions[1].region.a, spec.stiffness_regions[1].region.a);
  EXPECT_EQ(again.stiffness_regions[1].region.b.x, spec.stiffness_regions[1].region.b.x);
  // An override replaces the list as a whole.
  const SceneSpec overridden = load_scene_spec(again_file, {"stiffness.regions=[{group: tissue, k_vol: 99}]"});
  ASSERT_EQ(overridden.stiffness_regions.size(), 1u);
  EXPECT_EQ(overridden.stiffness_regions[0].k_vol, 99.0);
}

}  // namespace
}  // namespace ebh
