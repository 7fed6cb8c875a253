#!/bin/bash
# A stand-in for a replay that has begun writing its output (test_sweep's runner tests): it makes
# the output's temporary as `ebh replay` does (DIR/.NAME.HOST.PID.ebh-partial, io/atomic.hpp) and
# writes its PID into a file in $EBH_FAKE_PID_DIR; then, with EBH_FAKE_KILL_SELF set, it kills
# itself with SIGKILL (as the OOM killer would), else it sleeps until a signal ends it.
[ "$1" = replay ] || exit 2
out=
while [ $# -gt 0 ]; do
  [ "$1" = -o ] && out=$2
  shift
done
echo partial >"$(dirname "$out")/.$(basename "$out").$(uname -n).$$.ebh-partial"
[ -n "$EBH_FAKE_PID_DIR" ] && echo $$ >"$EBH_FAKE_PID_DIR/$$"
[ -n "$EBH_FAKE_KILL_SELF" ] && kill -KILL $$
exec sleep 60
