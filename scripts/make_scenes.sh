#!/usr/bin/env bash
# Regenerates the tetrahedral meshes of the paper's four scenes from scripts/geo/*.geo:
#   scenarios/tube.msh, gap.msh, cholecystectomy.msh   (MSH 4.1 ASCII)
#   scenarios/gynaecology.msh                          (MSH 2.2 ASCII: both readers see a real scene)
# then checks each one with scripts/check_msh.py (tets, boundary triangles, interior faces, groups,
# bounding box, worst quality) and fails if a tet count is off Table 1 by more than 5%.
#
# You do NOT need gmsh to use ebh: the .msh files are committed. This script is for changing a
# scene. It needs gmsh >= 4.8 with OpenCASCADE (Debian: apt-get install gmsh) and python3.
#
#   scripts/make_scenes.sh              regenerate all four meshes (about a minute, one core)
#   scripts/make_scenes.sh tube gap     only these
#   scripts/make_scenes.sh --check      only check the committed .msh files
#   scripts/make_scenes.sh --tune NAME  re-tune NAME's lc to its Table 1 count (rewrites the .geo)
#
# Deterministic: one thread (-nt 1), Mesh.RandomSeed = 1 in each .geo, fixed lc in each .geo.
# The same gmsh version gives the same files; another version may differ by a few percent in the
# tet count (the check tolerates 5%; re-tune with --tune). Idempotent: it only overwrites outputs.
set -euo pipefail
cd "$(dirname "$0")/.."

declare -A TARGET=([tube]=8068 [gap]=16630 [cholecystectomy]=44178 [gynaecology]=16848)
declare -A FORMAT=([tube]=msh41 [gap]=msh41 [cholecystectomy]=msh41 [gynaecology]=msh22)
ALL=(tube gap cholecystectomy gynaecology)

mode=make
names=()
for arg in "$@"; do
  case "$arg" in
    --check) mode=check ;;
    --tune) mode=tune ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    -*) echo "make_scenes.sh: unknown option '$arg' (try --help)" >&2; exit 2 ;;
    *) [ -n "${TARGET[$arg]:-}" ] || { echo "make_scenes.sh: unknown scene '$arg'" >&2; exit 2; }
       names+=("$arg") ;;
  esac
done
[ ${#names[@]} -gt 0 ] || names=("${ALL[@]}")

if [ $mode != check ] && ! command -v gmsh >/dev/null; then
  echo "make_scenes.sh: gmsh not found (apt-get install gmsh); the committed .msh files need no gmsh" >&2
  exit 1
fi

status=0
for name in "${names[@]}"; do
  geo=scripts/geo/$name.geo
  msh=scenarios/$name.msh
  if [ $mode = tune ]; then
    python3 scripts/geo/tune_lc.py "$geo" "${TARGET[$name]}" --tol 0.01 --write || status=1
    continue
  fi
  if [ $mode = make ]; then
    echo "== $name: gmsh $(gmsh --version 2>&1) -> $msh (${FORMAT[$name]})"
    tmp=$(mktemp "scenarios/.$name.XXXXXX.msh")
    if ! gmsh -3 -nt 1 "$geo" -format "${FORMAT[$name]}" -o "$tmp" > "$tmp.log" 2>&1 \
        || grep -q '^Error' "$tmp.log"; then
      grep -E '^(Error|Warning)' "$tmp.log" >&2 || tail -20 "$tmp.log" >&2
      rm -f "$tmp" "$tmp.log"
      echo "make_scenes.sh: gmsh failed on $geo" >&2
      exit 1
    fi
    rm -f "$tmp.log"
    chmod 644 "$tmp"
    mv "$tmp" "$msh"
  fi
  python3 scripts/check_msh.py "$msh" --expect "${TARGET[$name]}" --tol 0.05 || status=1
  size=$(stat -c %s "$msh")
  if [ "$size" -gt 6500000 ]; then
    echo "make_scenes.sh: $msh is $size bytes (keep it under ~6 MB)" >&2
    status=1
  fi
done
[ $status = 0 ] && echo "make_scenes.sh: all scenes OK" || echo "make_scenes.sh: FAILED" >&2
exit $status
