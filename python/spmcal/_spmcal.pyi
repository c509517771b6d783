"""Types of the native module (pyo3). Arrays: float64 unless said otherwise."""

import os
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]
_Array = npt.NDArray[np.float64]

__version__: str

class SpmcalError(Exception): ...
class FileError(SpmcalError): ...
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
    def from_params(params: _Path, urdf: Optional[_Path] = None) -> "Model": ...
    def forward(self, joints: _Array, matrices: bool = False) -> _Array:
        """(n, 3) or (3,) joint readings (rad) -> (n, 4) quaternions qw, qx, qy, qz (or (n, 3, 3))."""
    def ik(self, q: _Array) -> _Array:
        """(n, 4) or (4,) unit quaternions -> (n, 3) joint readings (rad), working mode."""
    def track(self, joints: _Array, previous: _Array) -> _Array:
        """The FDA along a stream, each row from the previous solution (the first from `previous`)."""
    def all_modes(self, joints: _Array) -> _Array:
        """Every assembly mode (<= 8) of one set of readings (3,): (k, 4) quaternions."""
    def jacobians(self, joints: _Array) -> _Array:
        """Forward Jacobians (n, 3, 3): joint rates -> MP angular velocity."""
    def conditioning(self, joints: _Array) -> Union[_Array, float]:
        """Conditioning index (n,) (a float for one row): 1 isotropic, 0 at a parallel singularity."""
    @property
    def marker_names(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def save(self, path: _Path) -> None: ...

class Session:
    """A session: static poses, sequential captures, a free-motion recording or a ROS 2 bag."""

    @staticmethod
    def load(path: _Path, model: Optional[_Path] = None) -> "Session": ...
    @staticmethod
    def from_arrays(
        joints: _Array,
        markers: _Array,
        marker_names: list[str],
        model: _Path,
        name: str = "arrays",
        poses: Optional[list[int]] = None,
        times: Optional[list[float]] = None,
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
    def save(self, path: _Path) -> None: ...
    def __len__(self) -> int: ...

class Calibration:
    """Calibrated parameters, report and covariance."""

    def to_dict(self) -> dict[str, Any]: ...
    @property
    def parameters(self) -> dict[str, Any]: ...
    @property
    def model(self) -> Model: ...
    @property
    def verdict(self) -> str: ...
    @property
    def passed(self) -> bool: ...
    @property
    def identifiability(self) -> dict[str, Any]: ...
    @property
    def parameter_names(self) -> list[str]: ...
    @property
    def covariance(self) -> _Array: ...
    @property
    def std_errors(self) -> dict[str, float]: ...
    @property
    def predicted_error_deg(self) -> Optional[float]: ...
    def errors(self) -> dict[str, Any]:
        """Per-pose errors against the camera: {"poses", "nominal", "calibrated", "unit"}."""
    def save(self, path: _Path) -> None: ...

def calibrate(
    session: Session,
    model: Optional[_Path] = None,
    config: Union[None, _Path, dict[str, Any]] = None,
    **overrides: Any,
) -> Calibration: ...
def compare(session: Session, params: list[_Path] = ..., model: Optional[_Path] = None) -> list[dict[str, Any]]: ...
def simulate(config: _Path, out: Optional[_Path] = None, seed: Optional[int] = None, poses: Optional[int] = None) -> Session: ...
def export(params: _Path, urdf: _Path, model: Optional[_Path] = None) -> list[str]: ...
def plan(
    poses: int,
    model: _Path = "models/agile_wrist.urdf",
    params: Optional[_Path] = None,
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
    joints: _Array,
    markers: list[int],
    marker_positions: _Array,
    camera_rotation: list[float],
    camera_translation: list[float],
    camera_model: str = "depth_scale",
    camera_terms: Optional[list[float]] = None,
) -> dict[str, Any]:
    """Private (an independent check's hook): the fit's marker-level model at `x` (None: the start)
    around `model`, the registration (qw, qx, qy, qz; t), the markers' positions (k, 3) and the
    camera model: {"names", "predictions" (m, 3), "orientations" (m, 3, 3), "jacobian" (m, 3, n),
    "information" (m, n, n), "whitening" (m, 3, 3), "actuated_dirs", "platform_dirs"}."""
