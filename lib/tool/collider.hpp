#pragma once
// Tool colliders (§5.1): parameterised convex primitives in a local frame (the tool frame or a
// jaw's hinge frame), each with a signed-distance / closest-surface-point query. Host/device
// (EBH_HD) templates on the scalar so a CUDA backend reuses the same vertex-tool collision math.
//
// Conventions: sd < 0 inside. `normal` is the outward unit normal at the closest surface point
// (= grad sd away from the medial axis), `point` = p - sd * normal is q_proj of the closest-point
// projection, `hess` = Hessian of sd at p, exact for points inside the collider (sd <= 0; it is
// zero on flat faces and (I - n n^T - a a^T) / rho on curved ones) and left zero outside, where
// no contact energy exists.
#include "math/vec.hpp"

namespace ebh {

enum class Shape : int { Sphere = 0, Capsule = 1, Cylinder = 2, Box = 3 };

/// Which frame a collider is expressed in (tool_model.hpp gives their poses).
enum class ColliderFrame : int { Tool = 0, UpperJaw = 1, LowerJaw = 2 };

/// One convex primitive in its frame (metres).
///   Sphere:   centre a, radius
///   Capsule:  segment a -> b, radius
///   Cylinder: axis a -> b with flat caps at a and b, radius
///   Box:      centre a, half extents `half` along the frame's axes; with radius > 0 its edges and
///             corners are rounded by that radius (the box of half extents half - radius swept by a
///             ball: its closest-point projection is continuous to a depth of `radius`, where a
///             sharp box's jumps between faces at the edges)
template <class T>
struct Collider {
  Shape shape = Shape::Sphere;
  ColliderFrame frame = ColliderFrame::Tool;
  Vec3<T> a{}, b{};
  T radius{};
  Vec3<T> half{};
};

/// A rigid transform x_parent = R x_child + t.
template <class T>
struct Rigid {
  Mat3<T> R = Mat3<T>::identity();
  Vec3<T> t{};
};
template <class T> EBH_HD Vec3<T> apply(const Rigid<T>& f, Vec3<T> x) { return f.R * x + f.t; }
template <class T> EBH_HD Vec3<T> apply_inverse(const Rigid<T>& f, Vec3<T> x) { return transpose(f.R) * (x - f.t); }
template <class T> EBH_HD Rigid<T> compose(const Rigid<T>& a, const Rigid<T>& b) { return {a.R * b.R, a.R * b.t + a.t}; }

/// A jaw's hinge frame in the tool frame: the rotation about the tool's y axis by the angle with
/// cosine c and sine s (maps +z to (s, 0, c)); the upper jaw turns by +angle, the lower by -angle.
template <class T> EBH_HD Mat3<T> jaw_rotation(T c, T s) {
  Mat3<T> R = Mat3<T>::identity();
  R(0, 0) = c; R(0, 2) = s; R(2, 0) = -s; R(2, 2) = c;
  return R;
}

/// Collider frame f -> world for the tool frame -> world `tool`, the jaws opened by the angle with
/// cosine c and sine s (tool_model.hpp: jaw_opening).
template <class T> EBH_HD Rigid<T> collider_world(const Rigid<T>& tool, ColliderFrame f, T c, T s) {
  if (f == ColliderFrame::Tool) return tool;
  Rigid<T> hinge;
  hinge.R = jaw_rotation(c, f == ColliderFrame::UpperJaw ? s : -s);
  return compose(tool, hinge);
}

template <class T>
struct SurfaceQuery {
  T sd{};            ///< signed distance, negative inside
  Vec3<T> point{};   ///< closest surface point
  Vec3<T> normal{};  ///< outward unit normal at `point`
  Mat3<T> hess{};    ///< Hessian of sd at p (exact inside; zero outside)
};

namespace detail {
/// Smallest radial distance used in curvature terms: below it (a point within 1e-3 of the
/// radius of a capsule's or cylinder's axis, or a sphere's centre) the exact 1/rho curvature is
/// replaced by 1/rho_min so the Hessian stays finite. The energy and gradient are unaffected.
template <class T> EBH_HD T rho_floor(T radius) { return T(1e-3) * radius; }

/// A deterministic unit vector perpendicular to unit u.
template <class T> EBH_HD Vec3<T> any_perpendicular(Vec3<T> u) {
  Vec3<T> e = (u.x * u.x < T(0.5)) ? Vec3<T>{1, 0, 0} : Vec3<T>{0, 1, 0};
  return normalized(e - dot(e, u) * u);
}

/// Round part: p at radial offset v (length rho) from a centre (point) or an axis (unit u, or
/// zero for a sphere); fills sd, normal, point, hess.
template <class T>
EBH_HD SurfaceQuery<T> round_query(Vec3<T> p, Vec3<T> v, Vec3<T> u, T radius, Vec3<T> fallback_normal) {
  SurfaceQuery<T> s;
  const T rho = norm(v);
  s.sd = rho - radius;
  s.normal = rho > T(0) ? v / rho : fallback_normal;
  s.point = p - s.sd * s.normal;
  if (s.sd <= T(0)) {
    const T r = rho > rho_floor(radius) ? rho : rho_floor(radius);
    s.hess = (T(1) / r) * (Mat3<T>::identity() - outer(s.normal, s.normal) - outer(u, u));
  }
  return s;
}
/// A box with rounded edges (Collider::radius > 0): the core box of half extents half - radius,
/// inflated by radius. Outside the core the closest core point cl, n = (p - cl) / |p - cl|, sd =
/// |p - cl| - radius, and the Hessian is that of the distance to the core's nearest feature: 0 at
/// a face, (I - n n^T - a a^T) / |p - cl| at an edge along a, (I - n n^T) / |p - cl| at a corner.
/// Inside the core (deeper than radius) the nearest face, as for a sharp box.
template <class T>
EBH_HD SurfaceQuery<T> rounded_box_query(const Collider<T>& c, Vec3<T> p) {
  const T r = c.radius;
  const Vec3<T> hc{c.half.x - r, c.half.y - r, c.half.z - r};
  const Vec3<T> v = p - c.a;
  SurfaceQuery<T> q;
  const Vec3<T> d{(v.x < 0 ? -v.x : v.x) - hc.x, (v.y < 0 ? -v.y : v.y) - hc.y, (v.z < 0 ? -v.z : v.z) - hc.z};
  if (d.x <= T(0) && d.y <= T(0) && d.z <= T(0)) {
    int k = 0;
    if (d.y > d[k]) k = 1;
    if (d.z > d[k]) k = 2;
    q.sd = d[k] - r;
    Vec3<T> n{};
    n[k] = v[k] < T(0) ? T(-1) : T(1);
    q.normal = n;
    q.point = p - q.sd * n;
    return q;
  }
  const Vec3<T> cl = cwise_max(cwise_min(v, hc), -hc);
  const Vec3<T> diff = v - cl;
  const T dist = norm(diff);
  q.normal = diff / dist;
  q.sd = dist - r;
  q.point = c.a + cl + r * q.normal;
  if (q.sd <= T(0)) {
    int outside = 0, along = 0;
    for (int k = 0; k < 3; ++k) {
      if (d[k] > T(0)) ++outside;
      else along = k;
    }
    if (outside >= 2) {
      const T rho = dist > rho_floor(r) ? dist : rho_floor(r);
      Mat3<T> P = Mat3<T>::identity() - outer(q.normal, q.normal);
      if (outside == 2) {
        Vec3<T> a{};
        a[along] = T(1);
        P = P - outer(a, a);
      }
      q.hess = (T(1) / rho) * P;
    }
  }
  return q;
}
}  // namespace detail

/// Signed distance, closest surface point, outward normal and sd Hessian of p (collider frame).
template <class T>
EBH_HD SurfaceQuery<T> query_local(const Collider<T>& c, Vec3<T> p) {
  switch (c.shape) {
    case Shape::Sphere:
      return detail::round_query(p, p - c.a, Vec3<T>{}, c.radius, Vec3<T>{0, 0, 1});
    case Shape::Capsule: {
      const Vec3<T> ab = c.b - c.a;
      const T len = norm(ab);
      const Vec3<T> u = ab / len;
      T s = dot(p - c.a, u);
      const bool interior = s > T(0) && s < len;
      s = s < T(0) ? T(0) : (s > len ? len : s);
      const Vec3<T> v = p - (c.a + s * u);
      return detail::round_query(p, v, interior ? u : Vec3<T>{}, c.radius, detail::any_perpendicular(u));
    }
    case Shape::Cylinder: {
      const Vec3<T> ab = c.b - c.a;
      const T len = norm(ab);
      const Vec3<T> u = ab / len;
      const T s = dot(p - c.a, u) - len / T(2);      // axial coordinate from the mid-point
      const Vec3<T> v = (p - c.a) - dot(p - c.a, u) * u;  // radial offset
      const T rho = norm(v);
      const Vec3<T> vr = rho > T(0) ? v / rho : detail::any_perpendicular(u);
      const T dr = rho - c.radius, dz = (s < T(0) ? -s : s) - len / T(2);
      const Vec3<T> ucap = s < T(0) ? -u : u;
      SurfaceQuery<T> q;
      if (dr <= T(0) && dz <= T(0)) {  // inside: the nearer of the side and the cap
        if (dr > dz) {
          q = detail::round_query(p, v, u, c.radius, vr);
        } else {
          q.sd = dz;
          q.normal = ucap;
          q.point = p - q.sd * q.normal;
        }
      } else if (dr > T(0) && dz > T(0)) {  // beyond the rim circle
        const Vec3<T> rim = c.a + (len / T(2) + (s < T(0) ? -len / T(2) : len / T(2))) * u + c.radius * vr;
        const Vec3<T> d = p - rim;
        q.sd = norm(d);
        q.normal = d / q.sd;
        q.point = rim;
      } else if (dr > T(0)) {
        q.sd = dr;
        q.normal = vr;
        q.point = p - q.sd * q.normal;
      } else {
        q.sd = dz;
        q.normal = ucap;
        q.point = p - q.sd * q.normal;
      }
      return q;
    }
    case Shape::Box:
    default: {
      if (c.radius > T(0)) return detail::rounded_box_query(c, p);
      const Vec3<T> v = p - c.a;
      SurfaceQuery<T> q;
      Vec3<T> d{(v.x < 0 ? -v.x : v.x) - c.half.x, (v.y < 0 ? -v.y : v.y) - c.half.y,
                (v.z < 0 ? -v.z : v.z) - c.half.z};
      if (d.x <= T(0) && d.y <= T(0) && d.z <= T(0)) {  // inside: the nearest face
        int k = 0;
        if (d.y > d[k]) k = 1;
        if (d.z > d[k]) k = 2;
        q.sd = d[k];
        Vec3<T> n{};
        n[k] = v[k] < T(0) ? T(-1) : T(1);
        q.normal = n;
        q.point = p - q.sd * n;
      } else {
        const Vec3<T> cl = cwise_max(cwise_min(v, c.half), -c.half);
        const Vec3<T> diff = v - cl;
        q.sd = norm(diff);
        q.normal = diff / q.sd;
        q.point = c.a + cl;
      }
      return q;
    }
  }
}

/// Signed distance of p (collider frame) alone: the same value as query_local(c, p).sd, without
/// the closest point, normal and Hessian (broad-phase filters and the narrow phase's first pass).
template <class T>
EBH_HD T signed_distance_local(const Collider<T>& c, Vec3<T> p) {
  switch (c.shape) {
    case Shape::Sphere:
      return norm(p - c.a) - c.radius;
    case Shape::Capsule: {
      const Vec3<T> ab = c.b - c.a;
      const T len2 = dot(ab, ab);
      T s = dot(p - c.a, ab) / len2;
      s = s < T(0) ? T(0) : (s > T(1) ? T(1) : s);
      return norm(p - (c.a + s * ab)) - c.radius;
    }
    case Shape::Cylinder: {
      const Vec3<T> ab = c.b - c.a;
      const T len = norm(ab);
      const Vec3<T> u = ab / len;
      const T axial = dot(p - c.a, u);
      const T rho = norm((p - c.a) - axial * u);
      const T s = axial - len / T(2);
      const T dr = rho - c.radius, dz = (s < T(0) ? -s : s) - len / T(2);
      if (dr <= T(0) && dz <= T(0)) return dr > dz ? dr : dz;
      if (dr > T(0) && dz > T(0)) return EBH_SQRT(dr * dr + dz * dz);
      return dr > T(0) ? dr : dz;
    }
    case Shape::Box:
    default: {
      const Vec3<T> v = p - c.a;
      const T r = c.radius > T(0) ? c.radius : T(0);  // rounded: the core box, then - r
      const Vec3<T> d{(v.x < 0 ? -v.x : v.x) - (c.half.x - r), (v.y < 0 ? -v.y : v.y) - (c.half.y - r),
                      (v.z < 0 ? -v.z : v.z) - (c.half.z - r)};
      if (d.x <= T(0) && d.y <= T(0) && d.z <= T(0)) {
        T m = d.x > d.y ? d.x : d.y;
        return (m > d.z ? m : d.z) - r;
      }
      const Vec3<T> o{d.x > T(0) ? d.x : T(0), d.y > T(0) ? d.y : T(0), d.z > T(0) ? d.z : T(0)};
      return norm(o) - r;
    }
  }
}

/// Radius of a ball around the collider's centre that contains it.
template <class T>
EBH_HD T bounding_radius(const Collider<T>& c) {
  switch (c.shape) {
    case Shape::Sphere: return c.radius;
    case Shape::Capsule: return norm(c.b - c.a) / T(2) + c.radius;
    case Shape::Cylinder: { T h = norm(c.b - c.a) / T(2); return EBH_SQRT(h * h + c.radius * c.radius); }
    case Shape::Box: default: return norm(c.half);
  }
}
template <class T>
EBH_HD Vec3<T> centre(const Collider<T>& c) {
  return (c.shape == Shape::Capsule || c.shape == Shape::Cylinder) ? (c.a + c.b) / T(2) : c.a;
}

/// Inverse-normal projection (the paper's option, §5.1): distance t >= 0 along unit direction d
/// from p (inside the collider, sd(p) < 0) to where the ray leaves the collider. Bisection on sd,
/// valid for every convex primitive; 60 halvings bring the bracket below 1e-18 of its length.
template <class T>
EBH_HD T exit_distance_local(const Collider<T>& c, Vec3<T> p, Vec3<T> d) {
  T lo = T(0), hi = norm(p - centre(c)) + bounding_radius(c);  // p + hi d is outside
  for (int i = 0; i < 60; ++i) {
    const T mid = T(0.5) * (lo + hi);
    if (query_local(c, p + mid * d).sd < T(0)) lo = mid; else hi = mid;
  }
  return T(0.5) * (lo + hi);
}

}  // namespace ebh
