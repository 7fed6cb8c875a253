#!/usr/bin/env python3
"""Run time against force error: one replay per value of a scene key, each compared with a reference.

    scripts/sweep.py SCENE RECORDING --key solver.virtual_iterations --values 1,2,3,4,8,32
        [--reference 32] [--backend cuda] [--ebh build/ebh] [--keep DIR] [-- EXTRA ebh replay ARGS]

Replays RECORDING in SCENE once per value (`ebh replay ... --set KEY=VALUE`), then prints a
Markdown table, one row per value: the replay's real-time factor (its summary line), how far its
force is from the reference replay's, tick by tick (max and RMS of |F - F_ref|, N), and the force
metrics of `ebh metrics` (docs/METRICS.md): peak |F|, max force rate, RMS force step. The
reference is the last value unless --reference names one of them. Arguments after `--` go to every
`ebh replay` (e.g. `-- --duration 2 --mode lockstep`). Exits 1 with one line when a replay fails
(its error) or the replays' ticks differ in number.

Needs numpy and h5py (Debian: python3-numpy python3-h5py; scripts/setup.sh installs them).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

try:
    import h5py
    import numpy as np
except ImportError as e:  # pragma: no cover - depends on the machine
    sys.exit(f"sweep.py: {e.name} is missing: install python3-h5py python3-numpy (Debian) or run with /usr/bin/python3")

REAL_TIME = re.compile(r"wall: ([0-9.]+)x real time")


class SweepError(Exception):
    pass


def run(cmd):
    """Runs cmd; its stdout, or SweepError with ebh's last error line."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        lines = [l for l in (p.stderr + p.stdout).splitlines() if l.strip()]
        raise SweepError(lines[-1] if lines else f"{cmd[0]} exited with {p.returncode}")
    return p.stdout + p.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("recording")
    ap.add_argument("--key", required=True, help="scene key, as for ebh replay --set")
    ap.add_argument("--values", required=True, help="comma-separated values of the key")
    ap.add_argument("--reference", help="the value whose replay the others are compared with (default: the last)")
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--ebh", default="build/ebh", help="the ebh binary")
    ap.add_argument("--keep", help="write the replays here (default: a temporary folder, removed)")
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []  # more ebh replay arguments
    a = ap.parse_args(argv[:len(argv) - len(extra) - (1 if "--" in argv else 0)])
    values = [v.strip() for v in a.values.split(",") if v.strip()]
    if not values:
        sys.exit("sweep.py: --values: no value given")
    reference = a.reference if a.reference is not None else values[-1]
    if reference not in values:
        sys.exit(f"sweep.py: --reference {reference}: not one of --values {a.values}")
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = a.keep or tmp
        os.makedirs(out_dir, exist_ok=True)
        try:
            rows = {}
            for v in values:
                path = os.path.join(out_dir, f"sweep_{re.sub(r'[^A-Za-z0-9_.-]', '_', a.key)}_{v}.h5")
                log = run([a.ebh, "replay", a.scene, a.recording, "-o", path, "--backend", a.backend,
                           "--set", f"{a.key}={v}", *extra])
                m = REAL_TIME.search(log)
                metrics = json.loads(run([a.ebh, "metrics", "--json", path]))["whole"]
                with h5py.File(path, "r") as f:
                    force = f["haptic/force"][:]
                rows[v] = (float(m.group(1)) if m else float("nan"), metrics, force)
            ref = rows[reference][2]
            print(f"{a.scene} + {a.recording}, {a.backend}: {a.key} (reference {reference})\n")
            print(f"| {a.key} | real time | max abs(F - F_ref) (N) | RMS (N) | peak abs(F) (N) | max force rate (N/s) | RMS force step (N) |")
            print("|---|---|---|---|---|---|---|")
            for v in values:
                rt, metrics, force = rows[v]
                if force.shape != ref.shape:
                    raise SweepError(f"{a.key}={v}: {len(force)} ticks against the reference's {len(ref)}")
                d = np.linalg.norm(force - ref, axis=1)
                rms = float(np.sqrt(np.mean(d * d))) if len(d) else 0.0
                print(f"| {v} | {rt:.2f}x | {d.max(initial=0.0):.4g} | {rms:.4g} | {metrics['peak_force_N']:.4g} | "
                      f"{metrics['max_force_rate_N_per_s']:.4g} | {metrics['rms_force_step_N']:.4g} |")
        except SweepError as e:
            sys.exit(f"sweep.py: {e}")


if __name__ == "__main__":
    main()
