#!/usr/bin/env bash
# ebh gate --update on a baselines file of its own, with TMPDIR in WORK_DIR:
#  1. the baselines are locked from reading to writing: an update started while another process
#     holds the file says it waits, then runs; two updates at once (of two cases) both land;
#  2. a folder where the baselines cannot be written is said before any case runs (skipped where
#     this user can write everywhere and the file system has no immutable flag);
#  3. a case's replay output goes into a folder of its own under TMPDIR, gone when the gate ends;
#     the folder of a gate killed with SIGKILL is removed by the next gate, one of a process still
#     running is left alone;
#  4. updating one case leaves the others as they were, byte for byte: no key added (the reader
#     refuses a .nan metric), none dropped, no number rewritten, a hand-written layout kept.
#   tests/gate/update.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
unfreeze() { chattr -i "$work/ro" 2>/dev/null; chmod 755 "$work/ro" 2>/dev/null; }
[ -d "$work/ro" ] && unfreeze
rm -rf "$work"
mkdir -p "$work/tmp" "$work/ro"
trap unfreeze EXIT
export TMPDIR=$work/tmp
gate_case() {
  echo "  - {name: $1, scene: $2, recording: $3, start: $4, duration: $5, rms_force_step: 0, max_force_rate: 0," \
    "peak_force: 0, power_above_30hz: 0, penetration_max: 0}"
}
baselines() { echo "cases:"; gate_case a tube tube_insert 4 0.3; gate_case b gap gap_insert 2 0.3; }
baselines >"$work/b.yaml"

# 1. Locked by another process: the update waits for it.
if command -v flock >/dev/null; then
  flock "$work/b.yaml" sleep 2 &
  holder=$!
  sleep 0.5
  "$ebh" gate --baselines "$work/b.yaml" --update --case a >"$work/out.txt" 2>"$work/err.txt" ||
    fail "update beside a lock: $(cat "$work/err.txt")"
  grep -q "^ebh gate: $work/b.yaml: another ebh gate --update is writing it; waiting$" "$work/err.txt" ||
    fail "update beside a lock did not wait: $(cat "$work/err.txt")"
  kill -0 $holder 2>/dev/null && fail "the update did not wait for the lock"
  wait $holder
fi
# Two updates at once, of two cases: neither loses the other's.
baselines >"$work/b.yaml"
"$ebh" gate --baselines "$work/b.yaml" --update --case a >"$work/a.out" 2>"$work/a.err" &
pa=$!
"$ebh" gate --baselines "$work/b.yaml" --update --case b >"$work/b.out" 2>"$work/b.err" &
pb=$!
wait $pa || fail "update a: $(cat "$work/a.err")"
wait $pb || fail "update b: $(cat "$work/b.err")"
for n in a b; do
  grep -q "name: $n," "$work/b.yaml" || fail "case $n is gone: $(cat "$work/b.yaml")"
  grep "name: $n," "$work/b.yaml" | grep -q "rms_force_step: 0," && fail "case $n's update was lost: $(cat "$work/b.yaml")"
done

# 2. A folder the baselines cannot be written into: said before any case runs.
baselines >"$work/ro/b.yaml"
chmod 555 "$work/ro"
[ -w "$work/ro" ] && chattr +i "$work/ro" 2>/dev/null
if [ -w "$work/ro" ]; then
  echo "unwritable folder: skipped (this user writes everywhere)"
else
  status=0
  "$ebh" gate --baselines "$work/ro/b.yaml" --update >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ $status = 1 ] || fail "unwritable folder: exit status $status: $(cat "$work/err.txt")"
  [ ! -s "$work/out.txt" ] || fail "unwritable folder: cases ran first: $(cat "$work/out.txt")"
  [ "$(wc -l <"$work/err.txt")" = 1 ] || fail "unwritable folder: not one line: $(cat "$work/err.txt")"
  grep -Eq "^ebh: error: $work/ro/b.yaml: cannot create the output: (Permission denied|Operation not permitted)$" \
    "$work/err.txt" || fail "unwritable folder: $(cat "$work/err.txt")"
fi
unfreeze

# 3. The replay outputs' folders.
[ -z "$(ls -A "$work/tmp")" ] || fail "gates left files in TMPDIR: $(ls -A "$work/tmp")"
mkdir "$work/tmp/ebh_gate_$$_alive1"  # a running process's (this shell's)
{ echo "cases:"; gate_case long tube tube_insert 1 8; } >"$work/long.yaml"
"$ebh" gate --baselines "$work/long.yaml" >/dev/null 2>&1 &
killed=$!
for _ in $(seq 300); do
  compgen -G "$work/tmp/*ebh_gate_${killed}_*" >/dev/null && break
  sleep 0.1
done
kill -KILL $killed
wait $killed 2>/dev/null
compgen -G "$work/tmp/*ebh_gate_${killed}_*" >/dev/null || fail "the killed gate's folder did not appear"
"$ebh" gate --baselines "$work/b.yaml" --case a >/dev/null 2>&1
left=$(ls -A "$work/tmp")
[ "$left" = "ebh_gate_$$_alive1" ] || fail "TMPDIR after the next gate: $left"

# 4. Updating one case keeps the others as they were (a case without metrics gained
# `boundary_step_ratio: .nan`, and every case's duration: 0.3 became 0.29999999999999999).
others='  - {name: c, scene: gap, recording: gap_insert, start: 2, duration: 0.3}
  - name: d  # a case written by hand
    scene: gap
    recording: gap_insert
    start: 2
    duration: 0.3
    peak_force: 1.5'
{ echo "cases:"; gate_case a tube tube_insert 4 0.3; echo "$others"; } >"$work/new_case.yaml"
"$ebh" gate --baselines "$work/new_case.yaml" --update --case a >/dev/null 2>"$work/err.txt" ||
  fail "update beside a case without metrics: $(cat "$work/err.txt")"
[ "$(tail -n 7 "$work/new_case.yaml")" = "$others" ] ||
  fail "the cases not updated changed: $(cat "$work/new_case.yaml")"
grep "name: a," "$work/new_case.yaml" | grep -q "rms_force_step: 0," && fail "case a was not updated: $(cat "$work/new_case.yaml")"
"$ebh" gate --baselines "$work/new_case.yaml" --case a >/dev/null 2>"$work/err.txt" ||
  fail "the updated file does not read: $(cat "$work/err.txt")"
echo "gate update: ok"
