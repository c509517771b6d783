"""model.forward on 100,000 joint readings from Python, against the Rust loop it wraps.

Run from the repository root: ``python python/benchmarks/forward_batch.py``. The Rust figure is
criterion's `forward_batch_100k` (benches/kinematics.rs); this prints the Python call's best of 7.
"""

import time

import numpy as np

import spmcal

model = spmcal.Model.load("models/agile_wrist.urdf")
rng = np.random.default_rng(1)
rotvec = rng.uniform(-0.3, 0.3, size=(100_000, 3))
angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * rotvec / angle])
joints = model.ik(q)
best = float("inf")
for _ in range(7):
    start = time.perf_counter()
    model.forward(joints)
    best = min(best, time.perf_counter() - start)
print(f"model.forward, 100,000 readings: {best * 1e3:.1f} ms ({best * 1e1:.2f} us per reading)")
