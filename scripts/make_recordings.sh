#!/usr/bin/env bash
# Regenerates every committed synthetic recording (recordings/*.h5) from its plan
# (recordings/*.yaml) with `ebh synth`, seed 1, 1 kHz. The recordings are deterministic: the same
# ebh version and plan give bitwise the same trajectory (the HDF5 container may differ in its
# metadata bytes). Each file's root attribute `generator` records the command and ebh version.
#
#   scripts/make_recordings.sh [path/to/ebh]      (default: build/ebh)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
arg="${1:-$root/build/ebh}"
ebh="$(realpath -e "$arg" 2>/dev/null || true)"
if [[ -z "$ebh" || ! -x "$ebh" ]]; then
  echo "make_recordings.sh: no ebh binary at $arg (build it, or pass its path)" >&2
  exit 1
fi
cd "$root/recordings"
echo "$("$ebh" --version): regenerating recordings/*.h5"
for plan in tube_insert tube_grasp gap_insert gap_grasp cholecystectomy_press cholecystectomy_grasp gynaecology_press gynaecology_grasp; do
  "$ebh" synth "$plan.yaml" -o "$plan.h5" --seed 1 --rate 1000
done
