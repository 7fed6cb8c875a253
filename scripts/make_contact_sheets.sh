#!/usr/bin/env bash
# Regenerates docs/img/contact_<scene>.png: for each of the paper's four scenes, replays the first
# seconds of its committed recording with mesh snapshots (10 per second), renders them with
# `ebh render` (the scene file's camera) and tiles six evenly spaced frames into one image with
# the frame times as captions (Debian's python3 with numpy and matplotlib).
#
#   scripts/make_contact_sheets.sh                 # uses build/ebh, a fresh work directory
#   EBH=build-render/ebh WORK=/tmp/sheets REUSE=1 scripts/make_contact_sheets.sh
#
# EBH: the ebh binary (built with OSMesa). WORK: where replay outputs and frames go (kept).
# REUSE=1: keep a replay output already in WORK instead of replaying again.
# ONLY="tube gap": make only these sheets.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
EBH=${EBH:-$ROOT/build/ebh}
WORK=${WORK:-$(mktemp -d -t ebh_sheets.XXXXXX)}
REUSE=${REUSE:-0}
PY=${PYTHON:-/usr/bin/python3}
OUT=$ROOT/docs/img
mkdir -p "$WORK" "$OUT"

# sheet name | scene (the recording's `scene` attribute) | recording | seconds replayed | colour
# The durations end where each recording does its main thing: the hook deep in the bore or the
# gap, the forceps closed on the gallbladder and pulling, the hook pressed into the fundus. The
# fundus press is seen edge-on from the scene's camera, so that sheet colours the tissue by
# displacement to show the dent.
SHEETS=(
  "tube tube tube_insert 6 none"
  "gap gap gap_insert 4.6 none"
  "cholecystectomy cholecystectomy cholecystectomy_grasp 2.6 none"
  "gynaecology gynaecology_hook gynaecology_press 2.4 displacement"
)

for entry in "${SHEETS[@]}"; do
  read -r name scene recording seconds colour <<<"$entry"
  if [[ -n "${ONLY:-}" && " $ONLY " != *" $name "* ]]; then continue; fi
  out=$WORK/$name.h5
  if [[ "$REUSE" != 1 || ! -f "$out" ]]; then
    echo "== $name: ebh replay $scene $recording --duration $seconds" >&2
    "$EBH" replay "$scene" "$recording" -o "$out" --frames-hz 10 --duration "$seconds" -q
  fi
  "$EBH" render "$out" -o "$WORK/$name" --size 480x360 --no-time-bar --color-by "$colour" | tee "$WORK/$name.txt"
  legend=$(sed -n 's/^ *tissue colour = displacement from rest: 0 mm .* \.\. \([0-9.]*\) mm.*$/tissue: displacement 0 (blue) .. \1 mm (red)/p' "$WORK/$name.txt")
  "$PY" - "$WORK/$name" "$out" "$OUT/contact_$name.png" "$name" "$legend" <<'EOF'
import glob, sys
import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.image as mpimg
import matplotlib.pyplot as plt
import numpy as np

frames_dir, replay, target, name, legend = sys.argv[1:6]
files = sorted(glob.glob(frames_dir + "/frame_*.png"))
with h5py.File(replay, "r") as f:
    t = f["frames/t"][:]
    recording = f.attrs.get("recording", "")
    if isinstance(recording, bytes):
        recording = recording.decode()
picks = np.unique(np.linspace(0, len(files) - 1, 6).round().astype(int))
fig, axes = plt.subplots(2, 3, figsize=(9.6, 5.0), dpi=100)
for ax in axes.flat:
    ax.axis("off")
for ax, k in zip(axes.flat, picks):
    ax.imshow(mpimg.imread(files[k]))
    ax.set_title(f"t = {t[k]:.1f} s", fontsize=9)
rec = recording.rsplit("/", 1)[-1]
caption = "physical tool green, virtual tool grey" + (f"; {legend}" if legend else "")
fig.suptitle(f"{name}: {rec} ({caption})", fontsize=10)
fig.tight_layout(rect=(0, 0, 1, 0.95), pad=0.3)
fig.savefig(target, dpi=100, pil_kwargs={"optimize": True})
print(target)
EOF
done
