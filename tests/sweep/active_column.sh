#!/usr/bin/env bash
# summary.csv's active_vertices_mean and awake_vertices_mean: the means of a run's /haptic/active
# under solver.active_region and /physical/awake under solver.physical_region, empty for a run
# without the keys (here the reference).
#   tests/sweep/active_column.sh EBH_BIN WORK_DIR
set -euo pipefail
ebh=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
cat >"$work/plan.yaml" <<'PLAN'
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {}}
grid:
  solver.active_region: [0.01]
  solver.physical_region: [0.01]
start: 2.8
duration: 0.05
PLAN
"$ebh" sweep "$work/plan.yaml" -o "$work/s" >/dev/null 2>"$work/err" || { echo "FAIL: $(tail -1 "$work/err")"; exit 1; }
# reference flag, active_vertices_mean and awake_vertices_mean of each row (no quoted fields in these rows)
awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "reference") r = i; if ($i == "active_vertices_mean") a = i;
                                               if ($i == "awake_vertices_mean") w = i }; next }
         { print $r " " $a " " $w }' "$work/s/summary.csv" >"$work/rows.txt"
grep -qx '1  ' "$work/rows.txt" || { echo "FAIL: the reference (no region) has a value: $(cat "$work/rows.txt")"; exit 1; }
grep -qE '^0 [1-9][0-9]*(\.[0-9]+)? [1-9][0-9]*(\.[0-9]+)?$' "$work/rows.txt" ||
  { echo "FAIL: the regions' run has no means: $(cat "$work/rows.txt")"; exit 1; }
echo "active column: ok"
