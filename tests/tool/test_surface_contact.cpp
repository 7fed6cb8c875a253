// Surface contact (tool/surface_contact.hpp): the samples, the candidate search against brute
// force, no tunnelling between vertices, the rounded box's query, and E_con of samples against
// finite differences on both sides (the virtual tool's pose; the virtual mesh's positions).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>
#include <memory>
#include <set>
#include <tuple>

#include "contact_points.hpp"
#include "mesh/boundary.hpp"
#include "mesh/box_mesh.hpp"
#include "tool/contact.hpp"
#include "tool/surface_contact.hpp"
#include "tool/tool_energy.hpp"
#include "tool/tool_model.hpp"
#include "tool/virtual_tool.hpp"

using namespace ebh;

namespace {

ToolModel surface_tool(ToolSpec::Kind kind) {
  ToolSpec spec;
  spec.kind = kind;
  ToolModel tool = build_tool(spec);
  round_box_edges(tool);  // as attach_surface_contact does
  return tool;
}

/// The box [-20, 20] x [-20, 20] x [-20, 0] mm's boundary, 4 x 4 x 2 cells (5 and 10 mm triangles).
SurfaceMesh box_surface() {
  return extract_boundary(make_box_tets({-0.02, -0.02, -0.02}, {0.02, 0.02, 0.0}, 4, 4, 2));
}

const Quatd kDown{0, 1, 0, 0};  // tool +z = world -z

}  // namespace

TEST(SurfaceSamples, SubTriangleCentroidsCoverTheTriangle) {
  const std::vector<Vec3d> rest = {{0, 0, 0}, {0.003, 0, 0}, {0, 0.003, 0}};
  const std::vector<std::array<int, 3>> tris = {{0, 1, 2}};
  const SurfaceContactModel s = build_surface_contact(tris, rest, 0.001);
  EXPECT_EQ(s.rest_level[0], 5);  // ceil(longest edge 4.24 mm / 1 mm)
  std::vector<SurfaceSample> out;
  triangle_samples(s, 0, rest, out);
  ASSERT_EQ(out.size(), 25u);
  Vec3d mean{};
  double weight = 0;
  std::set<std::pair<long, long>> distinct;
  for (const SurfaceSample& p : out) {
    EXPECT_NEAR(p.b[0] + p.b[1] + p.b[2], 1.0, 1e-15);  // b0 = 1 - b1 - b2: a rounding or two
    for (double b : p.b) EXPECT_GT(b, 0.0);
    mean += sample_point(s, p, rest) / 25.0;
    weight += p.weight;
    distinct.insert({std::lround(p.b[1] * 1e9), std::lround(p.b[2] * 1e9)});
  }
  EXPECT_EQ(distinct.size(), 25u);
  EXPECT_LT(norm(mean - Vec3d{0.001, 0.001, 0}), 1e-15);  // equal areas: the centroids average to the centroid
  // Weights: the triangle's area in units of an equilateral triangle of edge `spacing`.
  EXPECT_NEAR(weight, 4.5e-6 / (0.25 * std::sqrt(3.0) * 1e-6), 1e-12);  // 25 equal terms of ~0.42: round-off ~1e-15
}

TEST(SurfaceSamples, TheKthSampleIsForEachSamplesKth) {
  // The device tick lists samples by their index in for_each_sample's order and recomputes them
  // with sample_barycentric: the two must agree bitwise at every level.
  for (int n = 1; n <= kMaxSampleLevel; ++n) {
    int k = 0;
    for_each_sample(n, [&](double b0, double b1, double b2) {
      double c0 = -1, c1 = -1, c2 = -1;
      sample_barycentric(n, k, c0, c1, c2);
      ASSERT_EQ(c0, b0) << "n " << n << " k " << k;
      ASSERT_EQ(c1, b1) << "n " << n << " k " << k;
      ASSERT_EQ(c2, b2) << "n " << n << " k " << k;
      ++k;
    });
    ASSERT_EQ(k, n * n);
  }
}

TEST(SurfaceSamples, StretchingAddsRowsPastTheRestLevel) {
  const std::vector<Vec3d> rest = {{0, 0, 0}, {0.002, 0, 0}, {0, 0.001, 0}};
  const SurfaceContactModel s = build_surface_contact(std::vector<std::array<int, 3>>{{0, 1, 2}}, rest, 0.001);
  EXPECT_EQ(sample_level(s, 0, rest), 3);  // ceil(2.236)
  std::vector<Vec3d> q = rest;
  q[1].x = 0.0010;  // compressed: still the rest level
  EXPECT_EQ(sample_level(s, 0, q), 3);
  q[1].x = 0.0050;  // longest edge 5.10 mm
  EXPECT_EQ(sample_level(s, 0, q), 6);
  q[1].x = 1.0;  // absurd stretch: capped
  EXPECT_EQ(sample_level(s, 0, q), kMaxSampleLevel);
}

// Triangles longer than kMaxSampleLevel spacings lose the no-tunnelling bound, and long, thin ones
// carry many samples: both are said at load; an even mesh near the spacing is quiet.
TEST(SurfaceSamples, LongTrianglesAndManySamplesAreSaid) {
  const std::vector<std::array<int, 3>> tri{{0, 1, 2}};
  const std::vector<Vec3d> even = {{0, 0, 0}, {0.002, 0, 0}, {0, 0.002, 0}};
  EXPECT_TRUE(surface_contact_warnings(build_surface_contact(tri, even, 0.001), even).empty());
  const std::vector<Vec3d> long_one = {{0, 0, 0}, {0.060, 0, 0}, {0, 0.060, 0}};  // 85 spacings of 1 mm
  const std::vector<std::string> w = surface_contact_warnings(build_surface_contact(tri, long_one, 0.001), long_one);
  ASSERT_EQ(w.size(), 1u) << ::testing::PrintToString(w);
  EXPECT_EQ(w[0].rfind("surface contact: 1 triangle of the virtual mesh is longer than 64 sample spacings (the longest "
                       "84.85 mm; the spacing, the tool's thinnest part, 1 mm)", 0), 0u) << w[0];
  // 300 needles of 60 mm from one corner: 64^2 samples each, 1.2 million; 1000 of them 4.1 million
  std::vector<Vec3d> fan = {{0, 0, 0}};
  std::vector<std::array<int, 3>> needles;
  for (int k = 0; k <= 1000; ++k) fan.push_back({0.063, 1e-5 * k, 0});
  for (int k = 0; k < 1000; ++k) needles.push_back({0, k + 1, k + 2});
  const std::vector<std::string> many = surface_contact_warnings(build_surface_contact(needles, fan, 0.001), fan);
  ASSERT_EQ(many.size(), 2u) << ::testing::PrintToString(many);  // each long enough to be slow, and all of them
  EXPECT_EQ(many[1].rfind("surface contact: the virtual mesh's triangles carry 4.1e+06 sample points", 0), 0u) << many[1];
  // A 50 mm triangle with a 1 mm tool: 50^2 samples, which a tick near it tests (a 25 mm one: 625, no).
  const std::vector<Vec3d> coarse = {{0, 0, 0}, {0.040, 0, 0}, {0, 0.030, 0}};
  const std::vector<std::string> slow = surface_contact_warnings(build_surface_contact(tri, coarse, 0.001), coarse);
  ASSERT_EQ(slow.size(), 1u) << ::testing::PrintToString(slow);
  EXPECT_EQ(slow[0].rfind("surface contact: 1 triangle of the virtual mesh is longer than 32 sample spacings (the "
                          "longest 50 mm;", 0), 0u) << slow[0];
  EXPECT_NE(slow[0].find("ticks in contact there are slow; mesh.virtual_refine or a finer mesh splits them"),
            std::string::npos);
  const std::vector<Vec3d> finer = {{0, 0, 0}, {0.020, 0, 0}, {0, 0.015, 0}};
  EXPECT_TRUE(surface_contact_warnings(build_surface_contact(tri, finer, 0.001), finer).empty());
  // A strip of 30 x 0.1 mm slivers (31^2 samples each, the diagonal 30.0002 mm rounded up, on
  // 1.5 mm^2): 200 of them carry 192200 samples, 320 times their area's need; the same strip in
  // triangles 3 mm long does not.
  const auto strip = [](double length, int count) {
    std::pair<std::vector<Vec3d>, std::vector<std::array<int, 3>>> m;
    for (int k = 0; k <= count; ++k) {
      m.first.push_back({0, 1e-4 * k, 0});
      m.first.push_back({length, 1e-4 * k, 0});
    }
    for (int k = 0; k < count; ++k) {
      m.second.push_back({2 * k, 2 * k + 1, 2 * k + 3});
      m.second.push_back({2 * k, 2 * k + 3, 2 * k + 2});
    }
    return m;
  };
  const auto [sliver_rest, slivers] = strip(0.030, 100);
  const std::vector<std::string> thin = surface_contact_warnings(build_surface_contact(slivers, sliver_rest, 0.001), sliver_rest);
  ASSERT_EQ(thin.size(), 1u) << ::testing::PrintToString(thin);
  EXPECT_EQ(thin[0].rfind("surface contact: 200 long, thin triangles of the virtual mesh carry 1.92e+05 sample points, 320 "
                          "times what their area needs", 0), 0u) << thin[0];
  const auto [short_rest, shorts] = strip(0.003, 100);
  EXPECT_TRUE(surface_contact_warnings(build_surface_contact(shorts, short_rest, 0.001), short_rest).empty());
  // 64 triangles of 25 mm meeting at one point (a face fanned from its rim to its centre): none
  // long or thin enough to say, but a tool at the centre tests their 40000 samples at every query
  // (such a fan on a 40 mm block replayed at 0.09x real time, the block's even triangles at 2.4x).
  std::vector<Vec3d> wheel = {{0, 0, 0}};
  std::vector<std::array<int, 3>> spokes;
  for (int k = 0; k < 64; ++k) {
    const double a = 2 * std::numbers::pi * k / 64;
    wheel.push_back({0.025 * std::cos(a), 0.025 * std::sin(a), 0});
    spokes.push_back({0, 1 + k, 1 + (k + 1) % 64});
  }
  const std::vector<std::string> crowded = surface_contact_warnings(build_surface_contact(spokes, wheel, 0.001), wheel);
  ASSERT_EQ(crowded.size(), 1u) << ::testing::PrintToString(crowded);
  EXPECT_EQ(crowded[0].rfind("surface contact: 64 triangles of the virtual mesh reach within 5 mm of its vertex 0 (at (0, 0, "
                             "0) mm) and carry 4.03e+04 sample points", 0), 0u) << crowded[0];
  const SurfaceMesh box = box_surface();  // even 5 and 10 mm triangles
  const std::vector<std::string> even_box = surface_contact_warnings(build_surface_contact(box.triangles, box.vertices, 0.001), box.vertices);
  EXPECT_TRUE(even_box.empty()) << ::testing::PrintToString(even_box);
}

TEST(SurfaceContact, StiffnessFloorHoldsTheThinnestPartAtTheForceLimit) {
  EXPECT_DOUBLE_EQ(surface_stiffness_factor(400, 3.3, 0.001), 3.3 / 1.5e-3 / 400);
  EXPECT_DOUBLE_EQ(surface_stiffness_factor(5000, 3.3, 0.001), 1.0);  // already above the floor
  EXPECT_DOUBLE_EQ(surface_stiffness_factor(400, 0.0, 0.001), 1.0);   // no force limit: no floor
  EXPECT_DOUBLE_EQ(thinnest_part(surface_tool(ToolSpec::Kind::Hook)), ToolSpec{}.hook.tip_radius);
}

TEST(SurfaceContact, CandidateSamplesIncludeEveryContactFoundByBruteForce) {
  const SurfaceMesh mesh = box_surface();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int inside = 0;
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    const ToolModel tool = surface_tool(kind);
    const SurfaceContactModel s = build_surface_contact(mesh.triangles, mesh.vertices, thinnest_part(tool));
    for (int trial = 0; trial < 40; ++trial) {
      // Pose the tool so its tip is near the top face; bin the surface at q0, then move every
      // vertex by up to the grid's margin (what it tolerates) and query at the moved positions.
      const ToolPose pose{{0.012 * u(rng), 0.012 * u(rng), 0.004 + 0.004 * u(rng)},
                          normalized(quat_from_rotvec(0.4 * Vec3d{u(rng), u(rng), u(rng)}) * kDown)};
      const double T = trial % 2 ? 0.004 : 0.0, th = trial % 2 ? 0.05 : 0.0;
      const double margin = 0.002;
      std::vector<Vec3d> q = mesh.vertices;
      VertexGrid grid;
      grid.rebuild(q, margin);
      SurfaceScratch scratch;
      std::vector<SurfaceSample> gathered, all;
      const PosedTool posed = pose_tool(tool, pose, 0.7);
      gather_samples(s, posed, q, grid, T, th, {}, scratch, gathered);
      for (Vec3d& v : q) v += (0.99 * margin / std::sqrt(3.0)) * Vec3d{u(rng), u(rng), u(rng)};
      gather_samples(s, posed, q, grid, T, th, {}, scratch, gathered);
      for (int t = 0; t < static_cast<int>(s.triangles.size()); ++t) triangle_samples(s, t, q, all);
      // Every sample inside the tool at a pose the call may reach (here: the pose itself, and a
      // pose moved by T and turned by th about the rotation centre) is among the gathered ones.
      std::set<std::tuple<int, long, long>> have;
      for (const SurfaceSample& p : gathered) have.insert({p.triangle, std::lround(p.b[1] * 1e9), std::lround(p.b[2] * 1e9)});
      for (const ToolPose& reach : {pose, ToolPose{pose.position + Vec3d{0, 0, -T},
                                                  normalized(quat_from_rotvec(Vec3d{th, 0, 0}) * pose.orientation)}}) {
        std::vector<ContactPoint> contacts;
        sample_narrow_phase(s, pose_tool(tool, reach, 0.7), all, q, contacts);
        for (const ContactPoint& c : contacts) {
          const SurfaceSample& p = all[c.vertex];
          ++inside;
          EXPECT_TRUE(have.count({p.triangle, std::lround(p.b[1] * 1e9), std::lround(p.b[2] * 1e9)}))
              << "trial " << trial << ": triangle " << p.triangle << " missed";
        }
      }
    }
  }
  EXPECT_GT(inside, 200) << "the poses touch the surface";
}

// A surface whose triangles are mostly tiny in one place (a locally refined patch) made the mean
// edge tiny and the triangle grid 1024^3 cells over the whole surface (8.6 GB for 0.5 million
// triangles in a 2.5 mm patch of a 40 mm block): the grid holds at most
// kTriangleGridCellsPerTriangle cells a triangle, and still finds every contact.
TEST(SurfaceContact, ADensePatchKeepsTheTriangleGridToItsTriangles) {
  SurfaceMesh mesh = box_surface();
  // A 0.6 mm patch of 60 x 60 squares (7200 triangles of 0.01 mm) just above the top face.
  const int n = 60, first = static_cast<int>(mesh.vertices.size());
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) mesh.vertices.push_back({0.001 + 1e-5 * i, 0.001 + 1e-5 * j, 1e-6});
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = first + i * (n + 1) + j, b = a + n + 1;
      mesh.triangles.push_back({a, b, b + 1});
      mesh.triangles.push_back({a, b + 1, a + 1});
    }
  const ToolModel tool = surface_tool(ToolSpec::Kind::Hook);
  const SurfaceContactModel s = build_surface_contact(mesh.triangles, mesh.vertices, thinnest_part(tool));
  VertexGrid grid;
  grid.rebuild(mesh.vertices, 0.002);
  SurfaceScratch scratch;
  std::vector<SurfaceSample> gathered, all;
  for (const Vec3d& at : {Vec3d{0.0013, 0.0013, 0}, Vec3d{-0.012, 0.008, 0}}) {  // on the patch, away from it
    const double depth = 0.0005;  // the hook's tip capsule (tool frame z = L) 0.5 mm into the top face
    const ToolPose pose{{at.x, at.y, tool.spec.hook.tip_length + tool.spec.hook.tip_radius - depth}, kDown};
    const PosedTool posed = pose_tool(tool, pose, 1.0);
    gather_samples(s, posed, mesh.vertices, grid, 0, 0, {}, scratch, gathered);
    const double cells = double(scratch.dims[0]) * scratch.dims[1] * scratch.dims[2];
    EXPECT_LE(cells, kTriangleGridCellsPerTriangle * static_cast<double>(s.triangles.size()))
        << scratch.dims[0] << " x " << scratch.dims[1] << " x " << scratch.dims[2] << " cells";
    all.clear();
    for (int t = 0; t < static_cast<int>(s.triangles.size()); ++t) triangle_samples(s, t, mesh.vertices, all);
    std::set<std::tuple<int, long, long>> have;
    for (const SurfaceSample& p : gathered) have.insert({p.triangle, std::lround(p.b[1] * 1e9), std::lround(p.b[2] * 1e9)});
    std::vector<ContactPoint> contacts;
    sample_narrow_phase(s, posed, all, mesh.vertices, contacts);
    EXPECT_FALSE(contacts.empty());
    for (const ContactPoint& c : contacts) {
      const SurfaceSample& p = all[c.vertex];
      EXPECT_TRUE(have.count({p.triangle, std::lround(p.b[1] * 1e9), std::lround(p.b[2] * 1e9)}))
          << "triangle " << p.triangle << " missed";
    }
  }
}

TEST(SurfaceContact, AThinToolBetweenVerticesIsFelt) {
  // Two 20 mm triangles; the hook's 1 mm tip pressed into the middle, far from every vertex.
  const std::vector<Vec3d> rest = {{-0.01, -0.01, 0}, {0.01, -0.01, 0}, {0.01, 0.01, 0}, {-0.01, 0.01, 0}};
  const std::vector<std::array<int, 3>> tris = {{0, 1, 2}, {0, 2, 3}};
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Hook;
  const ToolModel tool = build_tool(spec);
  const SurfaceContactModel s = build_surface_contact(tris, rest, thinnest_part(tool));
  VertexGrid grid;
  grid.rebuild(rest, 0.002);
  for (double depth : {0.0001, 0.0005, 0.0009}) {
    // Tip capsule (tool frame (0,0,L) -> (L,0,L)) lowest at z = -depth below the surface.
    const double L = spec.hook.tip_length, r = spec.hook.tip_radius;
    const ToolPose pose{{-0.002, 0.0005, L + r - depth}, kDown};
    std::vector<ContactTarget> vertex_targets, surface_targets;
    detect_contacts(tool, pose, 1.0, rest, {}, grid, 400, vertex_targets);
    EXPECT_TRUE(vertex_targets.empty()) << "no vertex is near the tip";
    SurfaceScratch scratch;
    surface_contact_targets(s, tool, pose, 1.0, rest, grid, 400, {}, scratch, surface_targets);
    ASSERT_FALSE(surface_targets.empty()) << "depth " << depth;
    // The deepest sample is within half the sample spacing (~0.35 mm here) of the tip's lowest
    // line: depth lost r - sqrt(r^2 - 0.35^2 mm^2) ~ 0.06 mm.
    EXPECT_NEAR(surface_penetration_depth(s, tool, pose, 1.0, rest, grid, {}, scratch), depth, 1e-4);
    for (const ContactTarget& t : surface_targets) {
      EXPECT_LT(t.target.z, rest[t.vertex].z) << "the surface is pushed down, away from the tool";
      EXPECT_GT(t.stiffness, 0.0);
    }
  }
}

TEST(RoundedBox, QueryMatchesFiniteDifferencesAndIsContinuousAtEdges) {
  Collider<double> box;
  box.shape = Shape::Box;
  box.a = {0.001, -0.002, 0.003};
  box.half = {0.001, 0.0025, 0.01};
  box.radius = 0.001;  // a jaw: rounded by its half thickness; the core is a flat rectangle
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int checked = 0;
  for (int t = 0; t < 4000 && checked < 300; ++t) {
    const Vec3d p = box.a + Vec3d{0.0013 * u(rng), 0.0028 * u(rng), 0.0103 * u(rng)};
    const SurfaceQuery<double> s = query_local(box, p);
    EXPECT_NEAR(signed_distance_local(box, p), s.sd, 1e-15);  // the same arithmetic, metres ~1e-3
    EXPECT_NEAR(norm(s.point - p), std::fabs(s.sd), 1e-12);   // a norm recomputed: relative round-off
    if (!(s.sd < -1e-5) || s.sd < -0.00099) continue;  // inside, not at the core (medial) plane
    const double eps = 1e-8;
    Vec3d grad;
    Mat3d H;
    for (int k = 0; k < 3; ++k) {
      Vec3d d{};
      d[k] = eps;
      grad[k] = (signed_distance_local(box, p + d) - signed_distance_local(box, p - d)) / (2 * eps);
      const Vec3d dn = (query_local(box, p + d).normal - query_local(box, p - d).normal) / (2 * eps);
      for (int i = 0; i < 3; ++i) H(i, k) = dn[i];
    }
    // Central differences with eps = 1e-8 m at a distance d >= 1e-5 m from the core's nearest
    // feature (depth < 0.99 radius): truncation eps^2 / d^2 <= 1e-6 on the gradient, eps^2 / d^3
    // <= 0.1 /m on the Hessian (whose entries reach 1 / d = 1e5 /m).
    EXPECT_LT(norm(grad - s.normal), 1e-6);
    double err = 0, scale = 1.0 / 1e-3;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) err = std::max(err, std::fabs(H(i, k) - s.hess(i, k)));
    EXPECT_LT(err, 1e-4 * scale) << "at " << p.x << " " << p.y << " " << p.z;
    ++checked;
  }
  EXPECT_GE(checked, 100);
  // Along a path across the edge between the bottom face and the end face, 0.3 mm deep, the
  // closest point moves continuously (a sharp box's jumps from one face to the other).
  Vec3d prev{};
  double largest = 0;
  for (int i = 0; i <= 1000; ++i) {
    const double a = M_PI / 2 * i / 1000.0;
    const Vec3d core_edge = box.a + Vec3d{0, 0, box.half.z - box.radius};
    const Vec3d p = core_edge + 0.0007 * Vec3d{std::sin(a), 0, std::cos(a)};
    const Vec3d cp = query_local(box, p).point;
    if (i) largest = std::max(largest, norm(cp - prev));
    prev = cp;
  }
  EXPECT_LT(largest, 5e-6);  // 1 mm * pi/2 / 1000 per step
}

namespace {

/// E_tool of fixed surface samples (one per tiny triangle around points inside the tool) at pose(x).
struct SampleCase {
  ToolModel tool;
  SurfaceContactModel surface;
  std::vector<Vec3d> q;
  std::vector<SurfaceSample> samples;
  ToolPose pose, physical;
  Stiffness k;
  double jaw = 0.6;
};

double sample_energy(const SampleCase& c, const Vec6& x, Vec6* g, Mat6* H) {
  const ToolPose p = perturb(c.pose, x);
  std::vector<ContactPoint> contacts;
  sample_narrow_phase(c.surface, pose_tool(c.tool, p, c.jaw), c.samples, c.q, contacts);
  return test::coupling_and_contact_energy(p, c.physical, c.k, contacts, g, H);
}

SampleCase make_sample_case(ToolSpec::Kind kind, std::mt19937& rng) {
  SampleCase c;
  c.tool = surface_tool(kind);
  std::normal_distribution<double> n(0, 1);
  c.pose = {{0.01, -0.02, 0.03}, normalized(Quatd{n(rng), n(rng), n(rng), n(rng)})};
  c.physical = {c.pose.position + 0.003 * Vec3d{n(rng), n(rng), n(rng)},
                normalized(quat_from_rotvec(0.4 * Vec3d{n(rng), n(rng), n(rng)}) * c.pose.orientation)};
  std::vector<std::array<int, 3>> tris;
  for (const Vec3d& y : test::inside_points(pose_tool(c.tool, c.pose, c.jaw), rng, 10, 5e-5)) {
    // A 0.1 mm triangle with centroid y: one sample (level 1), at y.
    const Vec3d e1 = 1e-4 * normalized(Vec3d{n(rng), n(rng), n(rng)}), e2 = 1e-4 * normalized(Vec3d{n(rng), n(rng), n(rng)});
    const int base = static_cast<int>(c.q.size());
    c.q.push_back(y - (e1 + e2) / 3.0);
    c.q.push_back(y + e1 - (e1 + e2) / 3.0);
    c.q.push_back(y + e2 - (e1 + e2) / 3.0);
    tris.push_back({base, base + 1, base + 2});
  }
  c.surface = build_surface_contact(tris, c.q, thinnest_part(c.tool));
  for (int t = 0; t < static_cast<int>(tris.size()); ++t) triangle_samples(c.surface, t, c.q, c.samples);
  return c;
}

}  // namespace

TEST(SurfaceContact, ToolSideGradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(11);
  for (auto kind : {ToolSpec::Kind::Hook, ToolSpec::Kind::Forceps}) {
    for (int t = 0; t < 6; ++t) {
      const SampleCase c = make_sample_case(kind, rng);
      ASSERT_EQ(c.samples.size(), 10u);
      Vec6 g;
      Mat6 H;
      sample_energy(c, Vec6::Zero(), &g, &H);
      const double eps = 1e-7;
      Vec6 fd;
      Mat6 fdH;
      for (int i = 0; i < 6; ++i) {
        Vec6 x = Vec6::Zero(), gp, gm;
        x[i] = eps;
        const double ep = sample_energy(c, x, &gp, nullptr);
        gp = test::pulled_back(x, gp);
        x[i] = -eps;
        fd[i] = (ep - sample_energy(c, x, &gm, nullptr)) / (2 * eps);
        gm = test::pulled_back(x, gm);
        fdH.col(i) = (gp - gm) / (2 * eps);
      }
      // Relative 1e-5, as for vertex contact (test_tool_derivatives.cpp): the samples are at least
      // 0.1 mm from a rounded box's core and 5e-5 m deep, so curvature radii >= ~1e-4 m give
      // O(eps^2 / rho^2) = 1e-6 truncation with eps = 1e-7.
      EXPECT_LE((fd - g).norm(), 1e-5 * g.norm() + 1e-12) << g.transpose() << "\n" << fd.transpose();
      EXPECT_LE((fdH - H).norm(), 1e-5 * H.norm()) << H << "\n\n" << fdH;
    }
  }
}

TEST(SurfaceContact, MeshSideTargetsCarryTheGradientOfTheSampleEnergy) {
  // E(q) = w k/2 sd(y(q))^2 for each sample in contact, the tool fixed: the targets' residual
  // sum k_i (target_i - q_i) at the current q is -dE/dq_i.
  std::mt19937 rng(5);
  const SampleCase c = make_sample_case(ToolSpec::Kind::Forceps, rng);
  const double k_con = 400;
  const PosedTool posed = pose_tool(c.tool, c.pose, c.jaw);
  const auto energy = [&](const std::vector<Vec3d>& q) {
    std::vector<ContactPoint> contacts;
    sample_narrow_phase(c.surface, posed, c.samples, q, contacts);
    double e = 0;
    for (const ContactPoint& cp : contacts) e += 0.5 * k_con * cp.weight * cp.phi * cp.phi;
    return e;
  };
  // Targets as surface_contact_targets builds them (every sample here is in contact).
  std::vector<ContactPoint> contacts;
  sample_narrow_phase(c.surface, posed, c.samples, c.q, contacts);
  ASSERT_EQ(contacts.size(), c.samples.size());
  std::vector<Vec3d> residual(c.q.size());
  for (const ContactPoint& cp : contacts) {
    const SurfaceSample& p = c.samples[cp.vertex];
    const auto& v = c.surface.triangles[p.triangle];
    for (int j = 0; j < 3; ++j) {
      const double kj = k_con * p.weight * p.b[j];
      residual[v[j]] += kj * ((c.q[v[j]] + (cp.target - cp.lever)) - c.q[v[j]]);
    }
  }
  const double eps = 1e-9;
  for (std::size_t i = 0; i < c.q.size(); i += 7)
    for (int k = 0; k < 3; ++k) {
      std::vector<Vec3d> qp = c.q, qm = c.q;
      qp[i][k] += eps;
      qm[i][k] -= eps;
      const double dE = (energy(qp) - energy(qm)) / (2 * eps);
      // eps = 1e-9 m on E ~ 1e-4 J: round-off ~1e-16 E / eps ~ 1e-11 N, truncation ~eps^2 (third derivative of E) ~ 1e-12 N,
      // against residuals of ~0.1 N: 1e-6 N leaves room for both.
      EXPECT_NEAR(-dE, residual[i][k], 1e-6 * std::max(1.0, std::fabs(dE))) << "vertex " << i << " axis " << k;
    }
}

TEST(SurfaceContact, AMeshIterationAfterANewtonCallReusesItsSamples) {
  // The targets from the Newton call's samples (the path virtual_mesh_targets takes right after
  // update_virtual_tool) are those a fresh search finds: the same vertices, targets and stiffnesses.
  const SurfaceMesh mesh = box_surface();
  ToolSpec spec;
  spec.kind = ToolSpec::Kind::Forceps;
  ToolModel tool = build_tool(spec);
  Stiffness k;
  attach_surface_contact(tool, mesh.triangles, mesh.vertices, k.k_con);
  VertexGrid grid;
  grid.rebuild(mesh.vertices, 0.002);
  VirtualToolState st;
  const ToolPose start{{0.003, -0.002, 0.0163}, kDown};  // the open jaws' tips (17.3 mm below) 1 mm into the top face
  init_virtual_tool(st, mesh.vertices.size(), start);
  const ToolPose device{start.position + Vec3d{0, 0, -0.004}, kDown};
  update_virtual_tool(tool, k, device, 1.0, mesh.vertices, {}, grid, st);
  ASSERT_TRUE(st.call_fresh);
  std::vector<ContactTarget> reused, searched;
  virtual_mesh_targets(tool, k, 1.0, mesh.vertices, {}, grid, st, reused);
  EXPECT_FALSE(st.call_fresh) << "the iteration that follows moves q";
  virtual_mesh_targets(tool, k, 1.0, mesh.vertices, {}, grid, st, searched);
  ASSERT_GT(reused.size(), 10u);
  ASSERT_EQ(reused.size(), searched.size());
  auto key = [](const ContactTarget& t) { return std::make_tuple(t.vertex, t.target.x, t.target.y, t.target.z, t.stiffness); };
  std::vector<std::tuple<int, double, double, double, double>> a, b;
  for (const ContactTarget& t : reused) a.push_back(key(t));
  for (const ContactTarget& t : searched) b.push_back(key(t));
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b);
}
