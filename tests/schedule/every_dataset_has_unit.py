"""Checks that every dataset of an ebh output carries a `unit` attribute (docs/FORMATS.md,
"Replay output"): prints the ones without and exits 1, else prints how many were checked."""
import sys

import h5py

missing, seen = [], []


def visit(name, obj):
    if isinstance(obj, h5py.Dataset):
        seen.append(name)
        if "unit" not in obj.attrs:
            missing.append(name)


with h5py.File(sys.argv[1], "r") as f:
    f.visititems(visit)
if missing:
    print("datasets without a unit attribute: " + ", ".join(missing))
    sys.exit(1)
print(f"{len(seen)} datasets, each with a unit")
