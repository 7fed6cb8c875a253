#!/usr/bin/env python3
"""damage_heap.py IN.h5 OUT.h5: OUT is IN with the size of its HDF5 global heap's first object
(where the variable-length string attributes live: mode, scene, the datasets' unit) set to
2^64 - 1. HDF5 copies a string by that size without checking it against the file and crashes
(cli.metrics.damaged_heap). Standard library only."""
import sys

data = bytearray(open(sys.argv[1], "rb").read())
heap = data.find(b"GCOL")  # the global heap collection
if heap < 0:
    sys.exit(sys.argv[1] + ": no global heap (no string attributes?)")
# An object: u16 index, u16 reference count, u32 reserved, u64 size; the first at heap + 16.
data[heap + 24:heap + 32] = b"\xff" * 8
open(sys.argv[2], "wb").write(data)
