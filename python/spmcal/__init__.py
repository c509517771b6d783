"""spmcal: calibration of spherical parallel manipulators from joint readings and camera markers.

The same nouns as the Rust library and the same errors as the command line::

    import spmcal
    session = spmcal.Session.load("datasets/agile_wrist_sim_400")
    calibration = spmcal.calibrate(session)
    print(calibration.predicted_error_deg)
    calibration.save("params.yaml")
    q = calibration.model.forward(session.joints)        # (n, 4) quaternions qw, qx, qy, qz

Arrays are numpy: joints ``(n, 3)`` in rad, quaternions ``(n, 4)`` scalar first, matrices
``(n, 3, 3)``, markers ``(n, m, 3)`` in m (NaN where unseen). Every error is a ``SpmcalError``
(``FileError``, ``ModelError``, ``KinematicsError``, ``ConfigError``, ``CalibrationError``,
``CompareError``, ``PlanError``, ``SimulationError``) whose message names the file, line and reason.
Long calls (``calibrate``, ``simulate``, ``plan``) release the GIL and honour Ctrl-C.
"""

from ._spmcal import (
    CalibrationError,
    Calibration,
    CompareError,
    ConfigError,
    FileError,
    KinematicsError,
    Model,
    ModelError,
    PlanError,
    Session,
    SimulationError,
    SpmcalError,
    __version__,
    calibrate,
    compare,
    export,
    plan,
    simulate,
)

__all__ = [
    "Calibration",
    "CalibrationError",
    "CompareError",
    "ConfigError",
    "FileError",
    "KinematicsError",
    "Model",
    "ModelError",
    "PlanError",
    "Session",
    "SimulationError",
    "SpmcalError",
    "__version__",
    "calibrate",
    "compare",
    "export",
    "plan",
    "simulate",
]
