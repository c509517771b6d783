"""A calibration study whose data comes from the numpy reference, not the crate's simulator.

Per session: a true Agile Wrist near docs/conventions.md's nominal one (axes tilted by σ 0.5° per axis, link
angles by 0.3°, offsets by 1°), a camera 0.8 m above O looking down (misplaced by σ 1 cm and 1°, a
perfect K), markers glued 3 mm (σ per axis) off the nominal positions, ``--poses`` orientations
within a 25° tilt disc and ±25° yaw (home first; poses kept where the conditioning and every
branch margin exceed 0.2), exact readings by the reference's IK, and all four markers at every
pose with stereo noise (0.2 mm across the line of sight ∝ d, 0.8 mm along it ∝ d², at 0.8 m:
docs/calibration.md's noise model) drawn by the reference. The session folder is written in the
documented format and calibrated by the program (``spmcal calibrate --dataset DIR --model
models/agile_wrist.urdf --config C --out params.yaml --json``, the default marker-level fit with
the depth-scale camera model named in ``C``: the bound below is that model's, where ``auto``, the
default, would choose rigid for most perfect cameras).

The calibrated parameters file's legs are put through the reference's FDA at 60 unseen poses of
the same workspace and compared with the truth, up to the rotations of B and of P common to every
pose (docs/calibration.md, "predicted accuracy"): the achieved error. Beside it, the Cramér–Rao
bound from the reference's own Jacobian: the Fisher information of the session's observations
under the true noise at the true parameters (the fit's parameter set — mechanism gauge-fixed by
the first two legs, ``R_CB``, ``t_CB``, the markers, the depth scale — built here, not asked of the
library), propagated to the same unseen poses with the common rotations projected out.
``--depth-scale 1.02`` draws the markers through a camera whose depths read 2% long
(``K = diag(1, 1, 1.02)``), which the fit's depth-scale model must find.

    python python/tests/reference_study.py --sessions 20 [--poses 200] [--seed 1] [--depth-scale S] [--program P]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_model as ref  # noqa: E402
import spmcal  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MODEL = "models/agile_wrist.urdf"
LATERAL_M, DEPTH_M, DISTANCE_M = 0.0002, 0.0008, 0.8
MARKERS = ["m1", "m2", "m3", "m4"]


@dataclass
class Truth:
    legs: list[ref.Leg]
    camera_rotation: ref.Array
    camera_translation: ref.Array
    markers: ref.Array


@dataclass
class Result:
    """One session: the achieved RMS error (deg) of the calibrated and nominal mechanisms on unseen
    poses, the Cramér–Rao RMS (deg) and its effective degrees of freedom."""

    achieved_deg: float
    nominal_deg: float
    crb_deg: float
    dof: float
    passed: bool
    depth_scale: float
    depth_scale_std_error: float


def draw_truth(rng: np.random.Generator) -> Truth:
    while True:
        legs = ref.perturbed(rng, ref.agile_wrist(), math.radians(0.5), math.radians(0.3), math.radians(1.0))
        if ref.home_is_regular(legs):
            break
    rotation = ref.expm(rng.normal(0, math.radians(1), 3)) @ np.diag([1.0, -1.0, -1.0])
    centre = np.array([0.0, 0.0, 0.8]) + rng.normal(0, 0.01, 3)
    return Truth(legs, rotation, -rotation @ centre, ref.agile_wrist_markers() + rng.normal(0, 0.003, (4, 3)))


def poses(rng: np.random.Generator, legs: list[ref.Leg], n: int, home: bool) -> tuple[ref.Array, ref.Array]:
    """``n`` regular orientations (home first when ``home``) and their readings."""
    chosen: list[ref.Array] = [np.eye(3)] if home else []
    while len(chosen) < n:
        r = ref.random_orientations(rng, 2 * n, 25.0, 25.0)
        chosen += list(r[ref.regular_poses(legs, r)])
    rotations = np.array(chosen[:n])
    return rotations, ref.ik(legs, rotations)


def fit_start(truth: Truth, depth_scale: float = 1.0) -> ref.Start:
    """The fit's parameter set around the truth, its gauge built here from docs/calibration.md:
    ``u_1``, ``v0_1`` held; ``u_2``, ``v0_2`` tilting in their plane with them; ``u_3``, ``v0_3``
    tilting freely; ``R_CB = exp(c) R_CB⁰``; ``t_CB``; the markers; the depth scale."""
    g = truth.legs

    def tangents(a: ref.Array) -> ref.Array:
        e1 = ref.unit(ref.cross(a, [0.3, 0.5, 0.7]))
        return np.array([e1, ref.cross(a, e1)])

    actuated = [np.zeros((0, 3)), ref.unit(ref.cross(g[0].u, g[1].u))[None], tangents(g[2].u)]
    platform = [np.zeros((0, 3)), ref.unit(ref.cross(g[0].v0, g[1].v0))[None], tangents(g[2].v0)]
    names = ["leg1.alpha1", "leg1.alpha2", "leg1.delta",
             "leg2.u_tilt", "leg2.alpha1", "leg2.alpha2", "leg2.delta", "leg2.v0_tilt",
             "leg3.u_tilt1", "leg3.u_tilt2", "leg3.alpha1", "leg3.alpha2", "leg3.delta", "leg3.v0_tilt1",
             "leg3.v0_tilt2"]
    names += [f"camera.rotation_{a}" for a in "xyz"] + [f"camera.t_{a}" for a in "xyz"]
    names += [f"{m}.{a}" for m in MARKERS for a in "xyz"] + ["camera.depth_scale"]
    return ref.Start(legs=g, camera_rotation=truth.camera_rotation, camera_translation=truth.camera_translation,
                     markers=truth.markers, camera_model="depth_scale",
                     camera_terms=ref.PERFECT_TERMS + [depth_scale - 1, 0, 0, 0, 0],
                     names=names, actuated_dirs=actuated, platform_dirs=platform)


def write_session(folder: Path, name: str, joints: ref.Array, measured: ref.Array) -> None:
    folder.mkdir(parents=True)
    (folder / "session.yaml").write_text(
        f"name: {name}\nmarkers: [{', '.join(MARKERS)}]\n"
        "description: drawn by python/tests/reference_study.py from the numpy reference\n")
    (folder / "joints.csv").write_text("pose,theta1_rad,theta2_rad,theta3_rad\n" + "".join(
        f"{j},{float(a)!r},{float(b)!r},{float(c)!r}\n" for j, (a, b, c) in enumerate(joints)))
    rows = []
    for j in range(len(joints)):
        for k, m in enumerate(MARKERS):
            x, y, z = measured[j, k]
            rows.append(f"{j},{m},{float(x)!r},{float(y)!r},{float(z)!r}\n")
    (folder / "markers.csv").write_text("pose,marker,x_m,y_m,z_m\n" + "".join(rows))


def legs_of(params: Path) -> list[ref.Leg]:
    """The legs of a parameters file (read by the library's reader, evaluated by the reference)."""
    return ref.legs_from_file(spmcal.Model.from_params(params).to_dict()["legs"])


def session(seed: int, n_poses: int, program: str, work: Path, fresh: int = 60, depth_scale: float = 1.0) -> Result:
    """One session drawn with ``seed`` (its camera's depths ``depth_scale`` times their length),
    calibrated by ``program`` in ``work``."""
    rng = np.random.default_rng(seed)
    truth = draw_truth(rng)
    _, joints = poses(rng, truth.legs, n_poses, home=True)
    start = fit_start(truth, depth_scale)
    zero = np.zeros(len(start.names))
    obs_joints = np.repeat(joints, 4, axis=0)
    obs_markers = np.tile(np.arange(4), len(joints))
    clean, _, jac, _ = ref.sensitivities(start, zero, obs_joints, obs_markers)
    covariance = ref.stereo_covariance(clean, LATERAL_M, DEPTH_M, DISTANCE_M)
    noise = np.einsum("nab,nb->na", np.linalg.cholesky(covariance), rng.standard_normal(clean.shape))
    folder = work / f"reference_{seed}"
    write_session(folder, f"reference_{seed}", joints, (clean + noise).reshape(len(joints), 4, 3))
    params = folder.parent / f"params_{seed}.yaml"
    config = folder.parent / f"config_{seed}.yaml"
    config.write_text("camera_model: depth_scale\n")
    out = subprocess.run([program, "calibrate", "--dataset", str(folder), "--model", MODEL, "--config", str(config),
                          "--out", str(params), "--json"], cwd=ROOT, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    report: dict[str, Any] = json.loads(out.stdout)["results"]

    # Unseen poses of the same workspace: the calibrated and nominal mechanisms against the truth.
    r_fresh, j_fresh = poses(rng, truth.legs, fresh, home=False)
    achieved = ref.orientation_error_deg(ref.fda(legs_of(params), j_fresh), r_fresh)
    nominal = ref.orientation_error_deg(ref.fda(ref.agile_wrist(), j_fresh), r_fresh)

    # The Cramér–Rao bound from the reference's Jacobian, at the same unseen poses.
    weights = np.linalg.inv(covariance)
    fisher = np.einsum("nap,nab,nbq->pq", jac, weights, jac)
    sigma = np.linalg.inv(fisher)
    _, _, _, omega = ref.sensitivities(start, zero, j_fresh, np.zeros(len(j_fresh), dtype=int))
    s = ref.common_rotations_removed(omega, r_fresh)
    qs = (s.T @ s / len(j_fresh)) @ sigma
    mean_square = float(np.trace(qs))
    camera = report["markers"]["camera_model"]
    return Result(achieved_deg=float(np.sqrt(np.mean(achieved**2))), nominal_deg=float(np.sqrt(np.mean(nominal**2))),
                  crb_deg=math.degrees(math.sqrt(mean_square)), dof=mean_square**2 / float(np.trace(qs @ qs)),
                  passed=bool(report["verdict"]["pass"]), depth_scale=float(camera["depth_scale"]),
                  depth_scale_std_error=float(camera["depth_scale_std_error"]))


def chi2_ratio_band(dof: float, p: float) -> tuple[float, float]:
    """The central ``1 − p`` range of ``χ²_ν / ν`` (Wilson–Hilferty)."""
    z = NormalDist().inv_cdf(1 - p / 2)
    c = 2 / (9 * dof)
    return (1 - c - z * math.sqrt(c)) ** 3, (1 - c + z * math.sqrt(c)) ** 3


def pooled(results: list[Result]) -> dict[str, float]:
    """RMS over the sessions, the pooled ratio ``√(Σ achieved² / Σ CRB²)`` with its effective
    degrees of freedom, and how many sessions fall inside their own 90% range."""
    a2 = sum(r.achieved_deg**2 for r in results)
    c2 = sum(r.crb_deg**2 for r in results)
    dof = c2**2 / sum(r.crb_deg**4 / r.dof for r in results)
    inside = 0
    for r in results:
        lo, hi = chi2_ratio_band(r.dof, 0.10)
        inside += lo <= (r.achieved_deg / r.crb_deg) ** 2 <= hi
    return {"sessions": len(results), "achieved_deg": math.sqrt(a2 / len(results)),
            "crb_deg": math.sqrt(c2 / len(results)), "ratio": math.sqrt(a2 / c2), "dof": dof,
            "nominal_deg": math.sqrt(sum(r.nominal_deg**2 for r in results) / len(results)),
            "inside_90": inside, "mean_session_dof": sum(r.dof for r in results) / len(results),
            "passed": sum(r.passed for r in results)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=20)
    parser.add_argument("--poses", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--depth-scale", type=float, default=1.0, help="the true camera's depth scale")
    parser.add_argument("--program", default=os.environ.get("SPMCAL_BIN", "spmcal"))
    args = parser.parse_args()
    os.chdir(ROOT)
    results = []
    with tempfile.TemporaryDirectory() as work:
        for s in range(args.sessions):
            r = session(args.seed + s, args.poses, args.program, Path(work), depth_scale=args.depth_scale)
            results.append(r)
            print(f"session {s + 1}: nominal {r.nominal_deg:.4f}°, calibrated {r.achieved_deg:.4f}°, "
                  f"CRB {r.crb_deg:.4f}° (ratio {r.achieved_deg / r.crb_deg:.3f}, dof {r.dof:.1f}), "
                  f"depth scale {r.depth_scale:.5f} ± {r.depth_scale_std_error:.5f}", flush=True)
    summary = pooled(results)
    z = np.array([(r.depth_scale - args.depth_scale) / r.depth_scale_std_error for r in results])
    summary["depth_scale_mean_error"] = float(np.mean([r.depth_scale for r in results]) - args.depth_scale)
    summary["depth_scale_z_rms"] = float(np.sqrt(np.mean(z**2)))
    summary["depth_scale_within_2_sigma"] = int(np.sum(np.abs(z) <= 2))
    lo, hi = chi2_ratio_band(summary["dof"], 0.05)
    print(json.dumps(summary, indent=1))
    print(f"pooled ratio {summary['ratio']:.3f}; 95% range of the ratio for an efficient fit: "
          f"{math.sqrt(lo):.3f}–{math.sqrt(hi):.3f}")


if __name__ == "__main__":
    main()
