#!/bin/bash
# A stand-in for `ebh replay` in test_sweep's runner tests (no GPU needed): writes every replay's
# output (-o) as a one-line text file, except the second line of a --batch file, which fails with
# the FILE:LINE error `ebh replay --batch` gives. With EBH_FAKE_DEVICE_LOG set, each child also
# appends "BACKEND CUDA_VISIBLE_DEVICES" to that file (a batch is CUDA).
[ "$1" = replay ] || exit 2
shift
if [ "$1" = --batch ]; then
  [ -n "$EBH_FAKE_DEVICE_LOG" ] && echo "cuda $CUDA_VISIBLE_DEVICES" >> "$EBH_FAKE_DEVICE_LOG"
  file=$2 n=0 status=0
  while IFS= read -r line; do
    n=$((n + 1))
    out=$(printf '%s\n' "$line" | sed -E 's/.* -o ("[^"]*"|[^ ]*).*/\1/' | tr -d '"')
    if [ $n -eq 2 ]; then echo "ebh: error: $file:$n: the second replay fails"; status=1; continue; fi
    printf '%s\n' "$line" > "$out"
  done < "$file"
  exit $status
fi
backend=cpu
while [ $# -gt 0 ]; do
  [ "$1" = -o ] && echo alone > "$2"
  [ "$1" = --backend ] && backend=$2
  shift
done
[ -n "$EBH_FAKE_DEVICE_LOG" ] && echo "$backend $CUDA_VISIBLE_DEVICES" >> "$EBH_FAKE_DEVICE_LOG"
exit 0
