#!/usr/bin/env bash
# An interrupt while ffmpeg assembles `ebh render --video`'s video stops ffmpeg too (none outlives
# ebh writing into the video's temporary), says "interrupted" in one line and leaves neither the
# video nor its temporary. A stand-in ffmpeg that never ends takes ffmpeg's place on the PATH:
#   tests/video_interrupt.sh EBH_BIN REPLAY_WITH_FRAMES.h5 WORK_DIR
set -uo pipefail
ebh=$1
replay=$2
work=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work/bin"
printf '#!/bin/sh\necho $$ > "%s/ffmpeg.pid"\nexec sleep 1000\n' "$work" >"$work/bin/ffmpeg"
# One that ignores SIGTERM, so that ebh waits for it to end before it sends SIGKILL.
mkdir -p "$work/stubborn"
printf '#!/bin/sh\ntrap "" TERM\necho $$ > "%s/ffmpeg.pid"\nexec sleep 1000\n' "$work" >"$work/stubborn/ffmpeg"
chmod +x "$work/bin/ffmpeg" "$work/stubborn/ffmpeg"
bin=$work/bin
stray() { [ -s "$work/ffmpeg.pid" ] && kill -KILL "$(cat "$work/ffmpeg.pid")" 2>/dev/null; }
trap stray EXIT
# started NAME CMD...: runs CMD in the background ($pid) and returns once it has started ffmpeg.
started() {
  local name=$1 waited=0
  shift
  rm -f "$work/ffmpeg.pid"
  PATH="$bin:$PATH" "$@" >"$work/$name.out" 2>"$work/$name.err" &
  pid=$!
  until [ -s "$work/ffmpeg.pid" ]; do
    kill -0 $pid 2>/dev/null || fail "$name: ended before it started ffmpeg: $(cat "$work/$name.err")"
    [ $waited -lt 600 ] || fail "$name: no ffmpeg after 60 s"
    sleep 0.1
    waited=$((waited + 1))
  done
}
# gone PID: the process PID has ended (a zombie left to init counts as ended), within 2 s.
gone() {
  local waited=0
  while [ $waited -lt 20 ]; do
    [ "$(awk '{print $3}' "/proc/$1/stat" 2>/dev/null || echo Z)" = Z ] && return 0
    sleep 0.1
    waited=$((waited + 1))
  done
  return 1
}
# checked NAME: ffmpeg is gone, the message says interrupted in one line, no video nor temporary.
checked() {
  local name=$1 ffmpeg
  ffmpeg=$(cat "$work/ffmpeg.pid")
  ! kill -0 "$ffmpeg" 2>/dev/null || fail "$name: ffmpeg ($ffmpeg) still runs after ebh ended"
  [ "$(wc -l <"$work/$name.err")" = 1 ] || fail "$name: not one line: $(cat "$work/$name.err")"
  grep -q "^ebh: error: --video .*$name.mp4: interrupted" "$work/$name.err" ||
    fail "$name: the message does not say interrupted: $(cat "$work/$name.err")"
  [ ! -e "$work/$name.mp4" ] || fail "$name: an interrupted render wrote its video"
  ! ls -a "$work" | grep -q "^\.$name\.mp4\..*\.ebh-partial$" || fail "$name: the video's temporary was left"
}
# SIGTERM to ebh alone: it stops ffmpeg itself, before the interrupt's grace runs out.
started term "$ebh" render "$replay" -o "$work/term_frames" --size 160x120 --video "$work/term.mp4"
kill -TERM $pid
status=0
wait $pid || status=$?
[ $status = 143 ] || fail "term: exit status $status, expected 143: $(cat "$work/term.err")"
checked term
# `timeout` (and a terminal's Ctrl-C) signal the whole process group: ffmpeg ends by the signal
# too, which is an interrupt, not ffmpeg failing.
started group timeout 600 "$ebh" render "$replay" -o "$work/group_frames" --size 160x120 --video "$work/group.mp4"
kill -TERM $pid
wait $pid
checked group
# A second signal while ebh waits for ffmpeg to end ends ebh at once: ffmpeg is killed first, not
# left running with its parent gone.
bin=$work/stubborn
started twice "$ebh" render "$replay" -o "$work/twice_frames" --size 160x120 --video "$work/twice.mp4"
kill -TERM $pid
sleep 0.2
kill -TERM $pid
status=0
wait $pid || status=$?
[ $status = 143 ] || fail "twice: exit status $status, expected 143: $(cat "$work/twice.err")"
gone "$(cat "$work/ffmpeg.pid")" || fail "twice: ffmpeg ($(cat "$work/ffmpeg.pid")) still runs after ebh ended"
[ "$(cat "$work/twice.err")" = "ebh: interrupted again: stopping now; unfinished outputs removed" ] ||
  fail "twice: not the second interrupt's line: $(cat "$work/twice.err")"
[ ! -e "$work/twice.mp4" ] || fail "twice: an interrupted render wrote its video"
! ls -a "$work" | grep -q "^\.twice\.mp4\..*\.ebh-partial$" || fail "twice: the video's temporary was left"
echo "video interrupt: ok"
