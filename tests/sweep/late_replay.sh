#!/bin/bash
# A stand-in for a replay that the sweep's interrupt reaches after it wrote its output (test_sweep's
# runner tests): it writes the output (-o) at once, then exits 143 on SIGTERM (as `ebh replay`
# does when a signal arrives on its way out).
trap 'exit 143' TERM INT
while [ $# -gt 0 ]; do
  [ "$1" = -o ] && echo written > "$2"
  shift
done
sleep 60 &
wait
