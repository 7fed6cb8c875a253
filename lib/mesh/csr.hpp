#pragma once
// Compressed sparse rows built from (row, item) pairs: the incidence lists the solvers gather over.
#include <vector>

namespace ebh {

/// Builds a CSR list rows -> items from (row, item) pairs given in item order (stable: each row's
/// items keep increasing item order, which fixes the order of every gather over them).
///   row_of_each(i, emit): calls emit(row) for every row item i belongs to
///   offsets: #rows+1; entries: the items of row r are entries[offsets[r] .. offsets[r+1])
template <class RowOf>
void build_csr(int rows, int items, RowOf&& row_of_each, std::vector<int>& offsets, std::vector<int>& entries) {
  offsets.assign(rows + 1, 0);
  for (int i = 0; i < items; ++i) row_of_each(i, [&](int row) { ++offsets[row + 1]; });
  for (int r = 0; r < rows; ++r) offsets[r + 1] += offsets[r];
  entries.assign(offsets[rows], 0);
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (int i = 0; i < items; ++i) row_of_each(i, [&](int row) { entries[fill[row]++] = i; });
}

}  // namespace ebh
