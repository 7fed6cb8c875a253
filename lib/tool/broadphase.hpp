#pragma once
// Broad phase for vertex-tool collision: a uniform grid over the virtual-mesh vertices'
// reference positions q_ref, rebuilt when the physical step delivers new positions (or when the
// bound below is exceeded), so a tick's query costs the cells and vertices near the tool, not the
// whole mesh.
//
// Invariant (what makes it exact): every vertex i satisfies |q_i - q_ref_i| <= margin. Then a
// vertex inside a collider C has q_ref_i within `margin` of C, and a query for C inflated by
// `margin` returns it: the candidates are a superset of the vertices in contact.
// Enforcement: the caller reports how far vertices may have moved since the rebuild
// (note_motion, e.g. the virtual-mesh solver's largest per-iteration update); once the
// accumulated bound passes the margin the grid counts itself stale and detect_contacts rebuilds it
// (a counted fallback, O(m)). Every query also checks the invariant on the candidates it touches
// and flags a violation (violated()); with set_check_all(true) (tests, debug runs) each query
// checks all m vertices, O(m).
#include <cstdint>
#include <span>
#include <vector>

#include "math/vec.hpp"

namespace ebh {

class VertexGrid {
 public:
  /// Bins q_ref (#m positions, metres). `margin` (metres) is the displacement the grid tolerates.
  /// The cell size is max(margin / 2, mean vertex spacing); allocation happens only when m or the
  /// cell count grows.
  void rebuild(std::span<const Vec3d> q_ref, double margin);

  /// Accumulates a bound on how far any vertex moved since the last rebuild.
  void note_motion(double max_vertex_displacement) { moved_ += max_vertex_displacement; }
  /// True when never built, built for another vertex count, or the motion bound passed the margin.
  bool stale(std::size_t m) const { return q_ref_.size() != m || m == 0 || moved_ > margin_ || violated_; }

  /// Calls visit(i) once for every vertex i whose reference cell intersects the box
  /// [lo - margin - extra, hi + margin + extra] and for which keep_cell(centre, half_diagonal +
  /// margin + extra)
  /// is true (a conservative per-cell test). Vertices may repeat across calls; the caller dedupes.
  /// `q` (#m current positions) is used to check the invariant on visited vertices.
  /// `pass` (from next_pass(), 0: none): calls of one pass skip the cells an earlier call of it
  /// walked, so the overlapping boxes that cover one collider (cover_collider) test each cell and
  /// visit its vertices once; every call of a pass must use the same keep_cell and extra.
  template <class CellTest, class Visit>
  void query(Vec3d lo, Vec3d hi, double extra, std::span<const Vec3d> q, CellTest&& keep_cell, Visit&& visit,
             std::uint32_t pass = 0) const;

  /// max_i |q_i - q_ref_i|, O(m): the invariant check.
  double max_displacement(std::span<const Vec3d> q) const;

  double margin() const { return margin_; }
  double cell_size() const { return cell_; }
  bool violated() const { return violated_; }
  void set_check_all(bool on) { check_all_ = on; }
  int rebuilds() const { return rebuilds_; }
  /// Per-vertex stamps for de-duplication by callers (#m, zero after rebuild).
  std::vector<std::uint32_t>& stamps() const { return stamps_; }
  /// Per-vertex scratch for callers (#m, any values: meaningful only where the caller wrote it
  /// under its current stamp).
  std::vector<int>& slots() const { return slots_; }
  std::uint32_t next_stamp() const { return ++stamp_; }
  /// A new pass for query (never 0).
  std::uint32_t next_pass() const { return ++pass_; }

 private:
  std::vector<Vec3d> q_ref_;       // #m reference positions
  std::vector<int> cell_start_;    // #cells + 1, offsets into cell_vertex_
  std::vector<int> cell_vertex_;   // #m vertex indices sorted by cell
  std::vector<int> vertex_cell_;   // #m scratch of rebuild
  mutable std::vector<std::uint32_t> stamps_;  // #m
  mutable std::vector<int> slots_;             // #m
  mutable std::uint32_t stamp_ = 0;
  mutable std::vector<std::uint32_t> cell_pass_;  // #cells the last pass that walked each cell
  mutable std::uint32_t pass_ = 0;                // passes only grow: a cell's entry is never a future pass
  mutable bool violated_ = false;
  Vec3d origin_{};
  int dims_[3] = {0, 0, 0};
  double cell_ = 1.0, margin_ = 0.005, moved_ = 0.0;  // margin default: 5 mm
  bool check_all_ = false;
  int rebuilds_ = 0;
};

template <class CellTest, class Visit>
void VertexGrid::query(Vec3d lo, Vec3d hi, double extra, std::span<const Vec3d> q, CellTest&& keep_cell,
                       Visit&& visit, std::uint32_t pass) const {
  if (check_all_ && max_displacement(q) > margin_) violated_ = true;
  const double grow = margin_ + extra;
  int c0[3], c1[3];
  for (int k = 0; k < 3; ++k) {
    const double a = (lo[k] - grow - origin_[k]) / cell_, b = (hi[k] + grow - origin_[k]) / cell_;
    if (b < 0.0 || a >= dims_[k]) return;  // the box misses the grid
    c0[k] = a < 0.0 ? 0 : static_cast<int>(a);
    c1[k] = b >= dims_[k] ? dims_[k] - 1 : static_cast<int>(b);
  }
  const double half_diag = 0.5 * cell_ * 1.7320508075688772;
  for (int z = c0[2]; z <= c1[2]; ++z)
    for (int y = c0[1]; y <= c1[1]; ++y)
      for (int x = c0[0]; x <= c1[0]; ++x) {
        const int cell = (z * dims_[1] + y) * dims_[0] + x;
        if (cell_start_[cell] == cell_start_[cell + 1]) continue;
        if (pass != 0) {
          if (cell_pass_[cell] == pass) continue;  // walked by an earlier box of this pass
          cell_pass_[cell] = pass;
        }
        const Vec3d centre = origin_ + Vec3d{(x + 0.5) * cell_, (y + 0.5) * cell_, (z + 0.5) * cell_};
        if (!keep_cell(centre, half_diag + grow)) continue;
        for (int j = cell_start_[cell]; j < cell_start_[cell + 1]; ++j) {
          const int i = cell_vertex_[j];
          if (squared_norm(q[i] - q_ref_[i]) > margin_ * margin_) violated_ = true;
          visit(i);
        }
      }
}

}  // namespace ebh
