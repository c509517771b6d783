"""spmcal: calibration of spherical parallel manipulators from joint readings and camera markers.

The same nouns as the Rust library and the same errors as the command line::

    import spmcal
    session = spmcal.Session.load("datasets/agile_wrist_sim_400")
    calibration = spmcal.calibrate(session)
    print(calibration.predicted_error_deg)
    calibration.save("params.yaml")
    q = calibration.model.forward(session.joints)        # (n, 4) quaternions qw, qx, qy, qz

Arrays are numpy: joints ``(n, 3)`` in rad, quaternions ``(n, 4)`` scalar first, matrices
``(n, 3, 3)``, markers ``(n, m, 3)`` in m (NaN where unseen). An array argument may be any
array-like (a list, a tuple, float32, ints, a view), read as ``np.asarray(x, dtype=float64)``; a
wrong shape raises ``ShapeError``, values numpy cannot read ``ArrayError`` (both ``ValueError``s).
Wherever a model is expected, a ``Model`` or a URDF's path; wherever parameters are, a ``Model`` or
a parameters file's path. ``str(calibration)`` is the text report, ``calibration.verdict`` its
word (``PASS``/``WARN``), ``calibration.parameters_table()`` its parameters in its units.

Every error is a ``SpmcalError`` (``FileError`` with ``ArrayError`` and ``ShapeError``,
``ModelError``, ``KinematicsError``, ``ConfigError``, ``CalibrationError``, ``CompareError``,
``PlanError``, ``SimulationError``) whose one-line message names the file, line or argument and
the reason. Long calls (``calibrate``, ``simulate``, ``plan``) release the GIL and honour Ctrl-C.
"""

from ._spmcal import (
    ArrayError,
    CalibrationError,
    Calibration,
    CompareError,
    ConfigError,
    Exported,
    FileError,
    KinematicsError,
    Model,
    ModelError,
    PlanError,
    Session,
    ShapeError,
    SimulationError,
    SpmcalError,
    __version__,
    calibrate,
    compare,
    export,
    plan,
    simulate,
)
from ._types import ParametersTable, Pixels, PoseErrors, RigTerm, RigTerms

__all__ = [
    "ArrayError",
    "Calibration",
    "CalibrationError",
    "CompareError",
    "ConfigError",
    "Exported",
    "FileError",
    "KinematicsError",
    "Model",
    "ModelError",
    "ParametersTable",
    "Pixels",
    "PlanError",
    "PoseErrors",
    "RigTerm",
    "RigTerms",
    "Session",
    "ShapeError",
    "SimulationError",
    "SpmcalError",
    "__version__",
    "calibrate",
    "compare",
    "export",
    "plan",
    "simulate",
]
