"""An independent reference of the marker-level observation model, in numpy (issue 32).

Written from ``docs/conventions.md``'s conventions and ``docs/calibration.md``'s camera model alone,
not from the library's code; the library is asked only what its parameter vector is (the names,
their order, and the gauge's tilt directions: ``spmcal._spmcal._marker_model``).

Conventions (docs/conventions.md, "Kinematic conventions"):

- leg i: actuated axis ``u``, zero direction ``z`` (orthogonal to ``u``), link angles ``α1``,
  ``α2``, platform axis ``v0`` (in P), encoder offset ``δ``; ``φ = θ + δ`` (joint scale 1);
  intermediate axis ``w(θ) = cos α1 u + sin α1 (cos φ z + sin φ (u × z))``;
- loop closure ``w_i(θ_i) · R v0_i = cos α2_i``, ``R`` mapping P to B;
- working mode: each leg keeps its home branch, the sign of ``(u × w) · v`` at ``R = I``; the FDA
  is the assembly mode continuously connected to home, followed here along the straight
  joint-space path from the home readings (the IK of ``R = I``);
- a marker at ``p`` in P is seen at ``K (R_CB R p + t_CB)`` in the camera frame, ``K`` the camera
  model (``rigid``: ``I``; ``depth_scale``: ``diag(1, 1, s)``; ``affine``:
  ``[[1, k_xy, k_xz], [k_xy, s_y, k_yz], [k_xz, k_yz, s]]``).

The parameter vector (the fit's, measured from its start): per leg the axis tilts (rotation
vectors ``Σ x_k d_k`` applied to the start's ``u`` and ``v0``; ``z`` re-orthogonalised against the
moved ``u``), ``α1``, ``α2``, ``δ`` added to the start's; ``R_CB = exp(c) R_CB⁰``; ``t_CB``, marker
positions and camera terms added to the start's.

The Jacobian is analytic: implicit differentiation of the closure equations for the FDA (with
``R ← exp(ε) R``, ``∂f_i/∂ε = (v_i × w_i)ᵀ``, so ``dε = −A⁻¹ ∂f/∂x``) and complex-step
differentiation (exact to rounding) of every explicit map — the geometry from the parameters,
the closure at a fixed ``R``, the camera point at a fixed ``R``. ``finite_difference_jacobian``
differentiates the whole reference numerically, to check the reference against itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Optional, Sequence

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[Any]

CAMERA_TERMS = ("depth_scale", "scale_y", "shear_xy", "shear_xz", "shear_yz")
PERFECT_TERMS = np.array([1.0, 1.0, 0.0, 0.0, 0.0])
COMPLEX_STEP = 1e-30


class ReferenceError(Exception):
    """A pose the reference cannot solve on the working mode (out of reach, near a singularity)."""


def cross(a: Any, b: Any) -> Array:
    """``a × b`` along the last axis, broadcasting (numpy's ``cross`` is slow on small arrays)."""
    a, b = np.asarray(a), np.asarray(b)
    out: Array = np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                           a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                           a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)
    return out


def hat(a: Array) -> Array:
    """``[a]×`` for ``(..., 3)`` vectors: ``(..., 3, 3)``."""
    out = np.zeros(a.shape[:-1] + (3, 3), dtype=a.dtype)
    out[..., 0, 1], out[..., 0, 2] = -a[..., 2], a[..., 1]
    out[..., 1, 0], out[..., 1, 2] = a[..., 2], -a[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -a[..., 1], a[..., 0]
    return out


def expm(phi: Array) -> Array:
    """Rotation matrix of rotation vectors ``(..., 3)`` (Rodrigues); complex-step safe (no abs)."""
    phi = np.asarray(phi)
    t2 = np.sum(phi * phi, axis=-1)
    small = np.abs(t2) < 1e-10
    t2_safe = np.where(small, 1.0, t2)
    t = np.sqrt(t2_safe)
    a = np.where(small, 1 - t2 / 6 + t2 * t2 / 120, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 + t2 * t2 / 720, (1 - np.cos(t)) / t2_safe)
    k = hat(phi)
    eye = np.broadcast_to(np.eye(3), k.shape)
    out: Array = eye + a[..., None, None] * k + b[..., None, None] * (k @ k)
    return out


def log_rotation(r: Array) -> Array:
    """Rotation vector of rotation matrices ``(..., 3, 3)`` (angles below π)."""
    c = np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    angle = np.arccos(c)
    v = np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]], axis=-1)
    s = np.sin(angle)
    scale = np.where(angle < 1e-8, 0.5 + angle**2 / 12, angle / (2 * np.where(s == 0, 1.0, s)))
    out: Array = v * scale[..., None]
    return out


def matrix_quaternion(r: Array) -> Array:
    """``qw, qx, qy, qz`` (``qw ≥ 0``) of a rotation matrix (Shepperd's method)."""
    t = np.trace(r)
    candidates = [t, r[0, 0], r[1, 1], r[2, 2]]
    i = int(np.argmax(candidates))
    if i == 0:
        s = math.sqrt(1 + t) * 2
        q = [s / 4, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    elif i == 1:
        s = math.sqrt(1 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        q = [(r[2, 1] - r[1, 2]) / s, s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
    elif i == 2:
        s = math.sqrt(1 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        q = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s]
    else:
        s = math.sqrt(1 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
        q = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4]
    out = np.array(q)
    return out if out[0] >= 0 else -out


def unit(v: Array) -> Array:
    """``v / |v|`` along the last axis, complex-step safe."""
    out: Array = v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return out


@dataclass(frozen=True)
class Leg:
    """One leg in docs/conventions.md's terms; ``branch`` the sign (±1) of ``(u × w) · v`` at home."""

    u: Array
    z: Array
    alpha1: Any
    alpha2: Any
    v0: Array
    delta: Any
    branch: float
    scale: Any = 1.0


def intermediate_axis(leg: Leg, theta: Array) -> Array:
    """``w(θ)`` for readings ``(n,)``: ``(n, 3)``, ``φ = sθ + δ``."""
    phi = leg.scale * theta + leg.delta
    y = cross(leg.u, leg.z)
    out: Array = (np.cos(leg.alpha1) * leg.u
                  + np.sin(leg.alpha1) * (np.cos(phi)[:, None] * leg.z + np.sin(phi)[:, None] * y))
    return out


def closure(legs: Sequence[Leg], joints: Array, r: Array) -> Array:
    """``w_i(θ_i) · R v0_i − cos α2_i`` for ``(n, 3)`` readings and ``(n, 3, 3)`` rotations."""
    cols = []
    for i, leg in enumerate(legs):
        w = intermediate_axis(leg, joints[:, i])
        v = np.einsum("nab,b->na", r, leg.v0)
        cols.append(np.sum(w * v, axis=1) - np.cos(leg.alpha2))
    return np.stack(cols, axis=1)


def closure_jacobian(legs: Sequence[Leg], joints: Array, r: Array) -> tuple[Array, Array]:
    """``A`` (rows ``(v_i × w_i)ᵀ``: ``∂f/∂ε`` for ``R ← exp(ε) R``) and the branch values
    ``(u_i × w_i) · v_i``, both per pose."""
    rows, signs = [], []
    for i, leg in enumerate(legs):
        w = intermediate_axis(leg, joints[:, i])
        v = np.einsum("nab,b->na", r, leg.v0)
        rows.append(cross(v, w))
        signs.append(np.sum(cross(leg.u, w) * v, axis=1))
    return np.stack(rows, axis=1), np.stack(signs, axis=1)


def conditioning(a: Array) -> Array:
    """``3 / (‖A‖_F ‖A⁻¹‖_F)`` per pose (1 isotropic, 0 singular)."""
    inv = np.linalg.inv(a)
    out: Array = 3 / (np.linalg.norm(a, axis=(1, 2)) * np.linalg.norm(inv, axis=(1, 2)))
    return out


def ik(legs: Sequence[Leg], r: Array, near: Optional[Array] = None) -> Array:
    """Readings ``(n, 3)`` of the working mode for rotations ``(n, 3, 3)``: per leg,
    ``a cos φ + b sin φ = c`` solved in closed form and the root on the leg's home branch taken;
    each reading unwrapped to within π of ``near`` (default 0)."""
    n = r.shape[0]
    out = np.zeros((n, 3))
    for i, leg in enumerate(legs):
        v = np.einsum("nab,b->na", r, leg.v0)
        y = cross(leg.u, leg.z)
        a = math.sin(leg.alpha1) * (v @ leg.z)
        b = math.sin(leg.alpha1) * (v @ y)
        c = math.cos(leg.alpha2) - math.cos(leg.alpha1) * (v @ leg.u)
        rho = np.hypot(a, b)
        if np.any(np.abs(c) > rho):
            raise ReferenceError(f"leg {i + 1}: out of reach")
        base, spread = np.arctan2(b, a), np.arccos(c / rho)
        chosen = np.full(n, np.nan)
        for phi in (base + spread, base - spread):
            w = (math.cos(leg.alpha1) * leg.u
                 + math.sin(leg.alpha1) * (np.cos(phi)[:, None] * leg.z + np.sin(phi)[:, None] * y))
            sign = np.sum(cross(leg.u, w) * v, axis=1)
            chosen = np.where(np.isnan(chosen) & (np.sign(sign) == leg.branch), phi, chosen)
        if np.any(np.isnan(chosen)):
            raise ReferenceError(f"leg {i + 1}: no root on the home branch")
        # φ − δ unwrapped to within π of the scaled `near`, then the scale divided out.
        angle = chosen - leg.delta
        centre = np.zeros(n) if near is None else leg.scale * near[:, i]
        out[:, i] = (centre + (angle - centre + np.pi) % (2 * np.pi) - np.pi) / leg.scale
    return out


def home_joints(legs: Sequence[Leg]) -> Array:
    """The readings of ``R = I`` on the home branches."""
    out: Array = ik(legs, np.eye(3)[None])[0]
    return out


def newton(legs: Sequence[Leg], joints: Array, r: Array, iterations: int, tol: float = 0.0) -> Array:
    """Up to ``iterations`` Newton steps on the closure, ``R ← exp(−A⁻¹ f) R``, ending after a
    step below ``tol`` rad."""
    for _ in range(iterations):
        a, _ = closure_jacobian(legs, joints, r)
        eps = -np.linalg.solve(a, closure(legs, joints, r)[..., None])[..., 0]
        r = expm(eps) @ r
        if np.abs(eps).max() < tol:
            break
    return r


def fda(legs: Sequence[Leg], joints: Array, steps: int = 12, min_conditioning: float = 0.05,
        min_margin: float = 0.05, start: Optional[Array] = None) -> Array:
    """The working-mode FDA of readings ``(n, 3)``: continuation from ``R = I`` at the home
    readings along the straight joint-space path, Newton at every step, refusing a path that comes
    near a singularity or leaves a leg's home branch. ``(n, 3, 3)``. With ``start`` (rotations of
    a nearby solution, e.g. before a tiny change of the parameters), Newton from there alone."""
    joints = np.atleast_2d(np.asarray(joints, dtype=float))
    if start is not None:
        return newton(legs, joints, start, 10)
    home = home_joints(legs)
    n = joints.shape[0]
    r = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    branches = np.array([leg.branch for leg in legs])
    sin_a1 = np.array([math.sin(leg.alpha1) for leg in legs])
    for s in range(1, steps + 1):
        path = home + (joints - home) * (s / steps)
        r = newton(legs, path, r, 8, 1e-9) if s < steps else newton(legs, path, r, 10)
        a, signs = closure_jacobian(legs, path, r)
        if np.any(np.abs(closure(legs, path, r)) > 1e-9):
            raise ReferenceError("the continuation lost the closure")
        if np.any(conditioning(a) < min_conditioning):
            raise ReferenceError("near a parallel singularity on the path")
        if np.any(signs * branches / sin_a1 < min_margin):
            raise ReferenceError("a leg left (or nearly left) its home branch on the path")
    return r


def camera_matrix(model: str, terms: Array) -> Array:
    """``K`` of docs/calibration.md's table; ``terms`` in ``CAMERA_TERMS``'s order."""
    s, sy, kxy, kxz, kyz = terms
    one, zero = terms[0] * 0 + 1, terms[0] * 0
    if model == "rigid":
        return np.array([[one, zero, zero], [zero, one, zero], [zero, zero, one]])
    if model == "depth_scale":
        return np.array([[one, zero, zero], [zero, one, zero], [zero, zero, s]])
    if model == "affine":
        return np.array([[one, kxy, kxz], [kxy, sy, kyz], [kxz, kyz, s]])
    raise ValueError(model)


@dataclass
class Start:
    """The fit's parameterisation at ``x = 0``: the geometry, registration, markers, camera model,
    and (from the library's interface) the parameter names and the gauge's tilt directions."""

    legs: list[Leg]
    camera_rotation: Array
    camera_translation: Array
    markers: Array
    camera_model: str
    camera_terms: Array
    names: list[str]
    actuated_dirs: list[Array]
    platform_dirs: list[Array]
    parsed: list[tuple[str, int, int]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.parsed = [parse_name(n) for n in self.names]


def parse_name(name: str) -> tuple[str, int, int]:
    """``(what, index, component)`` of a parameter name, e.g. ``leg3.u_tilt2`` → ``("u", 2, 1)``."""
    head, _, tail = name.partition(".")
    axes = {"x": 0, "y": 1, "z": 2}
    if head.startswith("leg"):
        leg = int(head[3:]) - 1
        for axis in ("u", "v0"):
            if tail.startswith(axis + "_tilt"):
                k = tail[len(axis) + 5:]
                return (axis, leg, int(k) - 1 if k else 0)
        if tail in ("alpha1", "alpha2", "delta", "scale"):
            return (tail, leg, 0)
    elif head == "platform" and tail == "sag":
        return ("sag", 0, 0)
    elif head == "camera":
        if tail.startswith("rotation_"):
            return ("rotation", 0, axes[tail[-1]])
        if tail.startswith("t_"):
            return ("translation", 0, axes[tail[-1]])
        if tail in CAMERA_TERMS:
            return ("term", 0, CAMERA_TERMS.index(tail))
    elif head.startswith("m") and head[1:].isdigit():
        return ("marker", int(head[1:]) - 1, axes[tail])
    raise ValueError(f"unknown parameter {name}")


@dataclass
class State:
    """Everything the observation model needs at one parameter vector."""

    legs: list[Leg]
    camera_rotation: Array
    camera_translation: Array
    markers: Array
    k: Array
    sag: Any = 0.0


def sagged(sag: Any, r: Array) -> Array:
    """The platform where its weight turns the rigid mechanism's ``r`` ``(n, 3, 3)``: by ``sag``
    times the gravity torque's arm ``(R z) × (−z)`` (docs/conventions.md), in B."""
    arm = np.cross(r[:, :, 2], np.array([0.0, 0.0, -1.0]))
    out: Array = expm(sag * arm) @ r
    return out


def state(start: Start, x: Array) -> State:
    """The geometry, registration, markers and ``K`` at ``x`` (real or complex)."""
    dtype = np.result_type(x, float)
    tilt_u = [np.zeros(3, dtype) for _ in range(3)]
    tilt_v = [np.zeros(3, dtype) for _ in range(3)]
    add = {key: [dtype.type(0)] * 3 for key in ("alpha1", "alpha2", "delta", "scale")}
    rotation = np.zeros(3, dtype)
    translation = np.zeros(3, dtype)
    markers = np.zeros(start.markers.shape, dtype)
    terms = np.zeros(5, dtype)
    sag = dtype.type(0)
    if len(x) != len(start.parsed):
        raise ValueError(f"x has {len(x)} entries for {len(start.parsed)} parameters")
    for value, (what, i, k) in zip(x, start.parsed):
        if what == "u":
            tilt_u[i] = tilt_u[i] + value * start.actuated_dirs[i][k]
        elif what == "v0":
            tilt_v[i] = tilt_v[i] + value * start.platform_dirs[i][k]
        elif what in add:
            add[what][i] = add[what][i] + value
        elif what == "rotation":
            rotation[k] = value
        elif what == "translation":
            translation[k] = value
        elif what == "marker":
            markers[i, k] = value
        elif what == "sag":
            sag = sag + value
        else:
            terms[k] = value
    legs = []
    for i, leg in enumerate(start.legs):
        u = expm(tilt_u[i]) @ leg.u
        z = unit(leg.z - u * np.sum(leg.z * u))
        legs.append(Leg(u=u, z=z, alpha1=leg.alpha1 + add["alpha1"][i], alpha2=leg.alpha2 + add["alpha2"][i],
                        v0=expm(tilt_v[i]) @ leg.v0, delta=leg.delta + add["delta"][i], branch=leg.branch,
                        scale=leg.scale + add["scale"][i]))
    return State(legs=legs, camera_rotation=expm(rotation) @ start.camera_rotation,
                 camera_translation=start.camera_translation + translation, markers=start.markers + markers,
                 k=camera_matrix(start.camera_model, start.camera_terms + terms), sag=sag)


def camera_points(s: State, r: Array, markers: Array) -> Array:
    """``K (R_CB R p_k + t_CB)`` for each observation (rotations ``(n, 3, 3)``, marker indices ``(n,)``)."""
    y = np.einsum("ab,nbc,nc->na", s.camera_rotation, r, s.markers[markers]) + s.camera_translation
    out: Array = np.einsum("ab,nb->na", s.k, y)
    return out


def predict(start: Start, x: Array, joints: Array, markers: Array,
            near: Optional[Array] = None) -> tuple[Array, Array]:
    """The predicted camera points ``(n, 3)`` and the FDA's rotations ``(n, 3, 3)`` at ``x`` (from
    the rotations ``near`` of a nearby ``x`` when given)."""
    s = state(start, np.asarray(x, dtype=float))
    r = sagged(s.sag, fda(s.legs, joints, start=near))
    return camera_points(s, r, markers), r


def implicit_step(a_inverse: Array, f_x: Array) -> Array:
    """``dε = −A⁻¹ ∂f/∂x``: how the FDA's rotation turns (in B) when the closure moves by ``f_x``."""
    out: Array = -np.einsum("nab,nb->na", a_inverse, f_x)
    return out


def sensitivities(start: Start, x: Array, joints: Array, markers: Array) -> tuple[Array, Array, Array, Array]:
    """Predictions ``(n, 3)``, rotations ``(n, 3, 3)``, the predictions' Jacobian ``(n, 3, p)`` and
    the orientations' ``(n, 3, p)`` (``dR = [dω]× R``, ``dω`` in B)."""
    x = np.asarray(x, dtype=float)
    s = state(start, x)
    rigid = fda(s.legs, joints)
    r = sagged(s.sag, rigid)
    predictions = camera_points(s, r, markers)
    a, _ = closure_jacobian(s.legs, joints, rigid)
    a_inverse = np.linalg.inv(a)
    rp = np.einsum("nab,nb->na", r, s.markers[markers])
    lever = np.einsum("ab,bc,ncd->nad", s.k, s.camera_rotation, hat(rp))  # K R_CB [R p]×
    p = len(x)
    jac = np.zeros((len(joints), 3, p))
    omega = np.zeros((len(joints), 3, p))
    for i in range(p):
        xc = x.astype(complex)
        xc[i] += 1j * COMPLEX_STEP
        sc = state(start, xc)
        f_x = closure(sc.legs, joints, rigid.astype(complex)).imag / COMPLEX_STEP
        # The rigid mechanism turns by the implicit step; the platform, by what the sag (at the
        # complex x) makes of that turn: the complex step through the composition, not a formula.
        d_rigid = implicit_step(a_inverse, f_x)
        turned = sagged(sc.sag, expm(1j * COMPLEX_STEP * d_rigid) @ rigid.astype(complex))
        step = np.einsum("nab,ncb->nac", turned, r).imag / COMPLEX_STEP
        d_omega = np.stack([step[:, 2, 1], step[:, 0, 2], step[:, 1, 0]], axis=1)
        explicit = camera_points(sc, r.astype(complex), markers).imag / COMPLEX_STEP
        jac[:, :, i] = explicit - np.einsum("nab,nb->na", lever, d_omega)
        omega[:, :, i] = d_omega
    return predictions, r, jac, omega


def finite_difference_jacobian(start: Start, x: Array, joints: Array, markers: Array,
                               steps: Optional[Array] = None) -> Array:
    """Central differences of the whole reference (FDA solved anew at every point): ``(n, 3, p)``."""
    x = np.asarray(x, dtype=float)
    h = np.full(len(x), 1e-6) if steps is None else steps
    _, r0 = predict(start, x, joints, markers)
    out = np.zeros((len(joints), 3, len(x)))
    for i in range(len(x)):
        e = np.zeros(len(x))
        e[i] = h[i]
        plus, _ = predict(start, x + e, joints, markers, near=r0)
        minus, _ = predict(start, x - e, joints, markers, near=r0)
        out[:, :, i] = (plus - minus) / (2 * h[i])
    return out


# --- The nominal Agile Wrist (docs/conventions.md) and perturbations -------------------------------------


def legs_from_file(legs: Sequence[dict[str, Any]]) -> list[Leg]:
    """Legs from a parameters file's ``legs`` (docs/sessions-and-formats.md: ``u``, ``z``,
    ``alpha1_deg``, ``alpha2_deg``, ``v0``, ``delta_deg``, ``scale`` (1 when absent), ``home_branch``)."""
    return [Leg(u=np.array(leg["u"], dtype=float), z=np.array(leg["z"], dtype=float),
                alpha1=math.radians(leg["alpha1_deg"]), alpha2=math.radians(leg["alpha2_deg"]),
                v0=np.array(leg["v0"], dtype=float), delta=math.radians(leg["delta_deg"]),
                branch=-1.0 if leg.get("home_branch", "negative") == "negative" else 1.0,
                scale=float(leg.get("scale", 1.0))) for leg in legs]


def agile_wrist() -> list[Leg]:
    """docs/conventions.md's nominal Agile Wrist: α1 = α2 = 90°, b = p = arctan √2, legs 120° apart; its
    legs are on the negative branch at home."""
    b = p = math.atan(math.sqrt(2))
    legs = []
    for i in range(3):
        eta = 2 * math.pi * i / 3
        u = np.array([-math.sin(eta) * math.sin(b), math.cos(eta) * math.sin(b), -math.cos(b)])
        z = np.array([math.cos(eta), math.sin(eta), 0.0])
        v0 = np.array([-math.sin(eta) * math.sin(p), math.cos(eta) * math.sin(p), math.cos(p)])
        legs.append(Leg(u=u, z=z, alpha1=math.pi / 2, alpha2=math.pi / 2, v0=v0, delta=0.0, branch=-1.0))
    return legs


def agile_wrist_markers() -> Array:
    """docs/conventions.md's nominal markers: m1–m3 on the MP (radius 0.075 m, 0.06 m above O, azimuths
    90°, 210°, 330°), m4 atop the column (0, 0, 0.22) m."""
    ring = [[0.075 * math.cos(math.radians(a)), 0.075 * math.sin(math.radians(a)), 0.06] for a in (90, 210, 330)]
    return np.array(ring + [[0.0, 0.0, 0.22]])


def random_tilt(rng: np.random.Generator, v: Array, sigma: float) -> Array:
    """``v`` turned by a random rotation of about ``sigma`` rad per axis."""
    return expm(rng.normal(0, sigma, 3)) @ v


def perturbed(rng: np.random.Generator, legs: Sequence[Leg], tilt: float, angle: float, offset: float) -> list[Leg]:
    """A geometry near ``legs``: axes tilted (σ ``tilt`` rad per axis), link angles and offsets moved."""
    out = []
    for leg in legs:
        u = random_tilt(rng, leg.u, tilt)
        z = unit(leg.z - u * (leg.z @ u))
        out.append(replace(leg, u=u, z=z, v0=random_tilt(rng, leg.v0, tilt),
                           alpha1=leg.alpha1 + rng.normal(0, angle), alpha2=leg.alpha2 + rng.normal(0, angle),
                           delta=leg.delta + rng.normal(0, offset)))
    return out


def general_spm(rng: np.random.Generator, coaxial: bool) -> list[Leg]:
    """A random SPM whose home (readings 0) is ``R = I``: actuated axes on a random cone (or one
    common axis, ``coaxial``), legs unevenly spaced, link angles 60°–130°, random zero directions
    and offsets; ``α2`` is the angle the home closure gives and each leg's branch its sign there."""
    b, p = rng.uniform(0.5, 1.2), rng.uniform(0.5, 1.2)
    legs = []
    for i in range(3):
        eta = 2 * math.pi * i / 3 + rng.uniform(-0.25, 0.25)
        u = np.array([0.0, 0.0, -1.0]) if coaxial else np.array(
            [-math.sin(eta) * math.sin(b), math.cos(eta) * math.sin(b), -math.cos(b)])
        eta_v = 2 * math.pi * i / 3 + rng.uniform(-0.25, 0.25)
        v0 = np.array([-math.sin(eta_v) * math.sin(p), math.cos(eta_v) * math.sin(p), math.cos(p)])
        z = unit(cross(u, rng.normal(size=3)))
        alpha1 = rng.uniform(math.radians(60), math.radians(130))
        delta = rng.uniform(-0.5, 0.5)
        leg = Leg(u=u, z=z, alpha1=alpha1, alpha2=0.0, v0=v0, delta=delta, branch=1.0)
        w = intermediate_axis(leg, np.zeros(1))[0]
        alpha2 = math.acos(float(np.clip(w @ v0, -1, 1)))
        sign = float(np.sign(cross(u, w) @ v0))
        legs.append(replace(leg, alpha2=alpha2, branch=sign))
    return legs


def home_is_regular(legs: Sequence[Leg], margin: float = 0.25) -> bool:
    """Whether ``R = I`` is far from both kinds of singularity (and reachable on the branches)."""
    try:
        home = home_joints(legs)
    except ReferenceError:
        return False
    a, signs = closure_jacobian(legs, home[None], np.eye(3)[None])
    margins = signs[0] * np.array([leg.branch for leg in legs]) / np.sin([leg.alpha1 for leg in legs])
    return bool(conditioning(a)[0] > margin and np.all(margins > margin))


def random_orientations(rng: np.random.Generator, n: int, tilt_deg: float, yaw_deg: float) -> Array:
    """``n`` orientations: a tilt of up to ``tilt_deg`` (uniform over the disc) about a horizontal
    axis after a yaw of up to ``yaw_deg``."""
    radius = np.radians(tilt_deg) * np.sqrt(rng.random(n))
    azimuth = rng.uniform(0, 2 * np.pi, n)
    tilt = np.stack([radius * np.cos(azimuth), radius * np.sin(azimuth), np.zeros(n)], axis=1)
    yaw = np.zeros((n, 3))
    yaw[:, 2] = np.radians(yaw_deg) * rng.uniform(-1, 1, n)
    out: Array = expm(tilt) @ expm(yaw)
    return out


def regular_poses(legs: Sequence[Leg], r: Array, margin: float = 0.2) -> Array:
    """Which of the rotations ``(n, 3, 3)`` are reachable on the home branches and well-conditioned."""
    keep = np.zeros(len(r), dtype=bool)
    for j in range(len(r)):
        try:
            joints = ik(legs, r[j:j + 1])
        except ReferenceError:
            continue
        a, signs = closure_jacobian(legs, joints, r[j:j + 1])
        margins = signs[0] * np.array([leg.branch for leg in legs]) / np.sin([leg.alpha1 for leg in legs])
        keep[j] = conditioning(a)[0] > margin and np.all(margins > margin)
    return keep


def stereo_covariance(points: Array, lateral: float, depth: float, distance: float) -> Array:
    """docs/calibration.md's stereo noise at camera points ``(n, 3)``:
    ``σ_l² (d/d₀)² (I − ℓℓᵀ) + σ_d² (d/d₀)⁴ ℓℓᵀ``, ``ℓ`` the line of sight."""
    d = np.linalg.norm(points, axis=1)
    ell = points / d[:, None]
    along = np.einsum("na,nb->nab", ell, ell)
    ratio = (d / distance)[:, None, None]
    out: Array = lateral**2 * ratio**2 * (np.eye(3) - along) + depth**2 * ratio**4 * along
    return out


def common_rotations_removed(s: Array, r: Array) -> Array:
    """The orientation sensitivities ``(n, 3, p)`` less their least-squares projection onto the
    rotations common to every pose, ``ψ_B + R_j ψ_P`` (invisible to any measurement):
    ``(3n, p)``."""
    n = len(r)
    c = np.concatenate([np.broadcast_to(np.eye(3), (n, 3, 3)), r], axis=2).reshape(3 * n, 6)
    stacked = s.reshape(3 * n, -1)
    coef, *_ = np.linalg.lstsq(c, stacked, rcond=None)
    out: Array = stacked - c @ coef
    return out


def orientation_error_deg(calibrated: Array, truth: Array, iterations: int = 8) -> Array:
    """Angles (deg) between ``G R_cal,j H`` and ``R_true,j`` after the rotations ``G`` (of B) and
    ``H`` (of P) that minimise their sum of squares (Gauss–Newton): the error no frame choice
    explains."""
    g, h = np.eye(3), np.eye(3)
    n = len(truth)
    for _ in range(iterations):
        e = log_rotation(g @ calibrated @ h @ np.transpose(truth, (0, 2, 1)))
        # e_j ≈ e_j⁰ + δg + (G R_cal,j H) δh (left rotation of B, right rotation of P).
        jac = np.concatenate([np.broadcast_to(np.eye(3), (n, 3, 3)), g @ calibrated @ h], axis=2).reshape(3 * n, 6)
        step, *_ = np.linalg.lstsq(jac, -e.reshape(-1), rcond=None)
        g = expm(step[:3]) @ g
        h = h @ expm(step[3:])
    e = log_rotation(g @ calibrated @ h @ np.transpose(truth, (0, 2, 1)))
    out: Array = np.degrees(np.linalg.norm(e, axis=1))
    return out
