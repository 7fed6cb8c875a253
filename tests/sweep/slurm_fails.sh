#!/usr/bin/env bash
# ebh sweep --slurm when the submission fails (sbatch not on PATH, or sbatch refusing the job):
# one line, exit status 1, and the sweep's folder as it was before: what the command made
# (the folder, plan.yaml, sweep.sbatch, slurm/) is gone, what was there stays byte-identical.
#   tests/sweep/slurm_fails.sh EBH_BIN WORK_DIR
set -uo pipefail
ebh=$1
work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work/bin"
# An sbatch that refuses every job, as a cluster does for an unknown partition.
printf '#!/bin/sh\necho "sbatch: error: Batch job submission failed: Invalid partition name specified" >&2\nexit 1\n' \
  >"$work/bin/sbatch"
chmod +x "$work/bin/sbatch"
cp "$(dirname "$0")/../data/sweep/tube_one_run.yaml" "$work/plan.yaml"

# submit PATH DIR EXPECT: the submission fails with one line matching EXPECT.
submit() {
  local status=0
  PATH=$1 "$ebh" sweep "$work/plan.yaml" -o "$2" --slurm >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ $status = 1 ] || fail "$2: exit status $status, expected 1: $(cat "$work/err.txt")"
  [ "$(wc -l <"$work/err.txt")" = 1 ] || fail "$2: not one line: $(cat "$work/err.txt")"
  grep -q "^ebh: error: --slurm: $3" "$work/err.txt" || fail "$2: $(cat "$work/err.txt")"
}

# 1. A new folder (two levels of it): nothing is left.
submit "$work/bin:$PATH" "$work/new/sweep" "sbatch failed (status 1): sbatch: error: Batch job submission failed"
[ ! -e "$work/new" ] || fail "left behind: $(find "$work/new")"
submit "$work/no_such_dir" "$work/none" "sbatch: cannot start sbatch: .*(is Slurm's sbatch on PATH?)"
[ ! -e "$work/none" ] || fail "left behind: $(find "$work/none")"

# 2. A folder of an earlier submission of the same plan: its files stay as they were.
mkdir -p "$work/old/slurm"
"$ebh" sweep "$work/plan.yaml" -o "$work/old" --collect >/dev/null 2>&1 || fail "cannot make the folder with --collect"
echo "an earlier script" >"$work/old/sweep.sbatch"
echo "an earlier task's log" >"$work/old/slurm/1_0.out"
before=$(cd "$work/old" && find . -type f | sort | xargs sha256sum)
submit "$work/bin:$PATH" "$work/old" "sbatch failed"
after=$(cd "$work/old" && find . -type f | sort | xargs sha256sum)
[ "$before" = "$after" ] || fail "the folder changed: before $before, after $after"

# 3. Slurm options without --slurm: refused, not run here; --tasks past the run count: one task per run.
for extra in "--slurm-args=--partition=gpu" "--tasks 2"; do
  status=0
  "$ebh" sweep "$work/plan.yaml" -o "$work/here" $extra >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ $status != 0 ] || fail "$extra without --slurm: exit status 0"
  [ ! -e "$work/here" ] || fail "$extra without --slurm: ran here: $(find "$work/here")"
done
grep -q "^ebh: error: --tasks needs --slurm" "$work/err.txt" || fail "--tasks without --slurm: $(cat "$work/err.txt")"
"$ebh" sweep "$work/plan.yaml" -o "$work/here" --slurm-args=-c2 >/dev/null 2>"$work/err.txt"
grep -q -- "--slurm-args.*--slurm" "$work/err.txt" || fail "--slurm-args without --slurm: $(cat "$work/err.txt")"
printf '#!/bin/sh\necho "$@" >"%s"\necho 42\n' "$work/sbatch_args.txt" >"$work/bin/sbatch"
PATH="$work/bin:$PATH" "$ebh" sweep "$work/plan.yaml" -o "$work/capped" --slurm --tasks 50 >"$work/out.txt" 2>"$work/err.txt" ||
  fail "--tasks 50: $(cat "$work/err.txt")"
grep -q -- "--array=0-1 " "$work/sbatch_args.txt" || fail "--tasks 50 of 2 runs: sbatch $(cat "$work/sbatch_args.txt")"
grep -q "^ebh sweep: --tasks 50: the plan has 2 runs here; submitting 2 tasks" "$work/err.txt" || fail "--tasks 50: $(cat "$work/err.txt")"
grep -q -- "--tasks 2 " "$work/capped/sweep.sbatch" || fail "--tasks 50: $(cat "$work/capped/sweep.sbatch")"
echo "slurm fails: ok"
