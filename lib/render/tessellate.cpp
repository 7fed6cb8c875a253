#include "render/tessellate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ebh {
namespace {

struct Emitter {
  const Rigid<double>& world;
  TriangleSoup& out;
  void vertex(Vec3d p, Vec3d n) {
    out.position.push_back(static_cast<Vec3f>(apply(world, p)));
    out.normal.push_back(static_cast<Vec3f>(normalized(world.R * n)));
  }
  void triangle(Vec3d a, Vec3d na, Vec3d b, Vec3d nb, Vec3d c, Vec3d nc) {
    vertex(a, na);
    vertex(b, nb);
    vertex(c, nc);
  }
};

/// An orthonormal frame (e1, e2, u) with u the unit axis.
void axis_frame(Vec3d u, Vec3d& e1, Vec3d& e2) {
  e1 = detail::any_perpendicular(u);
  e2 = cross(u, e1);
}

/// Side of a round tube from a to b (radius r), and optionally a hemisphere or a flat cap at each
/// end. The surface is parameterised by angle phi around the axis and, on the hemispheres, by
/// polar angle theta from the axis.
void round_body(Emitter& e, Vec3d a, Vec3d b, double r, int segments, bool hemispheres, bool flat_caps) {
  const double len = norm(b - a);
  const Vec3d u = len > 0 ? (b - a) / len : Vec3d{0, 0, 1};
  Vec3d e1, e2;
  axis_frame(u, e1, e2);
  const double dphi = 2.0 * std::numbers::pi / segments;
  auto radial = [&](int i) { return std::cos(i * dphi) * e1 + std::sin(i * dphi) * e2; };
  for (int i = 0; i < segments; ++i) {
    const Vec3d r0 = radial(i), r1 = radial(i + 1);
    if (len > 0) {
      e.triangle(a + r * r0, r0, a + r * r1, r1, b + r * r1, r1);
      e.triangle(a + r * r0, r0, b + r * r1, r1, b + r * r0, r0);
    }
    if (flat_caps) {
      e.triangle(b, u, b + r * r0, u, b + r * r1, u);
      e.triangle(a, -u, a + r * r1, -u, a + r * r0, -u);
    }
  }
  if (!hemispheres) return;
  const int rings = std::max(2, segments / 4);
  const double dth = 0.5 * std::numbers::pi / rings;
  // Direction at (theta from the pole, around-axis index i) on the hemisphere whose pole is s*u.
  auto dir = [&](double s, int ring, int i) {
    const double th = ring * dth;
    return std::sin(th) * radial(i) + (s * std::cos(th)) * u;
  };
  for (int ring = 0; ring < rings; ++ring)
    for (int i = 0; i < segments; ++i) {
      // end b: pole +u; end a: pole -u (winding reversed so both face outwards)
      const Vec3d p00 = dir(1, ring, i), p01 = dir(1, ring, i + 1), p10 = dir(1, ring + 1, i),
                  p11 = dir(1, ring + 1, i + 1);
      e.triangle(b + r * p00, p00, b + r * p10, p10, b + r * p11, p11);
      if (ring > 0) e.triangle(b + r * p00, p00, b + r * p11, p11, b + r * p01, p01);
      const Vec3d q00 = dir(-1, ring, i), q01 = dir(-1, ring, i + 1), q10 = dir(-1, ring + 1, i),
                  q11 = dir(-1, ring + 1, i + 1);
      e.triangle(a + r * q00, q00, a + r * q11, q11, a + r * q10, q10);
      if (ring > 0) e.triangle(a + r * q00, q00, a + r * q01, q01, a + r * q11, q11);
    }
}

void box(Emitter& e, Vec3d c, Vec3d h) {
  for (int axis = 0; axis < 3; ++axis)
    for (int s = -1; s <= 1; s += 2) {
      Vec3d n{};
      n[axis] = s;
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      Vec3d t1{}, t2{};
      t1[a1] = h[a1];
      t2[a2] = h[a2];
      if (s < 0) std::swap(t1, t2);  // keep (t1, t2, n) right-handed: counter-clockwise outside
      Vec3d off{};
      off[axis] = s * h[axis];
      const Vec3d f = c + off;
      const Vec3d p0 = f - t1 - t2, p1 = f + t1 - t2, p2 = f + t1 + t2, p3 = f - t1 + t2;
      e.triangle(p0, n, p1, n, p2, n);
      e.triangle(p0, n, p2, n, p3, n);
    }
}

}  // namespace

void tessellate(const Collider<double>& c, const Rigid<double>& world, int segments, TriangleSoup& out) {
  Emitter e{world, out};
  segments = std::max(segments, 8);
  switch (c.shape) {
    case Shape::Sphere:
      round_body(e, c.a, c.a, c.radius, segments, true, false);
      break;
    case Shape::Capsule:
      round_body(e, c.a, c.b, c.radius, segments, true, false);
      break;
    case Shape::Cylinder:
      round_body(e, c.a, c.b, c.radius, segments, false, true);
      break;
    case Shape::Box:
      box(e, c.a, c.half);
      break;
  }
}

TriangleSoup tessellate(const PosedTool& tool, int segments) {
  TriangleSoup out;
  for (int i = 0; i < tool.count; ++i) tessellate(tool.shape[i], tool.world[i], segments, out);
  return out;
}

void vertex_normals(const std::vector<Vec3f>& positions, const std::vector<std::array<int, 3>>& triangles,
                    std::vector<Vec3f>& normals) {
  std::vector<Vec3d> acc(positions.size());
  for (const auto& t : triangles) {
    const auto a = static_cast<Vec3d>(positions[t[0]]), b = static_cast<Vec3d>(positions[t[1]]),
               c = static_cast<Vec3d>(positions[t[2]]);
    const Vec3d n = cross(b - a, c - a);  // twice the area times the unit normal
    if (!std::isfinite(n.x + n.y + n.z)) continue;
    for (int k : t) acc[k] += n;
  }
  normals.resize(positions.size());
  for (std::size_t i = 0; i < acc.size(); ++i) {
    const Vec3d n = normalized(acc[i]);
    normals[i] = norm(n) > 0 ? static_cast<Vec3f>(n) : Vec3f{0, 0, 1};
  }
}

}  // namespace ebh
