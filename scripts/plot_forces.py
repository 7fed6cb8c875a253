#!/usr/bin/env python3
"""Force and torque of one or more replays over time, like Figure 7 of the paper.

    scripts/plot_forces.py a.h5 [b.h5 ...] -o forces.png [--labels A B ...] [--t0 S] [--t1 S]

A grid of eight panels: rows x, y, z and magnitude; columns force (N) and torque (N m). Each
replay output (docs/FORMATS.md, "Replay output": /haptic/t, /haptic/force, /haptic/torque, optional
/haptic/force_clamped) is one colour; ticks where the force was clamped at the device limit are
marked with a cross on the force-magnitude panel. Labels default to the file names.

Needs Debian's python3-matplotlib, python3-h5py and python3-numpy (scripts/setup.sh installs
them); when `python3` on PATH is another interpreter, run it as /usr/bin/python3.
"""
import argparse
import math
import os
import sys
import tempfile

try:
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as e:  # pragma: no cover - depends on the machine
    sys.exit(f"plot_forces.py: {e.name} is missing: install python3-matplotlib python3-h5py python3-numpy "
             "(Debian) or run with /usr/bin/python3")


class InputError(Exception):
    pass


def read(path, name, ncols=None):
    """Dataset `name` of file `path` as a float array, shape (N,) or (N, ncols)."""
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise InputError(f"{path}: cannot open as HDF5 ({e.strerror or e})")
    with f:
        if name not in f:
            raise InputError(f"{path}: dataset '{name}' missing")
        a = np.asarray(f[name][()], dtype=float)
    if ncols is not None and (a.ndim != 2 or a.shape[1] != ncols):
        raise InputError(f"{path}: dataset '{name}' has shape {a.shape}, expected (N,{ncols})")
    if ncols is None and a.ndim != 1:
        raise InputError(f"{path}: dataset '{name}' has shape {a.shape}, expected (N)")
    return a


def load(path):
    try:
        with h5py.File(path, "r") as f:
            if "/haptic" not in f and "/trajectory" in f:
                raise InputError(f"{path}: a device recording (/trajectory), not a replay output (/haptic): replay it "
                                 f"first (ebh replay SCENE {path} -o OUT.h5)")
    except OSError as e:
        raise InputError(f"{path}: cannot open as HDF5 ({e.strerror or e})")
    t = read(path, "/haptic/t")
    force = read(path, "/haptic/force", 3)
    torque = read(path, "/haptic/torque", 3)
    for name, a in (("/haptic/force", force), ("/haptic/torque", torque)):
        if len(a) != len(t):
            raise InputError(f"{path}: dataset '{name}' has {len(a)} rows, /haptic/t has {len(t)}")
    with h5py.File(path, "r") as f:
        clamped = np.asarray(f["/haptic/force_clamped"][()], dtype=bool) if "/haptic/force_clamped" in f else None
    if clamped is not None and clamped.shape != t.shape:
        raise InputError(f"{path}: dataset '/haptic/force_clamped' has shape {clamped.shape}, expected ({len(t)})")
    return t, force, torque, clamped


def plot(paths, labels, out, t0=None, t1=None, title=None):
    fig, axes = plt.subplots(4, 2, figsize=(11, 8.5), sharex=True)
    rows = ["x", "y", "z", "magnitude"]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (path, label) in enumerate(zip(paths, labels)):
        t, force, torque, clamped = load(path)
        keep = np.ones(len(t), dtype=bool)
        if t0 is not None:
            keep &= t >= t0
        if t1 is not None:
            keep &= t <= t1
        if not keep.any():
            raise InputError(f"{path}: no ticks between --t0 and --t1")
        c = colors[i % len(colors)]
        for col, data in enumerate((force, torque)):
            series = [data[:, 0], data[:, 1], data[:, 2], np.linalg.norm(data, axis=1)]
            for row, y in enumerate(series):
                axes[row, col].plot(t[keep], y[keep], color=c, lw=0.9, label=label if (row, col) == (0, 0) else None)
        if clamped is not None and (clamped & keep).any():
            sel = clamped & keep
            axes[3, 0].plot(t[sel], np.linalg.norm(force, axis=1)[sel], "x", color=c, ms=4,
                            label=f"{label}: at force limit ({sel.sum()} ticks)")
    for row, name in enumerate(rows):
        unit_f, unit_t = "N", "N m"
        axes[row, 0].set_ylabel(f"force {name} ({unit_f})" if name != "magnitude" else f"|F| ({unit_f})")
        axes[row, 1].set_ylabel(f"torque {name} ({unit_t})" if name != "magnitude" else f"|T| ({unit_t})")
        for col in range(2):
            axes[row, col].grid(True, lw=0.3)
    for col in range(2):
        axes[3, col].set_xlabel("time (s)")
    axes[0, 0].legend(loc="best", fontsize=8)
    if axes[3, 0].get_legend_handles_labels()[0]:
        axes[3, 0].legend(loc="best", fontsize=8)
    fig.suptitle(title or "Force and torque on the tool")
    fig.tight_layout()
    # Written beside its name and renamed over it: an interrupt or a full disk keeps what was there.
    folder = os.path.dirname(os.path.abspath(out))
    fd, temp = tempfile.mkstemp(prefix="." + os.path.basename(out) + ".", suffix=".partial", dir=folder)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temp, 0o666 & ~umask)  # as a file opened for writing gets it, not mkstemp's 0600
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, dpi=130, format="png")
        os.replace(temp, out)
    except BaseException:
        os.unlink(temp)
        raise
    finally:
        plt.close(fig)


def check_output(out, inputs):
    """The PNG to write: a .png name in an existing folder, not one of the replays."""
    if not out.lower().endswith(".png"):
        raise InputError(f"{out}: the plot is a PNG file: name it NAME.png")
    folder = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(folder):
        raise InputError(f"{out}: the folder {folder} does not exist")
    for path in inputs:
        if os.path.exists(out) and os.path.exists(path) and os.path.samefile(out, path):
            raise InputError(f"{out}: is the replay {path}, an input; choose another output file")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("replays", nargs="+", help="replay outputs (HDF5)")
    p.add_argument("-o", "--output", default="forces.png", help="PNG to write (default forces.png)")
    p.add_argument("--labels", nargs="+", help="one label per replay (default: file names)")
    p.add_argument("--t0", type=float, help="first time shown (s)")
    p.add_argument("--t1", type=float, help="last time shown (s)")
    p.add_argument("--title", help="figure title")
    a = p.parse_args(argv)
    labels = a.labels or [os.path.basename(r) for r in a.replays]
    if len(labels) != len(a.replays):
        p.error(f"--labels gives {len(labels)} labels for {len(a.replays)} replays")
    for name, v in (("--t0", a.t0), ("--t1", a.t1)):
        if v is not None and not math.isfinite(v):
            print(f"plot_forces.py: error: {name} {v}: expected a finite time in s", file=sys.stderr)
            return 1
    if a.t0 is not None and a.t1 is not None and a.t1 <= a.t0:
        p.error("--t1 must be after --t0")
    try:
        check_output(a.output, a.replays)
        plot(a.replays, labels, a.output, a.t0, a.t1, a.title)
    except InputError as e:
        print(f"plot_forces.py: error: {e}", file=sys.stderr)
        return 1
    print(a.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
