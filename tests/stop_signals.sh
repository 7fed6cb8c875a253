#!/usr/bin/env bash
# The signals whose default action ends a process without a word (SIGUSR1, SIGUSR2, SIGALRM,
# SIGXCPU, SIGVTALRM, SIGPROF) stop a replay as SIGTERM does: exit status 128 + signal, one line
# saying "interrupted", and neither the output nor its hidden temporary left. One ignored at the
# start stays ignored, as `nohup` leaves SIGHUP:
#   tests/stop_signals.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
export OMP_NUM_THREADS=1
signals="USR1 USR2 ALRM XCPU VTALRM PROF"
declare -A pids
for sig in $signals; do  # side by side: one second for all
  "$ebh" replay tube tube_insert -o "$work/$sig.h5" -q --duration 6 2>"$work/$sig.err" &
  pids[$sig]=$!
done
# temporary SIG: whether the replay made its output's temporary (it runs; its handlers are in).
temporary() { compgen -G "$work/.$1.h5.*.ebh-partial" >/dev/null; }
for sig in $signals; do
  waited=0
  until temporary "$sig"; do  # a busy machine may take a while to start six processes
    kill -0 "${pids[$sig]}" 2>/dev/null || fail "SIG$sig: the replay ended before it began: $(cat "$work/$sig.err")"
    [ $waited -lt 300 ] || fail "SIG$sig: no output's temporary after 30 s"
    sleep 0.1
    waited=$((waited + 1))
  done
done
for sig in $signals; do
  kill -0 "${pids[$sig]}" 2>/dev/null || fail "SIG$sig: the replay ended before the signal: $(cat "$work/$sig.err")"
  kill -"$sig" "${pids[$sig]}"
done
for sig in $signals; do
  status=0
  wait "${pids[$sig]}" || status=$?
  expected=$((128 + $(kill -l "$sig")))
  [ $status = $expected ] || fail "SIG$sig: exit status $status, expected $expected: $(cat "$work/$sig.err")"
  [ "$(wc -l <"$work/$sig.err")" = 1 ] && grep -q "interrupted" "$work/$sig.err" ||
    fail "SIG$sig: not one line saying interrupted: $(cat "$work/$sig.err")"
  [ ! -e "$work/$sig.h5" ] || fail "SIG$sig: an interrupted replay wrote its output"
  ! temporary "$sig" || fail "SIG$sig: the output's temporary was left"
done
# Ignored at the start (by the shell's trap, which exec keeps), SIGUSR1 and SIGALRM stay ignored;
# the replay writes its output and ends with 0.
(trap '' USR1 ALRM; exec "$ebh" replay tube tube_insert -o "$work/ignored.h5" -q --duration 2 2>"$work/ignored.err") &
pid=$!
sleep 0.5
kill -USR1 $pid || fail "ignored: the replay ended within 0.5 s: $(cat "$work/ignored.err")"
kill -ALRM $pid
status=0
wait $pid || status=$?
[ $status = 0 ] || fail "ignored: exit status $status: $(cat "$work/ignored.err")"
[ -s "$work/ignored.h5" ] || fail "ignored: no output"
echo "stop signals: ok"
