#!/usr/bin/env bash
# ebh sweep resumes: a finished run is never run again, a deleted or cut output is run again, and so is
# one replayed by hand with a --transform or --haptic-hz (not the run's replay), and a sweep
# stopped with SIGTERM leaves no half-written file and, rerun, runs exactly the runs it did not
# finish. The summary's error of a run identical to the reference is 0.
#   tests/sweep/resume.sh EBH_BIN WORK_DIR
set -euo pipefail
ebh=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }

# 4 runs: the reference (virtual iterations 8, repetition 0), its second repetition (the same
# replay, so the same forces), and 1 virtual iteration twice.
cat >"$work/plan.yaml" <<'EOF'
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {solver.virtual_iterations: 8}}
grid:
  solver.virtual_iterations: [8, 1]
repetitions: 2
start: 4
duration: DURATION
EOF
sed -i 's/DURATION/0.3/' "$work/plan.yaml"

# A column of summary.csv (no quoted fields in the rows read here), by header name.
column() {  # column FILE NAME -> one value per row
  awk -F, -v name="$2" 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == name) c = i; next } { print $c }' "$1"
}
ids_done() { ls "$1/runs" | sed -n 's/\.h5$//p' | sort; }
ran_ids() { sed -n 's/^\[[0-9]*\/[0-9]*\] done in .*(\([0-9a-f]*\))$/\1/p' "$1" | sort; }

# 1. A whole sweep.
"$ebh" sweep "$work/plan.yaml" -o "$work/a" --jobs 2 >"$work/a.out" 2>"$work/a.err" || fail "first sweep: $(tail -1 "$work/a.err")"
[ "$(ids_done "$work/a" | wc -l)" = 4 ] || fail "expected 4 outputs, got: $(ids_done "$work/a")"
[ "$(column "$work/a/summary.csv" status | sort -u)" = ok ] || fail "not every run ok: $(column "$work/a/summary.csv" status)"
[ -s "$work/a/summary.h5" ] || fail "no summary.h5 beside summary.csv"
# The reference (reference = 1) and its repetition have error 0; 1 virtual iteration does not.
paste -d' ' <(column "$work/a/summary.csv" reference) <(column "$work/a/summary.csv" repetition) \
  <(column "$work/a/summary.csv" set.solver.virtual_iterations) <(column "$work/a/summary.csv" force_error_rms_N) \
  <(column "$work/a/summary.csv" force_error_max_N) >"$work/errors.txt"
grep -qx '1 0 8 0 0' "$work/errors.txt" || fail "reference row: $(cat "$work/errors.txt")"
grep -qx '0 1 8 0 0' "$work/errors.txt" || fail "the reference's repetition has an error: $(cat "$work/errors.txt")"
[ "$(grep -c '^0 [01] 1 0\.0*[1-9]' "$work/errors.txt")" = 2 ] || fail "1 virtual iteration shows no error: $(cat "$work/errors.txt")"

# 2. Rerun: nothing to do. Delete one output: only that one runs.
"$ebh" sweep "$work/plan.yaml" -o "$work/a" 2>"$work/b.err" >/dev/null || fail "rerun: $(tail -1 "$work/b.err")"
grep -q '^ebh sweep: 4 runs, 4 already done' "$work/b.err" || fail "rerun did not skip: $(cat "$work/b.err")"
[ -z "$(ran_ids "$work/b.err")" ] || fail "rerun ran $(ran_ids "$work/b.err")"
victim=$(ids_done "$work/a" | sed -n 2p)
rm "$work/a/runs/$victim.h5"
"$ebh" sweep "$work/plan.yaml" -o "$work/a" 2>"$work/c.err" >/dev/null || fail "resume: $(tail -1 "$work/c.err")"
[ "$(ran_ids "$work/c.err")" = "$victim" ] || fail "expected only $victim to run, ran: $(ran_ids "$work/c.err")"

# A replay of the reference's window, mode, backend and overrides made by hand with a pose transform
# or another haptic rate (options a sweep never gives), copied under its name, is not the run's
# replay (its forces are another pose's, another rate's): it runs again.
ref=$(paste -d' ' <(column "$work/a/summary.csv" id) <(column "$work/a/summary.csv" reference) | sed -n 's/ 1$//p')
[ -n "$ref" ] || fail "no reference row in summary.csv"
for option in "--transform 0,0,5,0,0,0" "--haptic-hz 2000"; do
  # shellcheck disable=SC2086  # the option and its value, two words
  "$ebh" replay tube tube_insert -o "$work/hand.h5" --backend cpu --mode async --quiet --start 4 --duration 0.3 \
    --set solver.virtual_iterations=8 $option 2>"$work/hand.err" || fail "replay $option: $(tail -1 "$work/hand.err")"
  mv "$work/hand.h5" "$work/a/runs/$ref.h5"
  "$ebh" sweep "$work/plan.yaml" -o "$work/a" 2>"$work/h.err" >/dev/null || fail "$option: $(tail -1 "$work/h.err")"
  grep -q "^ebh sweep: 4 runs, 3 already done, 1 whose output is not the run's replay" "$work/h.err" \
    || fail "a replay made with $option taken as done: $(head -1 "$work/h.err")"
  [ "$(ran_ids "$work/h.err")" = "$ref" ] || fail "$option: expected $ref to run again, ran: $(ran_ids "$work/h.err")"
done

# An output cut short (a copy, a full disk) runs again; another program's file under a run's name
# stays, and the sweep then fails: that run has no result.
victim=$(ids_done "$work/a" | sed -n 3p)
head -c 3000 "$work/a/runs/$victim.h5" >"$work/cut.h5" && mv "$work/cut.h5" "$work/a/runs/$victim.h5"
"$ebh" sweep "$work/plan.yaml" -o "$work/a" 2>"$work/d.err" >/dev/null || fail "cut short: $(tail -1 "$work/d.err")"
grep -q '^ebh sweep: 4 runs, 3 already done, 1 whose output does not open (run again)' "$work/d.err" \
  || fail "the cut output: $(head -1 "$work/d.err")"
[ "$(ran_ids "$work/d.err")" = "$victim" ] || fail "expected $victim to run again, ran: $(ran_ids "$work/d.err")"
echo "not HDF5" >"$work/a/runs/$victim.h5"
if "$ebh" sweep "$work/plan.yaml" -o "$work/a" 2>"$work/e.err" >/dev/null; then fail "a run without a result passed"; fi
grep -q '^ebh: error: 1 of 4 runs have no result in .*summary.csv' "$work/e.err" || fail "no result: $(tail -1 "$work/e.err")"
rm "$work/a/runs/$victim.h5"

# 3. SIGTERM mid-way (runs of 1.5 s, one at a time), then resume.
sed -i 's/duration: 0.3/duration: 1.5/' "$work/plan.yaml"
"$ebh" sweep "$work/plan.yaml" -o "$work/k" --jobs 1 >/dev/null 2>"$work/k.err" &
pid=$!
for _ in $(seq 600); do  # at most 60 s for the first run to finish
  grep -q '^\[1/4\] done' "$work/k.err" && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.1
done
grep -q '^\[1/4\] done' "$work/k.err" || { kill $pid 2>/dev/null; fail "no run finished in 60 s: $(cat "$work/k.err")"; }
kill -TERM $pid
status=0
wait $pid || status=$?
[ $status != 0 ] || fail "the interrupted sweep exited 0"
grep -q 'interrupted: .*rerun the same command to go on' "$work/k.err" || fail "no interrupt message: $(cat "$work/k.err")"
partial=$(find "$work/k" -name '*.ebh-partial')
[ -z "$partial" ] || fail "temporaries left: $partial"
[ ! -e "$work/k/summary.csv" ] || fail "an interrupted sweep wrote a summary"
ls "$work/k/runs" | grep -q '\.failed$' && fail "a stopped run was recorded as failed"
before=$(ids_done "$work/k")
n=$(echo "$before" | wc -l)
[ "$n" -ge 1 ] && [ "$n" -lt 4 ] || fail "expected 1-3 finished runs after the interrupt, got $n"
"$ebh" sweep "$work/plan.yaml" -o "$work/k" 2>"$work/r.err" >/dev/null || fail "resume after SIGTERM: $(tail -1 "$work/r.err")"
grep -q "^ebh sweep: 4 runs, $n already done" "$work/r.err" || fail "resume: $(head -1 "$work/r.err")"
ran=$(ran_ids "$work/r.err")
[ "$(echo "$ran" | wc -l)" = $((4 - n)) ] || fail "resume ran $(echo $ran), expected $((4 - n)) runs"
[ -z "$(comm -12 <(echo "$before") <(echo "$ran"))" ] || fail "a finished run ran again"
[ "$(column "$work/k/summary.csv" status | sort -u)" = ok ] || fail "after resuming, not every run ok"
# 4. A run that fails (a pinned group the mesh lacks) is recorded with its error line; the
# others go on; the sweep's exit status says so.
cat >"$work/fails.yaml" <<'EOF'
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {}}
runs:
  - {pinned: [{group: no_such_group}]}
  - {solver.virtual_iterations: 2}
start: 4
duration: 0.1
EOF
status=0
"$ebh" sweep "$work/fails.yaml" -o "$work/f" >/dev/null 2>"$work/f.err" || status=$?
[ $status = 1 ] || fail "a sweep with a failed run exited $status"
tail -1 "$work/f.err" | grep -q "^ebh: error: 1 of 3 runs failed (the first: .*pinned.*unknown group 'no_such_group'" ||
  fail "failed sweep: $(tail -1 "$work/f.err")"
[ "$(column "$work/f/summary.csv" status | tr '\n' ' ')" = "ok failed ok " ] ||
  fail "statuses: $(column "$work/f/summary.csv" status | tr '\n' ' ')"
grep -q "failed,.*unknown group 'no_such_group'" "$work/f/summary.csv" || fail "the summary lacks the error line"

echo "resume: ok ($n of 4 finished before SIGTERM, the other $((4 - n)) ran on resume)"
