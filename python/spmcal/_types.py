"""The shapes of spmcal's dict results, as types (plain dicts at run time)."""

from typing import TypedDict

import numpy as np
import numpy.typing as npt


class ParametersTable(TypedDict):
    """``Calibration.parameters_table()``: one entry per parameter in each column, in the text
    report's units and order (``pandas.DataFrame(table)`` reads it as a table).

    ``value`` is the calibrated value (a link angle's or an offset's in degrees, the camera
    translation and the markers' positions in mm, the latency in ms, the camera clock's rate in ppm,
    a camera term unitless); an
    axis tilt or a rotation component is itself a departure, so its value is its change.
    ``change`` is the departure from the nominal model (link angles, offsets, tilts), from the
    starting registration (camera rotation and translation), from the model's marker positions,
    or from a perfect camera (scale 1, shear 0). ``std_error`` is NaN where the parameter was not
    fitted; ``status`` says why: ``fitted``, ``frozen``, ``at bound``, or for a camera term
    ``rigid`` or ``unidentifiable``. ``unit`` is ``deg``, ``mm``, ``ms``, ``ppm`` or ``""``
    (unitless).
    """

    name: list[str]
    value: list[float]
    change: list[float]
    std_error: list[float]
    unit: list[str]
    status: list[str]


class PoseErrors(TypedDict):
    """``Calibration.errors()``: each pose's error against the camera, as ``compare`` measures it,
    over the poses both models predict; ``unit`` is ``deg`` or ``mm``."""

    poses: npt.NDArray[np.uint64]
    nominal: npt.NDArray[np.float64]
    calibrated: npt.NDArray[np.float64]
    unit: str
