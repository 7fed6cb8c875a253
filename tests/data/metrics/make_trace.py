#!/usr/bin/env python3
"""Writes tests/data/metrics/press.h5, the small replay trace the `ebh metrics` CLI tests read.

A synthetic 0.4 s press at 1 kHz haptic / 100 Hz physical in the replay output layout
(docs/FORMATS.md, "Replay output"): the physical tool moves down 1 cm/s, touches at tick 100, the force rises
smoothly to 1.5 N with a 20 mN jump at each physical frame, contact ends at tick 350. Regenerate:

    /usr/bin/python3 tests/data/metrics/make_trace.py

Needs numpy and h5py (Debian python3-numpy, python3-h5py). Deterministic: no random numbers.
"""
import os

import h5py
import numpy as np

H, P, N = 1000.0, 100.0, 400
t = np.arange(N) / H
contact = (np.arange(N) >= 100) & (np.arange(N) < 350)
s = np.clip((t - 0.1) / 0.25, 0.0, 1.0)
fz = np.where(contact, 1.5 * np.sin(np.pi * s) ** 2 + 0.02 * ((np.arange(N) // 10) % 2), 0.0)
force = np.stack([0.1 * fz, 0.0 * fz, fz], axis=1)
torque = np.stack([0.0 * fz, 0.002 * fz, 0.0 * fz], axis=1)
pos = np.stack([0.0 * t, 0.0 * t, 0.02 - 0.01 * t], axis=1)
quat = np.tile([1.0, 0.0, 0.0, 0.0], (N, 1))
k_vcs = 500.0  # N/m: the virtual tool sits F / k above the physical tool
pose_physical = np.hstack([pos, quat])
pose_virtual = np.hstack([pos + force / k_vcs, quat])
penetration = np.where(contact, 1e-4 * fz / 1.5, 0.0)
penetration_physical = np.where(contact, 0.01 * (t - 0.1), 0.0)
step = 1e-4 + 2e-5 * np.cos(np.arange(N))
step[123] = 1.5e-3  # one tick over the 1 ms budget

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "press.h5")
with h5py.File(out, "w") as f:
    f.attrs.update(scene="synthetic", recording="synthetic press", mode="async", backend="cpu",
                   version="0.1.0", haptic_hz=H, physical_hz=P,
                   generator="tests/data/metrics/make_trace.py")
    gz = dict(compression="gzip", shuffle=True)
    f.create_dataset("haptic/t", data=t, **gz)
    f.create_dataset("haptic/force", data=force, **gz)
    f.create_dataset("haptic/torque", data=torque, **gz)
    f.create_dataset("haptic/force_clamped", data=np.zeros(N, np.uint8), **gz)
    f.create_dataset("haptic/pose_physical", data=pose_physical, **gz)
    f.create_dataset("haptic/pose_virtual", data=pose_virtual, **gz)
    f.create_dataset("haptic/penetration", data=penetration, **gz)
    f.create_dataset("haptic/penetration_physical", data=penetration_physical, **gz)
    f.create_dataset("haptic/contacts", data=np.where(contact, 4, 0).astype(np.int32), **gz)
    K = int(N * P / H)
    f.create_dataset("physical/t", data=np.arange(K) / P)
    f.create_dataset("physical/iterations", data=np.full(K, 20, np.int32))
    f.create_dataset("physical/residual", data=np.full(K, 1e-6))
    f.create_dataset("timing/haptic_step_s", data=step, **gz)
    f.create_dataset("timing/physical_step_s", data=np.full(K, 4e-3))
print(out)
