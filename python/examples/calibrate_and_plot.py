"""Calibrate a shipped session from Python and plot each pose's error before and after.

Run from the repository root (after ``pip install ./python``)::

    python python/examples/calibrate_and_plot.py            # writes errors_before_after.png

Notebook-style: each block is a cell.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display needed; in a notebook, drop this line
import matplotlib.pyplot as plt
import numpy as np

import spmcal

# %% Load a session (a folder, an .mcap bag, or arrays via Session.from_arrays).
session = spmcal.Session.load("datasets/agile_wrist_sim_400")
print(session, session.joints.shape, session.markers.shape)

# %% Calibrate (settings as in `calibrate --config`, here one override), then look at the result.
calibration = spmcal.calibrate(session, camera_model="depth_scale")
print(calibration)  # the text report, as `spmcal calibrate` prints it
print("verdict:", calibration.verdict, "-", calibration.verdict_reason)  # PASS or WARN, and why
print(f"predicted error on unseen poses: {calibration.predicted_error_deg:.4f} deg")

# %% The parameters in the report's units (deg, mm, ms): columns for pandas.DataFrame(table).
table = calibration.parameters_table()
for name, change, std_error, unit in list(zip(table["name"], table["change"], table["std_error"], table["unit"]))[:5]:
    print(f"  {name}: {change:+.4f} ± {std_error:.4f} {unit}")

# %% Each pose's error against the camera, nominal and calibrated model.
errors = calibration.errors()
order = np.argsort(errors["nominal"])
fig, ax = plt.subplots(figsize=(8, 4))
ax.plot(errors["nominal"][order], label=f"nominal (RMS {np.sqrt(np.mean(errors['nominal'] ** 2)):.3f})")
ax.plot(errors["calibrated"][order], label=f"calibrated (RMS {np.sqrt(np.mean(errors['calibrated'] ** 2)):.3f})")
ax.set_xlabel("pose (sorted by nominal error)")
ax.set_ylabel(f"error against the camera ({errors['unit']})")
ax.set_title(f"{session.name}: before and after calibration")
ax.legend()
out = Path("errors_before_after.png")
fig.savefig(out, dpi=120, bbox_inches="tight")
print("wrote", out)

# %% The calibrated model in a control loop: orientations of the session's joint readings.
q = calibration.model.forward(session.joints)
print("first orientation (qw, qx, qy, qz):", q[0])
calibration.save("params_from_python.yaml")
