"""The Python module against the Rust library and the command line (issue 24)."""

import json
import shutil
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import reference_model as ref
import spmcal
from conftest import run

MODEL = "models/agile_wrist.urdf"


def test_forward_is_the_command_lines_fda_to_1e12(cli: str, tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    model = spmcal.Model.load(MODEL)
    # Reachable readings: the IK of random tilts and yaws within 25 degrees.
    rotvec = rng.uniform(-0.3, 0.3, size=(50, 3))
    angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
    q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * rotvec / angle])
    joints = model.ik(q)
    path = tmp_path / "joints.csv"
    path.write_text("pose,theta1_rad,theta2_rad,theta3_rad\n" + "".join(
        f"{k},{float(a)!r},{float(b)!r},{float(c)!r}\n" for k, (a, b, c) in enumerate(joints)))
    out = run(cli, "fda", "--joints", str(path), "--json")
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["results"]
    expected = np.array([r["q_wxyz"] for r in rows])
    assert np.abs(model.forward(joints) - expected).max() < 1e-12
    # And the IK then FDA round trip returns the orientations (sign of q fixed, qw >= 0).
    assert np.abs(model.forward(joints) - q).max() < 1e-12
    # An independent fact (the command line and the module run the same Rust): the numpy
    # reference's FDA of docs/conventions.md's nominal wrist gives the same rotations.
    assert np.abs(ref.fda(ref.agile_wrist(), joints) - model.forward(joints, matrices=True)).max() < 1e-12
    assert np.abs(ref.fda(ref.agile_wrist(), joints) - ref.expm(rotvec)).max() < 1e-12


def test_forward_with_joint_scales_is_the_command_lines_fda_to_1e12(cli: str, tmp_path: Path) -> None:
    # A simulated truth with joint scales off by +0.4 / -0.3 / +0.2 % (phi = s theta + delta).
    lines = Path("datasets/agile_wrist_sim_400/truth.yaml").read_text().splitlines(keepends=True)
    scales = iter(["1.004", "0.997", "1.002"])
    text = "".join(line + (f"  scale: {next(scales)}\n" if line.startswith("  delta_deg:") else "") for line in lines)
    params = tmp_path / "scaled.yaml"
    params.write_text(text)
    model = spmcal.Model.from_params(str(params))
    unscaled = spmcal.Model.from_params("datasets/agile_wrist_sim_400/truth.yaml")
    rng = np.random.default_rng(11)
    rotvec = rng.uniform(-0.3, 0.3, size=(50, 3))
    angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
    q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * rotvec / angle])
    joints = model.ik(q)
    # The scales change the readings of a pose: s theta is the unscaled reading.
    assert np.abs(joints * np.array([1.004, 0.997, 1.002]) - unscaled.ik(q)).max() < 1e-12
    path = tmp_path / "joints.csv"
    path.write_text("pose,theta1_rad,theta2_rad,theta3_rad\n" + "".join(
        f"{k},{float(a)!r},{float(b)!r},{float(c)!r}\n" for k, (a, b, c) in enumerate(joints)))
    out = run(cli, "fda", "--params", str(params), "--joints", str(path), "--json")
    assert out.returncode == 0, out.stderr
    expected = np.array([r["q_wxyz"] for r in json.loads(out.stdout)["results"]])
    assert np.abs(model.forward(joints) - expected).max() < 1e-12
    assert np.abs(model.forward(joints) - q).max() < 1e-12


def test_the_other_kinematics_agree_with_forward() -> None:
    model = spmcal.Model.load(MODEL)
    joints = np.array([[0.1, -0.2, 0.05], [0.12, -0.18, 0.07]])
    q = model.forward(joints)
    matrices = model.forward(joints, matrices=True)
    assert matrices.shape == (2, 3, 3)
    assert np.abs(np.einsum("nij,nkj->nik", matrices, matrices) - np.eye(3)).max() < 1e-12
    tracked = model.track(joints, q[0])
    assert np.abs(tracked - q).max() < 1e-12
    modes = model.all_modes(joints[0])
    assert modes.shape[1] == 4 and np.abs(modes[0] - q[0]).max() < 1e-9
    assert model.jacobians(joints).shape == (2, 3, 3)
    conditioning = np.asarray(model.conditioning(joints))
    assert ((conditioning > 0) & (conditioning <= 1)).all()
    assert model.forward(joints[0]).shape == (4,)


def test_errors_are_exceptions_with_the_command_lines_message(cli: str, tmp_path: Path) -> None:
    bad = "tests/data/bad_inputs/bag_missing_joint_name/rec.mcap"
    with pytest.raises(spmcal.FileError) as raised:
        spmcal.Session.load(bad, model=MODEL)
    out = run(cli, "calibrate", "--dataset", bad, "--model", MODEL, "--out", str(tmp_path / "p.yaml"))
    assert out.returncode != 0
    assert out.stderr.strip() == f"error: {raised.value}"
    assert isinstance(raised.value, spmcal.SpmcalError)
    with pytest.raises(spmcal.KinematicsError, match="joints row 1"):
        spmcal.Model.load(MODEL).forward(np.array([[0.0, 0.0, 0.0], [3.0, -3.0, 3.0]]))
    with pytest.raises(spmcal.ConfigError, match="huber_threshold"):
        spmcal.calibrate(spmcal.Session.load("datasets/agile_wrist_sim_20"), huber_threshold=0.1)
    with pytest.raises(spmcal.ModelError):
        spmcal.Model.load("README.md")


def test_a_session_from_arrays_is_the_session_from_files() -> None:
    loaded = spmcal.Session.load("datasets/agile_wrist_sim_20")
    made = spmcal.Session.from_arrays(
        loaded.joints, loaded.markers, loaded.marker_names, model=MODEL, name=loaded.name,
        poses=[int(p) for p in loaded.poses])
    assert np.array_equal(made.joints, loaded.joints)
    assert np.array_equal(np.isnan(made.markers), np.isnan(loaded.markers))
    a, b = spmcal.calibrate(loaded), spmcal.calibrate(made)
    assert np.array_equal(a.covariance, b.covariance)
    assert a.parameters["legs"] == b.parameters["legs"]
    with pytest.raises(spmcal.FileError, match="markers: expected shape"):
        spmcal.Session.from_arrays(loaded.joints, loaded.markers[:, :2], loaded.marker_names, model=MODEL)


def test_the_calibration_of_a_shipped_dataset_is_the_command_lines(cli: str, tmp_path: Path) -> None:
    out = run(cli, "calibrate", "--dataset", "datasets/agile_wrist_sim_400", "--out", str(tmp_path / "cli.yaml"), "--json")
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)["results"]
    calibration = spmcal.calibrate(spmcal.Session.load("datasets/agile_wrist_sim_400"))
    ours = calibration.to_dict()
    assert len(ours["parameters"]) == len(report["parameters"]) > 0
    for a, b in zip(ours["parameters"], report["parameters"]):
        assert a["name"] == b["name"]
        assert a["change_deg"] == pytest.approx(b["change_deg"], abs=1e-12)
    assert ours["predicted_error_deg"]["rms"] == pytest.approx(report["predicted_error_deg"]["rms"], rel=1e-12)
    calibration.save(tmp_path / "py.yaml")
    assert spmcal.Model.from_params(tmp_path / "py.yaml").to_dict()["legs"] == \
        spmcal.Model.from_params(tmp_path / "cli.yaml").to_dict()["legs"]
    errors = calibration.errors()
    assert errors["calibrated"].mean() < errors["nominal"].mean() / 2
    # An independent fact: the simulation's truth. The calibrated legs through the numpy reference's
    # FDA against the true legs at the session's readings, up to the rotations common to every
    # pose, lie within the report's own 90% range of its predicted error (and far below nominal).
    session = spmcal.Session.load("datasets/agile_wrist_sim_400")
    true_legs = spmcal.Model.from_params("datasets/agile_wrist_sim_400/truth.yaml").to_dict()["legs"]
    truth = ref.fda(ref.legs_from_file(true_legs), session.joints)
    calibrated = ref.fda(ref.legs_from_file(calibration.parameters["legs"]), session.joints)
    achieved = ref.orientation_error_deg(calibrated, truth)
    nominal = ref.orientation_error_deg(ref.fda(ref.agile_wrist(), session.joints), truth)
    rms = float(np.sqrt(np.mean(achieved**2)))
    low, high = ours["predicted_error_deg"]["interval_90"]
    assert low <= rms <= high, (rms, low, high)
    assert rms < float(np.sqrt(np.mean(nominal**2))) / 10


def test_a_long_calibration_releases_the_gil() -> None:
    session = spmcal.Session.load("datasets/agile_wrist_free_motion_120s")
    ticks: list[float] = []
    done = threading.Event()

    def tick() -> None:
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    ticker = threading.Thread(target=tick)
    ticker.start()
    start = time.perf_counter()
    spmcal.calibrate(session)
    end = time.perf_counter()
    done.set()
    ticker.join()
    during = [t for t in ticks if start < t < end]
    # A fit that held the GIL would let the ticker run only between Python bytecodes: none here.
    assert end - start > 0.05 and len(during) > 10, (end - start, len(during))


def test_a_bag_and_a_simulation_are_sessions(tmp_path: Path) -> None:
    session = spmcal.simulate("configs/simulate_agile_wrist.yaml", seed=3, poses=30)
    assert len(session) == 30 and session.kind == "static"
    session.save(tmp_path / "s.mcap")
    back = spmcal.Session.load(tmp_path / "s.mcap", model=MODEL)
    assert np.array_equal(back.joints, session.joints)
    summary, q, joints = spmcal.plan(12, candidates=300)
    assert q.shape == (12, 4) and joints.shape == (12, 3) and summary["poses"] == 12
    added, _, _ = spmcal.plan(6, candidates=200, augment=spmcal.Session.load("datasets/agile_wrist_sim_20"))
    assert added["augments"] == ["agile_wrist_sim_20", 20]
    with pytest.raises(spmcal.ConfigError, match="camera_model"):
        spmcal.plan(6, camera_model="pinhole")
    compared = spmcal.compare(back)
    assert compared[0]["label"] == "nominal"


def test_ctrl_c_interrupts_a_long_call_at_once() -> None:
    import os
    import signal

    # A plan from 4,000 candidates takes about a second (the fits here take < 0.1 s).
    start = time.perf_counter()
    spmcal.plan(40, candidates=4000)
    full = time.perf_counter() - start
    timer = threading.Timer(0.02, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        spmcal.plan(40, candidates=4000)
    interrupted = time.perf_counter() - start
    timer.join()
    # The wait polls for signals every 50 ms: back well before the plan would have been made.
    assert interrupted < 0.02 + 0.1 < full, (interrupted, full)


def test_export_writes_a_urdf_that_loads_as_the_calibrated_model(tmp_path: Path) -> None:
    calibration = spmcal.calibrate(spmcal.Session.load("datasets/agile_wrist_sim_20"))
    calibration.save(tmp_path / "params.yaml")
    spmcal.export(tmp_path / "params.yaml", tmp_path / "calibrated.urdf", model=MODEL)
    joints = np.array([[0.1, -0.2, 0.05]])
    exported = spmcal.Model.load(tmp_path / "calibrated.urdf").forward(joints)
    assert np.abs(exported - calibration.model.forward(joints)).max() < 1e-9
    with pytest.raises(spmcal.FileError, match="refusing to overwrite"):
        spmcal.export(tmp_path / "params.yaml", tmp_path / "params.yaml", model=MODEL)


def test_bad_arrays_and_single_rows() -> None:
    model = spmcal.Model.load(MODEL)
    joints = np.array([[0.1, -0.2, 0.05], [0.12, -0.18, 0.07]])
    with pytest.raises(spmcal.FileError, match="previous: expected one quaternion"):
        model.track(joints, np.zeros((0, 4)))
    assert isinstance(model.conditioning(joints[0]), float)
    loaded = spmcal.Session.load("datasets/agile_wrist_sim_20")
    markers = loaded.markers.copy()
    row, marker = map(int, np.argwhere(np.isfinite(markers[:, :, 0]))[0])
    markers[row, marker, 2] = np.nan  # one coordinate missing: neither seen nor unseen
    with pytest.raises(spmcal.FileError, match=f"row {row}, marker `{loaded.marker_names[marker]}`"):
        spmcal.Session.from_arrays(loaded.joints, markers, loaded.marker_names, model=MODEL)
    with pytest.raises(spmcal.FileError, match="times: row 0"):
        spmcal.Session.from_arrays(loaded.joints, loaded.markers, loaded.marker_names, model=MODEL,
                                   times=[float("nan")] * len(loaded))


def test_loading_warnings_are_python_warnings(tmp_path: Path) -> None:
    # A station that captures a marker twice (a retake) loads with a warning: a Python warning.
    session = tmp_path / "retake"
    shutil.copytree("datasets/agile_wrist_sequential_200", session)
    joints, markers = session / "joints.csv", session / "markers.csv"
    pose1 = joints.read_text().splitlines()[2].split(",")[1:4]
    joints.write_text(joints.read_text() + f"765,{','.join(pose1)},382.5,0\n")
    markers.write_text(markers.read_text() + "765,m2,-0.0726,0.0494,0.7581\n")
    with pytest.warns(UserWarning, match="a retake"):
        spmcal.Session.load(str(session))
    # A recording's last frame, stamped after the last encoder sample, is a note: no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spmcal.Session.load("datasets/agile_wrist_free_motion_120s")
