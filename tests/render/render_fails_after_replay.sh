#!/bin/sh
# `ebh replay --render DIR` whose frames cannot be written once the replay is done (DIR on a full
# disk: a 16 KiB tmpfs, mounted in a private mount namespace): the previous output and the previous
# frames stay as they were, no temporary is left, and the error says so. Exits 77 (skipped) where
# no tmpfs can be mounted.
#   render_fails_after_replay.sh EBH WORK_DIR
set -u
ebh=$1
work=$2
rm -rf "$work" && mkdir -p "$work/frames" || exit 1
"$ebh" replay tube tube_insert -o "$work/out.h5" --duration 0.02 --frames-hz 0 -q || exit 1
cp "$work/out.h5" "$work/before.h5" || exit 1
unshare -m true 2>/dev/null || { echo "SKIP: cannot make a mount namespace here"; exit 77; }
exec unshare -m sh -c '
  ebh=$1 work=$2
  mount -t tmpfs -o size=16k tmpfs "$work/frames" 2>/dev/null || { echo "SKIP: cannot mount a tmpfs here"; exit 77; }
  echo previous > "$work/frames/frame_00000.png"
  "$ebh" replay tube tube_insert -o "$work/out.h5" --duration 0.1 --frames-hz 20 --render "$work/frames" -q 2> "$work/err.txt"
  status=$?
  cat "$work/err.txt"
  [ $status -eq 1 ] || { echo "FAIL: exit status $status, expected 1"; exit 1; }
  grep -q "^ebh: error: [^ ]*frames/frame_00000.png: cannot write the output: No space left on device; the previous frames are kept (nor is the replay'"'"'s output written: [^ ]*out.h5 is as it was)\$" "$work/err.txt" ||
    { echo "FAIL: not the expected error"; exit 1; }
  [ "$(cat "$work/frames/frame_00000.png")" = previous ] || { echo "FAIL: the previous frame was replaced"; exit 1; }
  [ "$(ls -A "$work/frames")" = frame_00000.png ] || { echo "FAIL: left among the frames: $(ls -A "$work/frames")"; exit 1; }
  cmp -s "$work/out.h5" "$work/before.h5" || { echo "FAIL: the previous output was replaced"; exit 1; }
  left=$(ls -A "$work" | grep -v -x -e out.h5 -e before.h5 -e frames -e err.txt)
  [ -z "$left" ] || { echo "FAIL: left beside the output: $left"; exit 1; }
  echo "PASS"
' sh "$ebh" "$work"
