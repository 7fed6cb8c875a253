#!/usr/bin/env python3
"""Finds the characteristic length lc (mm) of a scene .geo that gives a target tet count.

  scripts/geo/tune_lc.py scripts/geo/tube.geo 8068 [--tol 0.02] [--write]

The tet count falls roughly as lc^-3 but in steps (Delaunay and optimisation are not
continuous), so this is a bisection on log(lc) seeded by the power law, stopping at the first
lc within --tol of the target. With --write the lc default in the .geo (the line after
'If (!Exists(lc))') is replaced by the lc found, so scripts/make_scenes.sh reproduces it.
Runs gmsh single-threaded with the options of make_scenes.sh.
"""
import argparse
import math
import re
import subprocess
import sys
import tempfile


def count_tets(geo, lc, gmsh="gmsh"):
    with tempfile.NamedTemporaryFile(suffix=".msh") as out:
        subprocess.run([gmsh, "-3", "-nt", "1", geo, "-setnumber", "lc", repr(lc),
                        "-format", "msh41", "-o", out.name],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        n = 0
        with open(out.name) as f:
            for line in f:
                if line.startswith("$Elements"):
                    nblocks = int(next(f).split()[0])
                    for _ in range(nblocks):
                        _, _, etype, count = (int(x) for x in next(f).split())
                        for _ in range(count):
                            next(f)
                        if etype == 4:
                            n += count
                    break
        return n


def current_lc(geo):
    m = re.search(r"If \(!Exists\(lc\)\)\s*\n\s*lc = ([0-9.eE+-]+);", open(geo).read())
    if not m:
        sys.exit(f"{geo}: no 'If (!Exists(lc))' default found")
    return float(m.group(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("geo")
    ap.add_argument("target", type=int)
    ap.add_argument("--tol", type=float, default=0.02)
    ap.add_argument("--max-runs", type=int, default=20)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()

    lc = current_lc(args.geo)
    lo = hi = None  # lo: lc giving too many tets; hi: lc giving too few
    best = None
    for run in range(args.max_runs):
        n = count_tets(args.geo, lc)
        dev = n / args.target - 1.0
        print(f"  lc {lc:.5f}: {n} tets ({100 * dev:+.2f}%)", flush=True)
        if best is None or abs(dev) < abs(best[2]):
            best = (lc, n, dev)
        if abs(dev) <= args.tol:
            break
        if n > args.target:
            lo = lc
        else:
            hi = lc
        if lo is not None and hi is not None:
            lc = math.sqrt(lo * hi)
        else:
            lc = lc * (n / args.target) ** (1.0 / 3.0)
    lc, n, dev = best
    print(f"{args.geo}: lc = {lc:.5f} -> {n} tets ({100 * dev:+.2f}% vs {args.target})")
    # Robustness: a neighbouring lc (another gmsh build rounds differently) should stay close.
    for f in (0.997, 1.003):
        nn = count_tets(args.geo, round(lc, 5) * f)
        print(f"  check lc x {f}: {nn} tets ({100 * (nn / args.target - 1):+.2f}%)")
    if args.write:
        text = open(args.geo).read()
        text = re.sub(r"(If \(!Exists\(lc\)\)\s*\n\s*lc = )[0-9.eE+-]+;", rf"\g<1>{lc:.5f};", text)
        open(args.geo, "w").write(text)
    return 0 if abs(dev) <= args.tol else 1


if __name__ == "__main__":
    sys.exit(main())
