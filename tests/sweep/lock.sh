#!/usr/bin/env bash
# One sweep at a time in a folder: while a sweep runs, a second one into the same folder (the same
# plan, or another) is refused with one line naming the first one's PID, and changes nothing; the
# first finishes as if alone. The lock dies with its process: after a SIGKILL the next sweep goes
# on (no stale lock to remove by hand), and a finished sweep leaves no lock file.
#   tests/sweep/lock.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
cat >"$work/plan.yaml" <<'PLAN'
scenes:
  - {scene: tube, recordings: [tube_insert], reference: {}}
runs:
  - {solver.virtual_iterations: 2}
  - {solver.virtual_iterations: 3}
start: 4
duration: 1
PLAN
sed 's/duration: 1/duration: 0.5/' "$work/plan.yaml" >"$work/other.yaml"
dir=$work/sweep
ran_ids() { sed -n 's/^\[[0-9]*\/[0-9]*\] done in .*(\([0-9a-f]*\))$/\1/p' "$1" | sort; }

# wait_lock PID: until the sweep PID holds the folder's lock (its PID in DIR/.lock), at most 30 s.
wait_lock() {
  for _ in $(seq 300); do
    [ "$(cat "$dir/.lock" 2>/dev/null)" = "$1" ] && return 0
    kill -0 "$1" 2>/dev/null || return 1
    sleep 0.1
  done
  return 1
}

"$ebh" sweep "$work/plan.yaml" -o "$dir" >/dev/null 2>"$work/first.err" &
first=$!
wait_lock $first || fail "the first sweep took no lock: $(cat "$work/first.err")"
for plan in plan other; do
  status=0
  "$ebh" sweep "$work/$plan.yaml" -o "$dir" >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ $status = 1 ] || fail "$plan.yaml beside a running sweep: exit status $status: $(cat "$work/err.txt")"
  [ "$(wc -l <"$work/err.txt")" = 1 ] || fail "$plan.yaml: not one line: $(cat "$work/err.txt")"
  grep -q "^ebh: error: $dir: another ebh sweep (pid $first) is running in this folder$" "$work/err.txt" ||
    fail "$plan.yaml: $(cat "$work/err.txt")"
  [ "$(cat "$dir/.lock" 2>/dev/null)" = $first ] || fail "$plan.yaml: the first sweep's lock file changed"
done
status=0
wait $first || status=$?
[ $status = 0 ] || fail "the first sweep: exit status $status: $(tail -1 "$work/first.err")"
[ "$(ran_ids "$work/first.err" | wc -l)" = 3 ] || fail "the first sweep ran $(ran_ids "$work/first.err")"
[ ! -e "$dir/.lock" ] || fail "a finished sweep left its lock file"
grep -q '^duration: 1$' "$dir/plan.yaml" || fail "the folder's plan changed: $(cat "$dir/plan.yaml")"

# SIGKILL mid-way: the lock goes with the process; the next sweep takes the folder.
rm -rf "$dir/runs"
"$ebh" sweep "$work/plan.yaml" -o "$dir" >/dev/null 2>"$work/killed.err" &
killed=$!
wait_lock $killed || fail "the second sweep took no lock: $(cat "$work/killed.err")"
kill -KILL $killed
wait $killed 2>/dev/null
"$ebh" sweep "$work/plan.yaml" -o "$dir" >/dev/null 2>"$work/after.err" ||
  fail "after a SIGKILL: $(tail -1 "$work/after.err")"
[ ! -e "$dir/.lock" ] || fail "the sweep after a SIGKILL left its lock file"
echo "lock: ok"
