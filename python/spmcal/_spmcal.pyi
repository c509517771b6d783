"""Types of the native module (pyo3).

Array arguments take any array-like (``npt.ArrayLike``: lists, tuples, float32, ints, views), read
as ``np.asarray(x, dtype=float64)``; arrays returned are float64 unless said otherwise.
"""

import os
from pathlib import Path
from typing import Any, Iterable, Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

from ._types import ParametersTable, Pixels, PoseErrors, RigTerms

_Path = Union[str, "os.PathLike[str]"]
_Array = npt.NDArray[np.float64]
_ArrayLike = npt.ArrayLike
# Wherever a model is expected: a Model, a shipped model's name ("agile_wrist", "orbita3d"), or the
# path of a URDF.
_ModelLike = Union[_Path, "Model"]
# Wherever parameters are expected: a Model (its parameters), or the path of a parameters file.
_ParamsLike = Union[_Path, "Model"]

__version__: str

class SpmcalError(Exception): ...
class FileError(SpmcalError): ...
class ArrayError(FileError, ValueError):
    """An array argument numpy cannot read as numbers, or whose values cannot be used."""
class ShapeError(ArrayError):
    """An array argument of the wrong shape: names the argument, the shape expected and given."""
class ModelError(SpmcalError): ...
class KinematicsError(SpmcalError): ...
class ConfigError(SpmcalError): ...
class CalibrationError(SpmcalError): ...
class CompareError(SpmcalError): ...
class PlanError(SpmcalError): ...
class SimulationError(SpmcalError): ...

class Model:
    """A mechanism's kinematic model: a URDF's nominal one or a parameters file's."""

    @staticmethod
    def load(urdf: _Path) -> "Model": ...
    @staticmethod
    def from_params(params: _Path, urdf: Optional[_ModelLike] = None) -> "Model": ...
    def forward(self, joints: _ArrayLike, matrices: bool = False) -> _Array:
        """(n, 3) or (3,) joint readings (rad) -> (n, 4) quaternions qw, qx, qy, qz (or (n, 3, 3))."""
    def ik(self, q: _ArrayLike) -> _Array:
        """(n, 4) or (4,) unit quaternions -> (n, 3) joint readings (rad), working mode."""
    def track(self, joints: _ArrayLike, previous: _ArrayLike) -> _Array:
        """The FDA along a stream, each row from the previous solution (the first from `previous`)."""
    def all_modes(self, joints: _ArrayLike) -> _Array:
        """Every assembly mode (<= 8) of one set of readings (3,): (k, 4) quaternions."""
    def jacobians(self, joints: _ArrayLike) -> _Array:
        """Forward Jacobians (n, 3, 3): joint rates -> MP angular velocity."""
    def conditioning(self, joints: _ArrayLike) -> Union[_Array, float]:
        """Conditioning index (n,) (a float for one row): 1 isotropic, 0 at a parallel singularity."""
    @property
    def marker_names(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def save(self, path: _Path) -> None: ...

class Session:
    """A session: static poses, sequential captures, a free-motion recording or a ROS 2 bag."""

    @staticmethod
    def load(path: _Path, model: Optional[_ModelLike] = None) -> "Session": ...
    @staticmethod
    def from_arrays(
        joints: _ArrayLike,
        markers: _ArrayLike,
        marker_names: Sequence[str],
        model: _ModelLike,
        name: str = "arrays",
        poses: Optional[_ArrayLike] = None,
        times: Optional[_ArrayLike] = None,
    ) -> "Session": ...
    @property
    def name(self) -> str: ...
    @property
    def kind(self) -> str: ...
    @property
    def model(self) -> str: ...
    @property
    def marker_names(self) -> list[str]: ...
    @property
    def poses(self) -> npt.NDArray[np.uint64]: ...
    @property
    def joints(self) -> _Array: ...
    @property
    def markers(self) -> _Array: ...
    @property
    def times(self) -> _Array: ...
    @property
    def cameras(self) -> list[str]:
        """The rig's camera names (cameras.yaml) of a session seen through its pixels; [] for points."""
    @property
    def pixels(self) -> Pixels:
        """Each pixel a camera saw: {"pose" (k,) uint64 | "time_s" (k,), "marker", "camera" (k,) int64, "uv" (k, 2) px}."""
    def save(self, path: _Path) -> None: ...
    def __len__(self) -> int: ...

class Calibration:
    """Calibrated parameters, report and covariance. ``str(calibration)`` is the text report."""

    def to_dict(self) -> dict[str, Any]:
        """The report as `spmcal calibrate --json` gives it (`results`)."""
    @property
    def parameters(self) -> dict[str, Any]:
        """The calibrated parameters file's content."""
    @property
    def model(self) -> Model: ...
    @property
    def verdict(self) -> Literal["PASS", "WARN", "FAIL"]:
        """The report's verdict word, about the mechanism (the camera's noise is reported beside it)."""
    @property
    def verdict_reason(self) -> str:
        """The verdict's sentence, as the report prints it after the word."""
    @property
    def verdict_reasons(self) -> list[dict[str, str]]:
        """Why it is not a pass: each reason's `level` (WARN or FAIL), `finding` and `action`."""
    @property
    def model_check(self) -> dict[str, Any] | None:
        """Whether the residuals are what the noise model says: `passed`, `statistic`, `p_value`,
        `tests`, and for a failed check its `cause`, `finding` and `action`."""
    @property
    def passed(self) -> bool:
        """`verdict == "PASS"`."""
    @property
    def identifiability(self) -> dict[str, Any]: ...
    @property
    def parameter_names(self) -> list[str]:
        """The parameter vector's names, in the covariance's order."""
    @property
    def parameter_units(self) -> list[str]:
        """The parameter vector's units, in the covariance's order: "rad", "m", "s" or "" (unitless)."""
    @property
    def covariance(self) -> _Array:
        """(p, p), in `parameter_units` (zero rows for held parameters)."""
    @property
    def std_errors(self) -> dict[str, float]:
        """Fitted parameters' standard errors in `parameter_units`, in the covariance's order."""
    @property
    def predicted_error_deg(self) -> Optional[float]: ...
    def parameters_table(self) -> ParametersTable:
        """The parameters as the text report shows them (deg, mm, ms), one row each, as columns."""
    def errors(self) -> PoseErrors:
        """Per-pose errors against the camera: {"poses", "nominal", "calibrated", "unit"}."""
    @property
    def rig(self) -> Optional[RigTerms]:
        """The camera rig refined with the mechanism, as the report gives it; None for points."""
    def write_cameras(self, path: _Path) -> None:
        """Write the refined rig as a Kalibr camchain, as `spmcal calibrate --cameras-out`."""
    def save(self, path: _Path) -> None: ...

class Exported:
    """What `export` wrote."""

    @property
    def urdf(self) -> Path: ...
    @property
    def companion(self) -> Path:
        """The companion beside the URDF (NAME.yaml): markers, camera model, provenance."""
    @property
    def warnings(self) -> list[str]:
        """What the user should be told (also comments in both files)."""

def calibrate(
    session: Session,
    model: Optional[_ModelLike] = None,
    config: Union[None, _Path, dict[str, Any]] = None,
    **overrides: Any,
) -> Calibration: ...
def compare(
    session: Session,
    params: Union[None, _ParamsLike, Iterable[_ParamsLike]] = None,
    model: Optional[_ModelLike] = None,
) -> list[dict[str, Any]]: ...
def simulate(config: _Path, out: Optional[_Path] = None, seed: Optional[int] = None, poses: Optional[int] = None) -> Session: ...
def export(params: _ParamsLike, urdf: _Path, model: Optional[_ModelLike] = None) -> Exported: ...
def plan(
    poses: int,
    model: Optional[_ModelLike] = None,
    params: Optional[_ParamsLike] = None,
    config: Optional[_Path] = None,
    candidates: int = 2000,
    margin_deg: float = 2.0,
    camera_model: str = "depth_scale",
    augment: Optional[Session] = None,
) -> tuple[dict[str, Any], _Array, _Array]:
    """Plan `poses` poses as `spmcal plan`: (summary, (poses, 4) quaternions, (poses, 3) joints)."""
def _marker_model(
    model: Model,
    x: Optional[list[float]],
    joints: _ArrayLike,
    markers: list[int],
    marker_positions: _ArrayLike,
    camera_rotation: list[float],
    camera_translation: list[float],
    camera_model: str = "depth_scale",
    camera_terms: Optional[list[float]] = None,
) -> dict[str, Any]:
    """Private (an independent check's hook): the fit's marker-level model at `x` (None: the start)
    around `model`, the registration (qw, qx, qy, qz; t), the markers' positions (k, 3) and the
    camera model: {"names", "predictions" (m, 3), "orientations" (m, 3, 3), "jacobian" (m, 3, n),
    "information" (m, n, n), "whitening" (m, 3, 3), "actuated_dirs", "platform_dirs"}."""
