"""The shapes of spmcal's dict results, as types (plain dicts at run time)."""

from typing import Optional, TypedDict, Union

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


class Pixels(TypedDict, total=False):
    """``Session.pixels``: each pixel a camera of the rig saw (``pixels.csv``), one row per marker
    per camera. A static session has ``pose`` (uint64 ids), a free-motion recording ``time_s`` (the
    capture's time on the camera's clock, s); ``marker`` indexes ``Session.marker_names``,
    ``camera`` ``Session.cameras``; ``uv`` is ``(k, 2)`` px, the top-left pixel's centre at
    (0, 0). Empty arrays for a session of points."""

    pose: npt.NDArray[np.uint64]
    time_s: npt.NDArray[np.float64]
    marker: npt.NDArray[np.int64]
    camera: npt.NDArray[np.int64]
    uv: npt.NDArray[np.float64]


class RigTerm(TypedDict):
    """One term of the rig: its value in ``cameras.yaml`` (``None`` for a pose's terms, which are
    changes only), the fit's change and its standard error (``None`` when held) in ``unit``
    (``px`` intrinsics, ``""`` distortion, ``deg`` rotations and the baseline's direction, ``mm`` a
    later camera's translation)."""

    name: str
    unit: str
    file_value: Optional[float]
    change: float
    std_error: Optional[float]
    held: bool


class RigTerms(TypedDict):
    """``Calibration.rig``: the report's refined rig — the first baseline's length held as the
    metric scale (m), every term, and each camera's pixel noise ``[camera, sigma_px, std_error_px]``."""

    baseline_held_m: float
    terms: list[RigTerm]
    pixel_noise_px: list[list[Union[str, float]]]
