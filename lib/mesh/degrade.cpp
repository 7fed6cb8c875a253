#include "mesh/degrade.hpp"

#include <algorithm>
#include <stdexcept>

#include "math/splitmix.hpp"
#include "mesh/boundary.hpp"
#include "mesh/quality.hpp"

namespace ebh {
namespace {


double quality(const TetMesh& mesh, const Tet& t) {
  return tet_mean_ratio(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], mesh.vertices[t[3]]);
}

/// The foot of v's perpendicular on the plane through a, b, c, and whether it lies inside the triangle.
Vec3d foot_on_plane(const Vec3d& v, const Vec3d& a, const Vec3d& b, const Vec3d& c, bool* inside) {
  const Vec3d n = cross(b - a, c - a);
  const Vec3d p = v - (dot(v - a, n) / squared_norm(n)) * n;
  const double s0 = dot(cross(b - a, p - a), n), s1 = dot(cross(c - b, p - b), n), s2 = dot(cross(a - c, p - c), n);
  *inside = (s0 > 0 && s1 > 0 && s2 > 0) || (s0 < 0 && s1 < 0 && s2 < 0);
  return p;
}

}  // namespace

DegradeReport degrade_mesh_quality(TetMesh& mesh, const std::vector<std::uint8_t>& fixed,
                                   const DegradeOptions& options) {
  if (!(options.target_quality > 0 && options.target_quality < 1))
    throw std::invalid_argument("degrade_mesh_quality: target quality must be in (0, 1)");
  const int nv = static_cast<int>(mesh.vertices.size()), nt = static_cast<int>(mesh.tets.size());
  if (!fixed.empty() && fixed.size() != size_t(nv))
    throw std::invalid_argument("degrade_mesh_quality: fixed has the wrong size");

  // Vertices that may move: interior, not fixed. Incidence vertex -> tets.
  std::vector<std::uint8_t> movable(nv, 1);
  std::vector<int> surface_to_volume;
  extract_boundary(mesh, &surface_to_volume);
  for (int v : surface_to_volume) movable[v] = 0;
  for (int v = 0; v < nv && !fixed.empty(); ++v)
    if (fixed[v]) movable[v] = 0;
  std::vector<std::vector<int>> incident(nv);
  for (int t = 0; t < nt; ++t)
    for (int c = 0; c < 4; ++c) incident[mesh.tets[t][c]].push_back(t);

  DegradeReport report;
  std::vector<std::uint8_t> touched(nv, 0);  // a moved vertex and its neighbours: keep cases apart
  SplitMix64 rng{options.seed};
  const double target = options.target_quality;
  int attempts = 0;
  for (int done = 0; done < options.tets && attempts < 64 * std::max(options.tets, 1) && nt > 0; ++attempts) {
    const Tet tet = mesh.tets[rng.next() % std::uint64_t(nt)];
    if (std::any_of(tet.begin(), tet.end(), [&](int v) { return touched[v] != 0; })) continue;
    // The shape (0 cap, 1 sliver, 2 needle: in turn, else the next one this tet allows), the
    // corner to move and its direction.
    auto direction = [&](int c, int shape, Vec3d* dir) {
      const Vec3d& x = mesh.vertices[tet[c]];
      if (shape == 2) {
        int near = -1;
        for (int o = 0; o < 4; ++o)
          if (o != c && (near < 0 || squared_norm(mesh.vertices[tet[o]] - x) < squared_norm(mesh.vertices[tet[near]] - x)))
            near = o;
        *dir = mesh.vertices[tet[near]] - x;
        return true;
      }
      bool inside = false;
      const Vec3d foot = foot_on_plane(x, mesh.vertices[tet[(c + 1) % 4]], mesh.vertices[tet[(c + 2) % 4]],
                                       mesh.vertices[tet[(c + 3) % 4]], &inside);
      *dir = foot - x;
      return inside == (shape == 0) && squared_norm(*dir) > 0;
    };
    int corner = -1, shape = -1;
    Vec3d dir{};
    for (int turn = 0; turn < 3 && corner < 0; ++turn)
      for (int c = 0; c < 4 && corner < 0; ++c)
        if (movable[tet[c]] && direction(c, (done + turn) % 3, &dir)) { corner = c; shape = (done + turn) % 3; }
    if (corner < 0) continue;
    const int v = tet[corner];
    const Vec3d x0 = mesh.vertices[v];
    auto worst_around = [&](double s) {
      mesh.vertices[v] = x0 + s * dir;
      double q = 1;
      for (int t : incident[v]) q = std::min(q, quality(mesh, mesh.tets[t]));
      return q;
    };
    if (worst_around(0) < target) { mesh.vertices[v] = x0; continue; }
    double lo = 0, hi = 1;  // worst_around(lo) >= target > worst_around(hi)
    if (worst_around(1) >= target) lo = 1;
    for (int it = 0; it < 60 && lo < 1; ++it) {
      const double mid = 0.5 * (lo + hi);
      (worst_around(mid) >= target ? lo : hi) = mid;
    }
    mesh.vertices[v] = x0 + lo * dir;
    report.moved_vertices.push_back(v);
    (shape == 0 ? report.caps : shape == 1 ? report.slivers : report.needles)++;
    for (int t : incident[v])
      for (int u : mesh.tets[t]) touched[u] = 1;
    ++done;
  }
  report.worst_quality = 1;
  for (int t = 0; t < nt; ++t) {
    const double q = quality(mesh, mesh.tets[t]);
    if (q < report.worst_quality) { report.worst_quality = q; report.worst_tet = t; }
  }
  return report;
}

}  // namespace ebh
