#!/usr/bin/env bash
# An interrupted command exits with 128 + signal (143 for SIGTERM, 130 for SIGINT), not 1 (bad
# input), says so in one line and leaves no output:
#   tests/interrupt_status.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
for sig in TERM INT; do
  "$ebh" replay tube tube_insert -o "$work/$sig.h5" -q 2>"$work/$sig.err" &
  pid=$!
  sleep 1
  kill -0 $pid 2>/dev/null || fail "the replay ended within 1 s: $(cat "$work/$sig.err")"
  kill -$sig $pid
  status=0
  wait $pid || status=$?
  expected=$((128 + $(kill -l $sig)))
  [ $status = $expected ] || fail "SIG$sig: exit status $status, expected $expected: $(cat "$work/$sig.err")"
  grep -q "interrupted" "$work/$sig.err" || fail "no interrupt message: $(cat "$work/$sig.err")"
  [ ! -e "$work/$sig.h5" ] || fail "an interrupted replay wrote its output"
done
# interrupted NAME SIG CMD...: runs CMD (its output in $work/NAME.out and .err), sends SIG a second
# later and sets `status` to its exit status.
# With CPU=S set, it waits instead until the command has used S seconds of processor time (past
# its load on a busy machine, where a second of wall time may not be).
interrupted() {
  local name=$1 sig=$2
  shift 2
  "$@" >"$work/$name.out" 2>"$work/$name.err" &
  local pid=$!
  if [ -n "${CPU:-}" ]; then
    local tick used waited=0
    tick=$(getconf CLK_TCK)
    while [ $waited -lt 600 ]; do  # 60 s at most
      used=$(awk '{print $14 + $15}' "/proc/$pid/stat" 2>/dev/null) || break
      [ "$used" -ge $((CPU * tick)) ] && break
      sleep 0.1
      waited=$((waited + 1))
    done
  else
    sleep 1
  fi
  kill -"$sig" $pid
  status=0
  wait $pid || status=$?
}
# Before a command polls for interrupts (a long load; table1 and validate never do) a signal ends
# it at once with one line and 128 + signal, not without a word.
interrupted table1 INT "$ebh" table1
[ $status = 130 ] || fail "table1: exit status $status, expected 130: $(cat "$work/table1.err")"
grep -q "^ebh: interrupted by SIGINT; no output file written$" "$work/table1.err" ||
  fail "table1: no interrupt message: $(cat "$work/table1.err")"
# An interrupted gate names the case it stopped in, not its temporary replay file.
interrupted gate TERM "$ebh" gate
[ $status = 143 ] || fail "gate: exit status $status, expected 143: $(cat "$work/gate.err")"
grep -q "baselines.yaml:[0-9]*: cases\[[0-9]*\] (.*): interrupted; the gate stopped here" "$work/gate.err" ||
  fail "gate: the interrupt does not name the case: $(cat "$work/gate.err")"
# A signal during a long physical step (30000 iterations: seconds a step) stops the step too, in
# each mode: 130 and the message, no output, not a crash (the step's partway state is no result),
# and no wait for the step to end (the grace would end the process with its own message).
for mode in async lockstep; do
  CPU=2 interrupted "step_$mode" INT "$ebh" replay tube tube_insert -o "$work/step_$mode.h5" -q --mode $mode --duration 0.5 \
    --set solver.physical_iterations=30000 --set solver.physical_tolerance=0
  [ $status = 130 ] || fail "$mode, in a long step: exit status $status, expected 130: $(cat "$work/step_$mode.err")"
  grep -q "interrupted after [0-9.e+-]* of 0.5 s; no output written" "$work/step_$mode.err" ||
    fail "$mode, in a long step: $(cat "$work/step_$mode.err")"
  ! grep -q "still running after the interrupt's grace" "$work/step_$mode.err" ||
    fail "$mode: the step ran on after the interrupt"
  [ ! -e "$work/step_$mode.h5" ] || fail "$mode: an interrupted replay wrote its output"
done
# A signal ignored at the start stays ignored: `nohup ebh ...` outlives its terminal's SIGHUP.
nohup "$ebh" replay tube tube_insert -o "$work/nohup.h5" -q --duration 6 >"$work/nohup.err" 2>&1 &
pid=$!
sleep 1
kill -0 $pid 2>/dev/null || fail "the nohup replay ended within 1 s: $(cat "$work/nohup.err")"
kill -HUP $pid
status=0
wait $pid || status=$?
[ $status = 0 ] || fail "nohup: SIGHUP stopped the replay (exit status $status): $(cat "$work/nohup.err")"
[ -s "$work/nohup.h5" ] || fail "nohup: no output"
echo "interrupt status: ok"
