#!/usr/bin/env bash
# A run's output deleted after the summary was written: no file is newer than the summary, yet the
# report does not count the run as ok. It says which run and why in one line and collects the
# summary again (the run is then not run yet), and a resumed sweep runs exactly that run. Where the
# summary cannot be written again (here summary.h5 is a folder), the report lists the run as not
# run yet, with why, and warns.
#   tests/sweep/report_outdated.sh EBH_BIN WORK_DIR
set -euo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
cp "$(dirname "$0")/../data/sweep/tube_one_run.yaml" "$work/plan.yaml"  # the reference and solver.virtual_iterations=2
dir=$work/s
"$ebh" sweep "$work/plan.yaml" -o "$dir" >/dev/null 2>"$work/sweep.err" || fail "sweep: $(tail -1 "$work/sweep.err")"
# The id and status of the run that is not the reference (no quoted fields in these rows).
row() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "id") d = i; if ($i == "status") s = i; if ($i == "reference") r = i }
                     next }
           $r == "0" { print $d " " $s }' "$1"
}
victim=$(row "$dir/summary.csv" | cut -d' ' -f1)
[ "$(row "$dir/summary.csv")" = "$victim ok" ] || fail "after the sweep: $(row "$dir/summary.csv")"

rm "$dir/runs/$victim.h5"
"$ebh" sweep report "$dir" >"$work/report.md" 2>"$work/report.err" || fail "report: $(cat "$work/report.err")"
grep -q "^$dir/summary.csv: out of date: it lists .*solver.virtual_iterations=2 ($victim) as ok, but to run again: its output $dir/runs/$victim.h5 is not there (deleted since the summary was written)$" \
  "$work/report.err" || fail "no line naming the run and why: $(cat "$work/report.err")"
grep -q '| solver.virtual_iterations=2 |' "$work/report.md" && fail "the run without its output is in the table: $(cat "$work/report.md")"
grep -q '^1 run not run yet$' "$work/report.md" || fail "the run is not said to be not run yet: $(cat "$work/report.md")"
[ "$(row "$dir/summary.csv")" = "$victim pending" ] || fail "summary.csv not collected again: $(row "$dir/summary.csv")"

# Resumed, the sweep runs exactly that run.
"$ebh" sweep "$work/plan.yaml" -o "$dir" >/dev/null 2>"$work/resume.err" || fail "resume: $(tail -1 "$work/resume.err")"
grep -q '^ebh sweep: 2 runs, 1 already done' "$work/resume.err" || fail "resume: $(head -1 "$work/resume.err")"
[ "$(grep -c '^\[[0-9]*/[0-9]*\] done in ' "$work/resume.err")" = 1 ] && grep -q "done in .*($victim)\$" "$work/resume.err" ||
  fail "resume did not run exactly $victim: $(cat "$work/resume.err")"
[ "$(row "$dir/summary.csv")" = "$victim ok" ] || fail "after resuming: $(row "$dir/summary.csv")"

# The summary cannot be written again: the report lists the run as not run yet all the same.
rm "$dir/runs/$victim.h5"
rm "$dir/summary.h5"
mkdir -p "$dir/summary.h5/in_the_way"
"$ebh" sweep report "$dir" >"$work/stuck.md" 2>"$work/stuck.err" || fail "report, summary not writable: $(cat "$work/stuck.err")"
grep -q "^ebh: warning: $dir: cannot collect the runs again (.*); reporting summary.csv as it is, except 1 run it lists as ok: not run yet (its output is to run again)$" \
  "$work/stuck.err" || fail "no warning: $(cat "$work/stuck.err")"
grep -q '| solver.virtual_iterations=2 |' "$work/stuck.md" && fail "the run without its output is in the table: $(cat "$work/stuck.md")"
grep -q "^not run yet: $victim solver.virtual_iterations=2: to run again: its output $dir/runs/$victim.h5 is not there (deleted since the summary was written)$" \
  "$work/stuck.md" || fail "the run is not listed as not run yet, with why: $(cat "$work/stuck.md")"
echo "report outdated: ok"
