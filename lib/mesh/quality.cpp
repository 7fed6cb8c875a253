#include "mesh/quality.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <tuple>
#include <unordered_map>

#include "mesh/boundary.hpp"
#include "mesh/tet_locator.hpp"

namespace ebh {

std::string vertex_name(const TetMesh& mesh, int v) {
  std::string s = "vertex " + std::to_string(v);
  if (v >= 0 && static_cast<std::size_t>(v) < mesh.file_node_ids.size())
    s += " (node id " + std::to_string(mesh.file_node_ids[v]) + ")";
  return s;
}

namespace {

bool finite(const Vec3d& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

bool indices_ok(const Tet& t, int nv) {
  for (int k = 0; k < 4; ++k) {
    if (t[k] < 0 || t[k] >= nv) return false;
    for (int j = 0; j < k; ++j)
      if (t[j] == t[k]) return false;
  }
  return true;
}

double longest_edge(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double l2 = std::max({squared_norm(b - a), squared_norm(c - a), squared_norm(d - a), squared_norm(c - b),
                              squared_norm(d - b), squared_norm(d - c)});
  return std::sqrt(l2);
}

/// -1 inverted, 0 degenerate, +1 fine (see kDegenerateVolume).
int volume_sign(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d, double* volume = nullptr) {
  const double v = signed_volume(a, b, c, d);
  if (volume) *volume = v;
  const double l = longest_edge(a, b, c, d);
  const double eps = kDegenerateVolume * l * l * l;
  if (!(std::fabs(v) > eps)) return 0;  // also NaN
  return v > 0 ? 1 : -1;
}

std::string tet_name(const TetMesh& mesh, int t) {
  std::string s = "tet " + std::to_string(t);
  if (static_cast<std::size_t>(t) < mesh.file_tet_ids.size()) s += " (element id " + std::to_string(mesh.file_tet_ids[t]) + ")";
  return s;
}

std::string plural(std::size_t n, const std::string& what) {
  if (n == 1) return "1 " + what;
  return std::to_string(n) + " " + (what == "vertex" ? std::string("vertices") : what + "s");
}

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

/// Pairs (later, earlier) of vertices within `tol` of each other; a uniform grid hash with cells of
/// size tol (or 1 when tol is 0, then only exact duplicates match), searched over 27 cells.
std::vector<std::pair<int, int>> find_duplicates(const std::vector<Vec3d>& p, double tol) {
  Vec3d lo{INFINITY, INFINITY, INFINITY};
  for (const auto& x : p)
    if (finite(x)) lo = cwise_min(lo, x);
  const double cell = tol > 0 && std::isfinite(tol) ? tol : 1.0;
  struct Key {
    long long i, j, k;
    bool operator==(const Key& o) const { return i == o.i && j == o.j && k == o.k; }
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      return static_cast<std::size_t>(static_cast<unsigned long long>(k.i) * 73856093ULL ^
                                      static_cast<unsigned long long>(k.j) * 19349663ULL ^
                                      static_cast<unsigned long long>(k.k) * 83492791ULL);
    }
  };
  std::unordered_map<Key, std::vector<int>, Hash> grid;
  std::vector<std::pair<int, int>> dups;
  for (std::size_t v = 0; v < p.size(); ++v) {
    if (!finite(p[v])) continue;
    const Vec3d r = (p[v] - lo) / cell;
    // cell index, clamped so that extreme coordinates (or an overflowing diagonal) stay defined
    auto index = [](double x) { return std::isfinite(x) ? static_cast<long long>(std::floor(std::clamp(x, -1e15, 1e15))) : 0LL; };
    const Key key{index(r.x), index(r.y), index(r.z)};
    int earliest = -1;
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          auto it = grid.find({key.i + di, key.j + dj, key.k + dk});
          if (it == grid.end()) continue;
          for (int u : it->second)
            if (norm(p[u] - p[v]) <= tol && (earliest < 0 || u < earliest)) earliest = u;
        }
    if (earliest >= 0) dups.emplace_back(static_cast<int>(v), earliest);
    grid[key].push_back(static_cast<int>(v));
  }
  return dups;
}

/// Pairs of tets (of non-zero volume) that share a face and lie on the same side of it: one
/// overlaps the other (a tet inside another, a fold of the mesh). Two tets on opposite sides of
/// their face see it in opposite orientations (kTetFaces, flipped for a tet of negative volume);
/// the same orientation puts them on one side. Combinatorial, so exact.
/// `tets` (the mesh's tets of valid indices, ids[i] the mesh's index of tets[i]) and their
/// sorted_tet_faces; sign_of by the mesh's index.
std::vector<std::array<int, 2>> overlapping_tets(const std::vector<Tet>& tets, const std::vector<int>& ids,
                                                 const std::vector<TetFace>& all, const std::vector<signed char>& sign_of) {
  // Each run of one face's tets (of non-zero volume; sorted_tet_faces orders them by tet).
  std::vector<std::array<int, 2>> out;
  std::array<int, 2> run_tet{}, run_odd{};
  for (std::size_t i = 0; i < all.size();) {
    int n = 0;
    std::size_t j = i;
    for (; j < all.size() && all[j].same_face(all[i]); ++j) {
      const int i_tet = all[j].tet_face / 4, f = all[j].tet_face % 4, t = ids[i_tet];
      if (sign_of[t] == 0) continue;
      if (n < 2) {
        const Tet& k = tets[i_tet];
        const int a = k[kTetFaces[f][0]], b = k[kTetFaces[f][1]], c = k[kTetFaces[f][2]];
        // the face's orientation as seen from its tet: an odd permutation of the sorted triple
        const bool odd = ((a > b) + (a > c) + (b > c)) % 2 == 1;
        run_tet[n] = t;
        run_odd[n] = odd != (sign_of[t] < 0);
      }
      ++n;
    }
    // three or more: nonmanifold_faces says so
    if (n == 2 && run_odd[0] == run_odd[1]) out.push_back({run_tet[0], run_tet[1]});
    i = j;
  }
  return out;
}

}  // namespace

double tet_mean_ratio(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double v = signed_volume(a, b, c, d);
  const double l2 = squared_norm(b - a) + squared_norm(c - a) + squared_norm(d - a) + squared_norm(c - b) +
                    squared_norm(d - b) + squared_norm(d - c);
  if (!(v > 0) || !(l2 > 0)) return 0.0;
  return std::min(1.0, 12.0 * std::cbrt(3.0 * v * 3.0 * v) / l2);
}

std::vector<int> mesh_parts(const TetMesh& mesh) {
  const int n = static_cast<int>(mesh.vertices.size());
  std::vector<int> root(n);
  for (int i = 0; i < n; ++i) root[i] = i;
  auto find = [&root](int a) {
    while (root[a] != a) a = root[a] = root[root[a]];
    return a;
  };
  for (const Tet& t : mesh.tets)
    for (int k = 1; k < 4; ++k) {
      const int a = find(t[0]), b = find(t[k]);
      if (a != b) root[std::max(a, b)] = std::min(a, b);  // the root is the part's lowest vertex
    }
  for (int i = 0; i < n; ++i) root[i] = find(i);
  return root;
}

namespace {

/// Whether embedding e lies strictly inside a tet: all four corners weigh more than a round-off
/// share (a vertex on a face or an edge of the other part, as along an unmerged seam, does not).
bool strictly_inside(const TetEmbedding& e) {
  constexpr double kInside = 1e-6;  // far above a face's round-off, far below a thin overlap's share
  return e.count == 4 && std::all_of(e.weight.begin(), e.weight.end(), [](double w) { return w > kInside; });
}

/// The parts' overlaps find_part_overlaps found (tet, tet of another part); {-1, -1}: none.
struct PartOverlaps {
  std::array<int, 2> centre{-1, -1};  ///< a tet whose centre lies inside the other: MeshReport::part_inside_part
  std::array<int, 2> vertex{-1, -1};  ///< only a vertex strictly inside: MeshReport::parts_overlap
};

/// MeshReport's joints: the tets' pieces (joined through shared faces; `tets` valid, `faces` their
/// sorted_tet_faces) and the vertices that tets of two pieces share.
void find_joints(const std::vector<Tet>& tets, const std::vector<TetFace>& faces, int nv, MeshReport& r) {
  const int nt = static_cast<int>(tets.size());
  std::vector<int> root(static_cast<std::size_t>(nt));
  for (int t = 0; t < nt; ++t) root[t] = t;
  auto find = [&root](int a) {
    while (root[a] != a) a = root[a] = root[root[a]];
    return a;
  };
  for (std::size_t i = 1; i < faces.size(); ++i)
    if (faces[i].same_face(faces[i - 1])) {
      const int a = find(faces[i].tet_face / 4), b = find(faces[i - 1].tet_face / 4);
      if (a != b) root[std::max(a, b)] = std::min(a, b);
    }
  std::vector<long long> size(static_cast<std::size_t>(nt), 0);
  for (int t = 0; t < nt; ++t) ++size[find(t)];
  // A vertex's pieces: the first seen, and whether another shares it (and the smallest there).
  std::vector<int> piece(static_cast<std::size_t>(nv), -1);
  std::vector<char> joint(static_cast<std::size_t>(nv), 0);
  std::vector<long long> smallest(static_cast<std::size_t>(nv), 0);
  for (int t = 0; t < nt; ++t)
    for (const int v : tets[t]) {
      const int p = find(t);
      if (piece[v] < 0) {
        piece[v] = p;
        smallest[v] = size[p];
      } else if (piece[v] != p) {
        joint[v] = 1;
        smallest[v] = std::min(smallest[v], size[p]);
      }
    }
  for (int v = 0; v < nv; ++v)
    if (joint[v] && r.joint_vertices++ == 0) {
      r.first_joint_vertex = v;
      r.joint_piece_tets = smallest[v];
    }
  if (r.joint_vertices == 0) return;
  // Pieces beyond one per connected part (tets sharing vertices).
  TetMesh m;
  m.vertices.resize(static_cast<std::size_t>(nv));
  m.tets = tets;
  const std::vector<int> part = mesh_parts(m);
  std::set<int> pieces, parts;
  for (int t = 0; t < nt; ++t) {
    pieces.insert(find(t));
    parts.insert(part[tets[t][0]]);
  }
  r.jointed_pieces = static_cast<long long>(pieces.size()) - static_cast<long long>(parts.size());
}

/// MeshReport::part_inside_part and parts_overlap: the centres of the tets of every part, and
/// their vertices, located in each other part whose bounding box holds them (a tumour inside its
/// organ, a box half inside another; two organs segmented apart that overlap by a voxel). A tet's
/// centre is inside its own tet, so parts that only touch (along an unmerged seam) have none inside
/// each other; a centre on an inner face of the other part is inside it still. A vertex counts only
/// strictly inside a tet (strictly_inside): a seam's vertices lie on the other part's faces. An
/// overlap that holds neither a centre nor a vertex of the other part (between its vertices) is not
/// found.
PartOverlaps find_part_overlaps(const TetMesh& mesh, double diagonal) {
  PartOverlaps found;
  const std::vector<int> part = mesh_parts(mesh);
  std::map<int, std::vector<int>> tets_of;  // part -> its tets
  for (int t = 0; t < static_cast<int>(mesh.tets.size()); ++t) tets_of[part[mesh.tets[t][0]]].push_back(t);
  if (tets_of.size() < 2) return found;
  const double tolerance = 1e-9 * diagonal;
  std::vector<char> of_a_tet(mesh.vertices.size(), 0);  // vertices a tet uses (the others are no part's)
  for (const Tet& t : mesh.tets)
    for (const int v : t) of_a_tet[v] = 1;
  std::vector<Vec3d> centre(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& k = mesh.tets[t];
    centre[t] = 0.25 * (mesh.vertices[k[0]] + mesh.vertices[k[1]] + mesh.vertices[k[2]] + mesh.vertices[k[3]]);
  }
  for (const auto& [container, tets] : tets_of) {
    Vec3d lo = centre[tets[0]], hi = lo;
    for (const int t : tets)
      for (const int v : mesh.tets[t]) {
        lo = cwise_min(lo, mesh.vertices[v]);
        hi = cwise_max(hi, mesh.vertices[v]);
      }
    const auto in_box = [&](const Vec3d& c) {
      return c.x >= lo.x && c.y >= lo.y && c.z >= lo.z && c.x <= hi.x && c.y <= hi.y && c.z <= hi.z;
    };
    std::vector<int> candidates;  // other parts' tets whose centre lies in this part's box
    for (int t = 0; t < static_cast<int>(mesh.tets.size()); ++t)
      if (part[mesh.tets[t][0]] != container && in_box(centre[t])) candidates.push_back(t);
    std::vector<int> points;  // other parts' vertices (of a tet) in this part's box
    if (found.vertex[0] < 0)
      for (int v = 0; v < static_cast<int>(mesh.vertices.size()); ++v)
        if (part[v] != container && of_a_tet[v] && in_box(mesh.vertices[v])) points.push_back(v);
    if (candidates.empty() && points.empty()) continue;
    TetMesh sub;
    sub.vertices = mesh.vertices;
    for (const int t : tets) sub.tets.push_back(mesh.tets[t]);
    const TetLocator locator(sub);
    for (const int t : candidates) {
      double error = 0;
      const TetEmbedding e = locator.locate(centre[t], error);
      if (e.count == 0 || error > tolerance) continue;
      for (const int c : tets) {  // a tet of the container with the embedding's corners
        const Tet& k = mesh.tets[c];
        if (std::all_of(e.vertex.begin(), e.vertex.begin() + e.count,
                        [&k](int v) { return std::find(k.begin(), k.end(), v) != k.end(); })) {
          found.centre = {t, c};
          return found;
        }
      }
    }
    for (const int v : points) {
      double error = 0;
      const TetEmbedding e = locator.locate(mesh.vertices[v], error);
      if (!strictly_inside(e) || error > tolerance) continue;
      const auto holds = [v](const Tet& k) { return std::find(k.begin(), k.end(), v) != k.end(); };
      const auto inner = std::find_if(mesh.tets.begin(), mesh.tets.end(), holds);
      const auto outer = std::find_if(tets.begin(), tets.end(), [&](int c) {
        return std::is_permutation(e.vertex.begin(), e.vertex.end(), mesh.tets[c].begin());
      });
      if (outer == tets.end()) continue;
      found.vertex = {static_cast<int>(inner - mesh.tets.begin()), *outer};
      break;
    }
  }
  return found;
}

}  // namespace

MeshReport validate_mesh(const TetMesh& mesh) {
  MeshReport r;
  const int nv = static_cast<int>(mesh.vertices.size());
  r.num_vertices = nv;
  r.num_tets = static_cast<int>(mesh.tets.size());

  for (int v = 0; v < nv; ++v)
    if (!finite(mesh.vertices[v])) r.nonfinite_vertices.push_back(v);
  if (mesh.file_tet_ids.size() == mesh.tets.size()) {
    std::vector<long long> ids(mesh.file_tet_ids.begin(), mesh.file_tet_ids.end());
    std::sort(ids.begin(), ids.end());
    for (std::size_t i = 1; i < ids.size(); ++i)
      if (ids[i] == ids[i - 1] && r.duplicate_tet_ids++ == 0) r.first_duplicate_tet_id = ids[i];  // the smallest
  }

  std::vector<char> used(static_cast<std::size_t>(nv), 0);
  std::vector<signed char> sign_of(mesh.tets.size(), 0);  // volume_sign of each tet checked (0: not)
  std::vector<Tet> valid;  // tets with valid indices, for the topology checks
  std::vector<int> valid_ids;  // their indices in the mesh
  valid.reserve(mesh.tets.size());
  valid_ids.reserve(mesh.tets.size());
  double quality_sum = 0.0;
  int quality_count = 0;
  r.quality_worst = 1.0;
  for (int t = 0; t < r.num_tets; ++t) {
    const Tet& tet = mesh.tets[t];
    if (!indices_ok(tet, nv)) {
      r.bad_index_tets.push_back(t);
      for (int v : tet)
        if (v >= 0 && v < nv) used[v] = 1;
      continue;
    }
    valid.push_back(tet);
    valid_ids.push_back(t);
    for (int v : tet) used[v] = 1;
    const Vec3d &a = mesh.vertices[tet[0]], &b = mesh.vertices[tet[1]], &c = mesh.vertices[tet[2]],
                &d = mesh.vertices[tet[3]];
    if (!finite(a) || !finite(b) || !finite(c) || !finite(d)) continue;
    const int sign = volume_sign(a, b, c, d);
    sign_of[t] = static_cast<signed char>(sign);
    if (sign == 0) r.degenerate_tets.push_back(t);
    if (sign < 0) r.inverted_tets.push_back(t);
    const double q = tet_mean_ratio(a, b, c, d);
    if (q < kPoorTetQuality) ++r.poor_tets;
    quality_sum += q;
    ++quality_count;
    if (q < r.quality_worst || r.worst_tet < 0) {
      r.quality_worst = q;
      r.worst_tet = t;
    }
  }
  if (quality_count > 0) {
    r.quality_mean = quality_sum / quality_count;
  } else {
    r.quality_worst = 0.0;
  }
  for (int v = 0; v < nv; ++v)
    if (!used[v]) r.unreferenced_vertices.push_back(v);

  // Duplicate positions, relative to the size of the mesh.
  Vec3d lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const auto& p : mesh.vertices)
    if (finite(p)) {
      lo = cwise_min(lo, p);
      hi = cwise_max(hi, p);
    }
  const double diag = nv > 0 && lo.x <= hi.x ? norm(hi - lo) : 0.0;
  r.duplicate_vertices = find_duplicates(mesh.vertices, 1e-12 * diag);
  if (r.bad_index_tets.empty() && r.nonfinite_vertices.empty()) {
    const PartOverlaps o = find_part_overlaps(mesh, diag);
    r.part_inside_part = o.centre;
    r.parts_overlap = o.vertex;
    if (o.vertex[0] >= 0) r.parts_overlap_names = tet_name(mesh, o.vertex[0]) + " reaches inside " + tet_name(mesh, o.vertex[1]);
  }
  auto vertex_name = [&](int v) {
    return static_cast<std::size_t>(v) < mesh.file_node_ids.size() ? "node " + std::to_string(mesh.file_node_ids[v])
                                                                    : "vertex " + std::to_string(v);
  };
  if (!r.duplicate_vertices.empty())
    r.duplicate_names = vertex_name(r.duplicate_vertices[0].first) + " duplicates " +
                        vertex_name(r.duplicate_vertices[0].second);
  if (r.worst_tet >= 0) r.worst_tet_name = tet_name(mesh, r.worst_tet);

  // The face checks below share one sort of the valid tets' faces.
  const std::vector<TetFace> faces = sorted_tet_faces(valid);
  r.overlapping_tets = overlapping_tets(valid, valid_ids, faces, sign_of);
  {
    std::vector<std::pair<Tet, int>> sorted;  // (the vertices sorted, the tet)
    sorted.reserve(mesh.tets.size());
    for (int t = 0; t < r.num_tets; ++t)
      if (indices_ok(mesh.tets[t], nv)) {
        Tet v = mesh.tets[t];
        std::sort(v.begin(), v.end());
        sorted.emplace_back(v, t);
      }
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 1; i < sorted.size(); ++i)
      if (sorted[i].first == sorted[i - 1].first) r.repeated_tets.push_back({sorted[i].second, sorted[i - 1].second});
    std::sort(r.repeated_tets.begin(), r.repeated_tets.end());
  }

  find_joints(valid, faces, nv, r);
  if (r.first_joint_vertex >= 0) r.joint_name = vertex_name(r.first_joint_vertex);
  // Faces and boundary edges.
  const std::vector<std::uint8_t> multiplicity = face_multiplicity(faces);
  const FaceCounts counts = count_faces(multiplicity);
  r.boundary_faces = counts.boundary;
  r.interior_faces = counts.interior;
  r.nonmanifold_faces = counts.nonmanifold;
  TetMesh valid_mesh;
  valid_mesh.vertices = mesh.vertices;
  valid_mesh.tets = std::move(valid);
  std::vector<int> to_volume;
  const SurfaceMesh surface = extract_boundary(valid_mesh, &to_volume, &multiplicity);
  std::vector<std::array<int, 2>> edges;
  edges.reserve(surface.triangles.size() * 3);
  for (const Tri& tri : surface.triangles)
    for (int k = 0; k < 3; ++k) {
      int a = to_volume[tri[k]], b = to_volume[tri[(k + 1) % 3]];
      edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2) r.nonmanifold_edges.push_back(edges[i]);
    i = j;
  }
  return r;
}

std::string MeshReport::fatal_message(const TetMesh& mesh) const {
  if (!bad_index_tets.empty()) {
    const int t = bad_index_tets[0];
    const Tet& tet = mesh.tets[t];
    return plural(bad_index_tets.size(), "tet") + " with an out-of-range or repeated vertex index, the first: " +
           tet_name(mesh, t) + " uses vertices " + std::to_string(tet[0]) + " " + std::to_string(tet[1]) + " " +
           std::to_string(tet[2]) + " " + std::to_string(tet[3]) + " of " + std::to_string(num_vertices);
  }
  if (!nonfinite_vertices.empty()) {
    const int v = nonfinite_vertices[0];
    return plural(nonfinite_vertices.size(), "vertex") + " with a non-finite coordinate, the first: " + vertex_name(mesh, v);
  }
  auto describe = [&](const std::vector<int>& tets, const char* what) {
    const int t = tets[0];
    const Tet& tet = mesh.tets[t];
    double v = 0.0;
    volume_sign(mesh.vertices[tet[0]], mesh.vertices[tet[1]], mesh.vertices[tet[2]], mesh.vertices[tet[3]], &v);
    const double l = longest_edge(mesh.vertices[tet[0]], mesh.vertices[tet[1]], mesh.vertices[tet[2]], mesh.vertices[tet[3]]);
    return std::to_string(tets.size()) + " " + what + (tets.size() == 1 ? " tet" : " tets") + ", the first: " +
           tet_name(mesh, t) + ", signed volume " + fmt(v) + " (longest edge " + fmt(l) + ")";
  };
  if (!inverted_tets.empty()) return describe(inverted_tets, "inverted");
  if (!degenerate_tets.empty()) return describe(degenerate_tets, "degenerate (flat)");
  if (!repeated_tets.empty())
    return plural(repeated_tets.size(), "tet") + " with the four vertices of another (in any order), the first: " +
           tet_name(mesh, repeated_tets[0][0]) + " repeats " + tet_name(mesh, repeated_tets[0][1]) +
           " (a part of the volume listed twice: in two entities, or a label meshed apart and appended?)";
  if (nonmanifold_faces > 0) return std::to_string(nonmanifold_faces) + " tet faces shared by three or more tets";
  if (!overlapping_tets.empty())
    return plural(overlapping_tets.size(), "pair") + " of tets on the same side of the face they share (one overlaps the " +
           "other: a tet inside another, or a fold), the first: " + tet_name(mesh, overlapping_tets[0][0]) + " and " +
           tet_name(mesh, overlapping_tets[0][1]);
  if (part_inside_part[0] >= 0) {
    return "two parts of the mesh overlap without sharing nodes: " + tet_name(mesh, part_inside_part[0]) +
           " reaches inside " + tet_name(mesh, part_inside_part[1]) +
           " of another part (a label meshed apart from its organ and appended? mesh them as one, with shared nodes, "
           "or leave one out: the overlap counts its volume and mass twice)";
  }
  if (num_tets == 0) return "no tets";
  return {};
}

std::vector<std::string> MeshReport::warnings() const {
  std::vector<std::string> w;
  if (!unreferenced_vertices.empty())
    w.push_back(plural(unreferenced_vertices.size(), "vertex") + " used by no tet, the first: vertex " +
                std::to_string(unreferenced_vertices[0]));
  // Duplicates that tets use on both sides leave the body cut along them (an unmerged seam): its
  // boundary then has non-manifold edges where the cut meets the surface.
  const bool seam = !duplicate_vertices.empty() && !nonmanifold_edges.empty();
  if (!duplicate_vertices.empty())
    w.push_back(plural(duplicate_vertices.size(), "vertex") + " at the position of another, the first: " +
                duplicate_names +
                (seam ? std::string(": the body is cut there (an unmerged seam: its sides move apart, and the cut's "
                                    "faces become surface inside it); merge them (Gmsh: Coherence Mesh;)")
                      : std::string()));
  if (!nonmanifold_edges.empty())
    w.push_back(plural(nonmanifold_edges.size(), "non-manifold boundary edge") +
                " (not in exactly 2 boundary faces), the first: vertices " + std::to_string(nonmanifold_edges[0][0]) +
                "-" + std::to_string(nonmanifold_edges[0][1]));
  if (duplicate_tet_ids > 0)
    w.push_back(plural(static_cast<std::size_t>(duplicate_tet_ids), "tet") +
                " with an element id another tet has too, the first: element id " +
                std::to_string(first_duplicate_tet_id) +
                " (a file's element ids are unique: two files joined? the ids messages name are ambiguous)");
  if (parts_overlap[0] >= 0 && part_inside_part[0] < 0)
    w.push_back("two parts of the mesh overlap slightly without sharing nodes: " + parts_overlap_names +
                " of another part (organs segmented apart that overlap by a voxel?): the overlap's volume and mass "
                "count twice, and each part's surface lies inside the other there; mesh them as one, with shared "
                "nodes, or shrink one");
  if (jointed_pieces > 0)
    w.push_back(plural(static_cast<std::size_t>(jointed_pieces), "piece") +
                (jointed_pieces == 1 ? " of the mesh touches" : " of the mesh touch") +
                " the rest at vertices or edges only, sharing no face (" +
                plural(static_cast<std::size_t>(joint_vertices), "vertex") + " shared; the first: " + joint_name +
                ", where the smaller piece has " + plural(static_cast<std::size_t>(joint_piece_tets), "tet") +
                "): unless pinned itself, such a piece turns about its joint, held only by its coupling to the virtual "
                "mesh (two labels of a segmentation touching at a corner?); mesh them as one volume, with shared "
                "faces, or apart");
  if (poor_tets > 0) {
    char line[320];
    std::snprintf(line, sizeof line,
                  " of mean ratio below %g, the worst %.3g (%s): near-flat tets stall the physical solver's "
                  "iterations or stop the replay (`ebh scene info` shows the mesh's quality and the solver's rate); "
                  "remesh them",
                  kPoorTetQuality, quality_worst, worst_tet_name.c_str());
    w.push_back(plural(static_cast<std::size_t>(poor_tets), "tet") + line);
  }
  return w;
}

Orientation orient_tets(TetMesh& mesh) {
  Orientation o;
  const int nv = static_cast<int>(mesh.vertices.size());
  for (int t = 0; t < static_cast<int>(mesh.tets.size()); ++t) {
    Tet& tet = mesh.tets[t];
    if (!indices_ok(tet, nv)) continue;
    const int sign = volume_sign(mesh.vertices[tet[0]], mesh.vertices[tet[1]], mesh.vertices[tet[2]], mesh.vertices[tet[3]]);
    if (sign > 0) {
      ++o.positive;
    } else if (sign < 0) {
      if (o.negative++ == 0) o.witness = t;
      std::swap(tet[1], tet[2]);
    }
  }
  if (o.negative > 0) o.kind = o.positive > 0 ? Orientation::Kind::Mixed : Orientation::Kind::Flipped;
  return o;
}

std::string orientation_warning(const Orientation& o, const TetMesh& mesh) {
  switch (o.kind) {
    case Orientation::Kind::Positive:
      return {};
    case Orientation::Kind::Flipped:
      return "all tets were negatively oriented; flipped them";
    case Orientation::Kind::Mixed:
      break;
  }
  return std::to_string(o.negative) + " of " + std::to_string(o.positive + o.negative) +
         " tets were negatively oriented (their vertex order differs from the others'), the first: " +
         tet_name(mesh, o.witness) + "; flipped them one by one";
}

int remove_unused_surface_vertices(SurfaceMesh& mesh) {
  const int nv = static_cast<int>(mesh.vertices.size());
  std::vector<int> remap(static_cast<std::size_t>(nv), -1);
  for (const Tri& tri : mesh.triangles)
    for (int v : tri) remap[v] = 0;
  int next = 0;
  for (int v = 0; v < nv; ++v)
    if (remap[v] == 0) {
      mesh.vertices[next] = mesh.vertices[v];
      remap[v] = next++;
    }
  if (next == nv) return 0;
  mesh.vertices.resize(next);
  for (Tri& tri : mesh.triangles)
    for (int& v : tri) v = remap[v];
  return nv - next;
}

MergedVertices merge_coincident_surface_vertices(SurfaceMesh& mesh, double within) {
  const int nv = static_cast<int>(mesh.vertices.size());
  std::vector<int> order(static_cast<std::size_t>(nv));
  for (int v = 0; v < nv; ++v) order[v] = v;
  auto key = [&](int v) { return std::tuple(mesh.vertices[v].x, mesh.vertices[v].y, mesh.vertices[v].z); };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  std::vector<int> first(static_cast<std::size_t>(nv));
  for (int v = 0; v < nv; ++v) first[v] = v;
  MergedVertices merged;
  for (int i = 1; i < nv; ++i)
    if (key(order[i]) == key(order[i - 1])) {
      first[order[i]] = first[order[i - 1]];  // stable: the lowest index of the position
      ++merged.vertices;
    }
  // Within reach: the kept vertices (in index order) hashed into cells of the reach's size; a
  // vertex looks through the 27 cells around its own for the lowest-numbered one within reach.
  if (within > 0) {
    const auto cell = [within](const Vec3d& p) {
      return std::array<long long, 3>{static_cast<long long>(std::floor(p.x / within)),
                                      static_cast<long long>(std::floor(p.y / within)),
                                      static_cast<long long>(std::floor(p.z / within))};
    };
    std::map<std::array<long long, 3>, std::vector<int>> kept;
    std::vector<int> near_into(static_cast<std::size_t>(nv), -1);
    for (int v = 0; v < nv; ++v) {
      if (first[v] != v) continue;
      const Vec3d& p = mesh.vertices[v];
      const std::array<long long, 3> c = cell(p);
      int into = -1;
      for (long long dx = -1; dx <= 1; ++dx)
        for (long long dy = -1; dy <= 1; ++dy)
          for (long long dz = -1; dz <= 1; ++dz)
            if (const auto it = kept.find({c[0] + dx, c[1] + dy, c[2] + dz}); it != kept.end())
              for (const int k : it->second)
                if (norm(mesh.vertices[k] - p) <= within && (into < 0 || k < into)) into = k;
      if (into < 0) {
        kept[c].push_back(v);
        continue;
      }
      near_into[v] = into;
      ++merged.vertices;
      ++merged.near;
    }
    for (int w = 0; w < nv; ++w)  // v and the vertices merged into it exactly; `into` is kept
      if (near_into[first[w]] >= 0) first[w] = near_into[first[w]];
  }
  if (merged.vertices == 0) return merged;
  std::vector<int> remap(static_cast<std::size_t>(nv), -1);
  int next = 0;
  for (int v = 0; v < nv; ++v)
    if (first[v] == v) {
      mesh.vertices[next] = mesh.vertices[v];
      remap[v] = next++;
    }
  mesh.vertices.resize(next);
  std::size_t kept = 0;
  for (const Tri& t : mesh.triangles) {
    const Tri r{remap[first[t[0]]], remap[first[t[1]]], remap[first[t[2]]]};
    if (r[0] == r[1] || r[1] == r[2] || r[2] == r[0]) {
      ++merged.faces;
      continue;
    }
    mesh.triangles[kept++] = r;
  }
  mesh.triangles.resize(kept);
  return merged;
}

int remove_repeated_surface_faces(SurfaceMesh& mesh) {
  std::set<std::array<int, 3>> seen;
  std::size_t kept = 0;
  for (const Tri& t : mesh.triangles) {
    std::array<int, 3> key{t[0], t[1], t[2]};
    std::sort(key.begin(), key.end());
    if (seen.insert(key).second) mesh.triangles[kept++] = t;
  }
  const int removed = static_cast<int>(mesh.triangles.size() - kept);
  mesh.triangles.resize(kept);
  return removed;
}

int remove_flat_surface_faces(SurfaceMesh& mesh) {
  std::vector<Tri> kept;
  kept.reserve(mesh.triangles.size());
  for (const Tri& t : mesh.triangles) {
    const Vec3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const double longest = std::max({squared_norm(b - a), squared_norm(c - b), squared_norm(a - c)});
    if (norm(cross(b - a, c - a)) > 1e-12 * longest) kept.push_back(t);
  }
  const int removed = static_cast<int>(mesh.triangles.size() - kept.size());
  // A flat face that fills a T-junction (a long edge against two short ones) closes the surface
  // there: without it the surface would open. Such faces stay.
  if (removed == 0 || surface_edges(kept).open > surface_edges(mesh.triangles).open) return 0;
  mesh.triangles = std::move(kept);
  return removed;
}

int remove_unreferenced_vertices(TetMesh& mesh) {
  const int nv = static_cast<int>(mesh.vertices.size());
  std::vector<int> remap(static_cast<std::size_t>(nv), -1);
  for (const Tet& tet : mesh.tets)
    for (int v : tet)
      if (v >= 0 && v < nv) remap[v] = 0;
  int next = 0;
  for (int v = 0; v < nv; ++v)
    if (remap[v] == 0) {
      mesh.vertices[next] = mesh.vertices[v];
      if (static_cast<std::size_t>(v) < mesh.file_node_ids.size()) mesh.file_node_ids[next] = mesh.file_node_ids[v];
      remap[v] = next++;
    }
  const int removed = nv - next;
  if (removed == 0) return 0;
  mesh.vertices.resize(next);
  if (mesh.file_node_ids.size() == static_cast<std::size_t>(nv)) mesh.file_node_ids.resize(next);
  for (Tet& tet : mesh.tets)
    for (int& v : tet)
      if (v >= 0 && v < nv) v = remap[v];
  std::size_t kept = 0;
  std::vector<int> new_index(mesh.triangles.size(), -1);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    Tri tri = mesh.triangles[f];
    bool ok = true;
    for (int& v : tri) {
      if (v < 0 || v >= nv || remap[v] < 0) ok = false;
      else v = remap[v];
    }
    if (!ok) continue;
    mesh.triangles[kept] = tri;
    if (f < mesh.triangle_group.size()) mesh.triangle_group[kept] = mesh.triangle_group[f];
    new_index[f] = static_cast<int>(kept);
    ++kept;
  }
  mesh.triangles.resize(kept);
  if (mesh.triangle_group.size() > kept) mesh.triangle_group.resize(kept);
  std::size_t kept_more = 0;
  for (const auto& [f, tag] : mesh.triangle_more_groups)
    if (f >= 0 && static_cast<std::size_t>(f) < new_index.size() && new_index[f] >= 0)
      mesh.triangle_more_groups[kept_more++] = {new_index[f], tag};
  mesh.triangle_more_groups.resize(kept_more);
  return removed;
}

int count_inverted_tets(std::span<const Vec3d> x, std::span<const Tet> tets, std::span<const signed char> rest_sign) {
  int inverted = 0;
  for (std::size_t t = 0; t < tets.size(); ++t) {
    const Tet& k = tets[t];
    inverted += inverted_or_flat(x[k[0]], x[k[1]], x[k[2]], x[k[3]], rest_sign[t]);
  }
  return inverted;
}

std::vector<signed char> rest_signs(std::span<const Vec3d> rest, std::span<const Tet> tets) {
  std::vector<signed char> sign(tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t) {
    const Tet& k = tets[t];
    sign[t] = signed_volume(rest[k[0]], rest[k[1]], rest[k[2]], rest[k[3]]) < 0 ? -1 : 1;
  }
  return sign;
}

}  // namespace ebh
