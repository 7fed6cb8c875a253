#!/usr/bin/env bash
# A sweep's folder holds one plan: another plan run into it is refused (one line naming
# DIR/plan.yaml and what to do), leaving the folder as it was; the same plan written otherwise
# (keys in another order, comments, another path to the same scene) and the folder's own
# plan.yaml resume it. --collect keeps every step free of replays.
#   tests/sweep/other_plan.sh EBH_BIN WORK_DIR TUBE_SCENE_FILE
set -uo pipefail
ebh=$1
work=$2
tube=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
cp "$(dirname "$0")/../data/sweep/tube_one_run.yaml" "$work/a.yaml"
sed 's/duration: 0.05/duration: 0.06/' "$work/a.yaml" >"$work/b.yaml"
dir=$work/sweep
"$ebh" sweep "$work/a.yaml" -o "$dir" --collect >/dev/null 2>"$work/err.txt" || fail "first plan: $(cat "$work/err.txt")"
mkdir -p "$dir/runs"
echo "a run of plan a" >"$dir/runs/0123456789abcdef.failed"
before=$(cd "$dir" && find . -type f | sort | xargs sha256sum)

# Another plan: refused before any work, with or without --collect.
for extra in "" --collect; do
  status=0
  "$ebh" sweep "$work/b.yaml" -o "$dir" $extra >"$work/out.txt" 2>"$work/err.txt" || status=$?
  [ $status = 1 ] || fail "b.yaml $extra: exit status $status: $(cat "$work/err.txt")"
  [ "$(wc -l <"$work/err.txt")" = 1 ] || fail "b.yaml $extra: not one line: $(cat "$work/err.txt")"
  grep -q "^ebh: error: $dir/plan.yaml: another plan's folder: .* not $work/b.yaml's; give $work/b.yaml a new folder (-o NEW_DIR" \
    "$work/err.txt" || fail "b.yaml $extra: $(cat "$work/err.txt")"
  after=$(cd "$dir" && find . -type f | sort | xargs sha256sum)
  [ "$before" = "$after" ] || fail "b.yaml $extra changed the folder: $after"
done

# The same plan: keys in another order, a comment, the scene by its path: a resume.
cat >"$work/a_again.yaml" <<PLAN
# plan a, written again
duration: 0.05
start: 4
runs:
  - {solver.virtual_iterations: 2}
scenes:
  - {scene: $tube, recordings: [tube_insert], reference: {}}
PLAN
"$ebh" sweep "$work/a_again.yaml" -o "$dir" --collect >/dev/null 2>"$work/err.txt" || fail "the same plan: $(cat "$work/err.txt")"
"$ebh" sweep "$dir/plan.yaml" -o "$dir" --collect >/dev/null 2>"$work/err.txt" || fail "the folder's plan: $(cat "$work/err.txt")"
# A row deleted from summary.csv by hand: the report names the run it lacks and how to rebuild it.
rows=$work/rows
"$ebh" sweep "$work/a.yaml" -o "$rows" --collect >/dev/null 2>"$work/err.txt" || fail "rows: $(cat "$work/err.txt")"
id=$(sed -n 3p "$rows/summary.csv" | cut -d, -f1)
mkdir -p "$rows/runs"
echo "another program's file" >"$rows/runs/$id.h5"
"$ebh" sweep "$work/a.yaml" -o "$rows" --collect >/dev/null 2>&1
grep -q "^$id,failed," "$rows/summary.csv" || fail "rows: $id: $(cat "$rows/summary.csv")"
sleep 0.01
sed -i "/^$id,/d" "$rows/summary.csv"
status=0
"$ebh" sweep report "$rows" >/dev/null 2>"$work/err.txt" || status=$?
[ $status = 1 ] || fail "a row deleted: exit status $status: $(cat "$work/err.txt")"
grep -q "^ebh: error: $rows/summary.csv: lacks 1 of the plan's runs (the first: .*($id), .*rebuild it: ebh sweep $rows/plan.yaml -o $rows --collect" \
  "$work/err.txt" || fail "a row deleted: $(cat "$work/err.txt")"

# A folder whose plan.yaml does not read (cut short, emptied): its error is named, not another plan.
cp "$dir/plan.yaml" "$work/kept.yaml"
for broken in "garbage: [" ""; do
  printf '%s\n' "$broken" >>"$dir/plan.yaml"
  [ -z "$broken" ] && : >"$dir/plan.yaml"
  status=0
  "$ebh" sweep "$work/a.yaml" -o "$dir" >/dev/null 2>"$work/err.txt" || status=$?
  [ $status = 1 ] || fail "broken plan.yaml '$broken': exit status $status: $(cat "$work/err.txt")"
  [ "$(wc -l <"$work/err.txt")" = 1 ] || fail "broken plan.yaml '$broken': not one line: $(cat "$work/err.txt")"
  if [ -n "$broken" ]; then want="$dir/plan.yaml:[0-9]*: YAML syntax error"; else want="$dir/plan.yaml: empty plan"; fi
  grep -q "^ebh: error: $want.*(the plan of the sweep's folder $dir, .*repair it, or give $work/a.yaml a new folder" \
    "$work/err.txt" || fail "broken plan.yaml '$broken': $(cat "$work/err.txt")"
  cp "$work/kept.yaml" "$dir/plan.yaml"
done
# A folder without a plan.yaml that holds a summary is no sweep's: refused, as it is. One whose
# runs/ holds run files only (copied from another sweep's folder) takes any plan.
rm "$dir/plan.yaml"
before=$(cd "$dir" && find . -type f | sort | xargs sha256sum)
status=0
"$ebh" sweep "$work/b.yaml" -o "$dir" --collect >/dev/null 2>"$work/err.txt" || status=$?
[ $status = 1 ] || fail "no plan.yaml, a summary: exit status $status: $(cat "$work/err.txt")"
grep -q "^ebh: error: $dir: not an ebh sweep folder (no plan.yaml) but holds summary.csv: name a new or empty folder" \
  "$work/err.txt" || fail "no plan.yaml, a summary: $(cat "$work/err.txt")"
after=$(cd "$dir" && find . -type f | sort | xargs sha256sum)
[ "$before" = "$after" ] || fail "no plan.yaml: the folder changed: $after"
rm "$dir/summary.csv" "$dir/summary.h5"
"$ebh" sweep "$work/b.yaml" -o "$dir" --collect >/dev/null 2>"$work/err.txt" || fail "no plan.yaml: $(cat "$work/err.txt")"
echo "other plan: ok"
