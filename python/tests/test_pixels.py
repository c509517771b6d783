"""Sessions seen through their cameras' pixels (issue 34): the pixels and cameras a session holds,
the rig a calibration refines, and the camchain it writes."""

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest

import spmcal
from conftest import ROOT, run

STEREO = "datasets/agile_wrist_stereo_200"


def pixel_rows(path: Path) -> list[tuple[str, str, str, float, float]]:
    """pixels.csv's rows, read with Python's csv module: (pose or time, marker, camera, u, v)."""
    with open(path, newline="") as f:
        return [(r[0], r[1], r[2], float(r[3]), float(r[4])) for r in list(csv.reader(f))[1:]]


def test_a_static_pixel_sessions_pixels_are_its_pixels_csv() -> None:
    session = spmcal.Session.load(STEREO)
    assert session.cameras == ["cam0", "cam1"]
    pixels = session.pixels
    assert set(pixels) == {"pose", "marker", "camera", "uv"}
    rows = pixel_rows(ROOT / STEREO / "pixels.csv")
    k = len(rows)
    assert k == 1535
    assert pixels["pose"].shape == (k,) and pixels["pose"].dtype == np.uint64
    assert pixels["marker"].shape == (k,) and pixels["camera"].shape == (k,)
    assert pixels["uv"].shape == (k, 2) and pixels["uv"].dtype == np.float64
    # The same rows, to the bit (the file holds full precision).
    names, cameras = session.marker_names, session.cameras
    got = sorted(
        (str(int(p)), names[int(m)], cameras[int(c)], float(uv[0]), float(uv[1]))
        for p, m, c, uv in zip(pixels["pose"], pixels["marker"], pixels["camera"], pixels["uv"])
    )
    assert got == sorted(rows)


def test_a_session_of_points_has_no_cameras_and_no_pixels() -> None:
    session = spmcal.Session.load("datasets/agile_wrist_sim_20")
    assert session.cameras == []
    pixels = session.pixels
    assert pixels["pose"].shape == (0,) and pixels["uv"].shape == (0, 2)


@pytest.mark.filterwarnings("ignore:.*falls outside the encoder stream")
def test_a_recordings_pixels_carry_their_capture_times(cli: str, tmp_path: Path) -> None:
    # The shipped ten-minute configuration, 20 s long (its model's path made absolute).
    text = (ROOT / "configs/simulate_agile_wrist_stereo_free_motion.yaml").read_text()
    text = text.replace("duration_s: 600", "duration_s: 20").replace(
        "model: ../models/agile_wrist.urdf", f"model: {ROOT / 'models/agile_wrist.urdf'}"
    )
    config = tmp_path / "config.yaml"
    config.write_text(text)
    out = run(cli, "simulate", "--config", str(config), "--out", str(tmp_path / "rec"))
    assert out.returncode == 0, out.stderr
    session = spmcal.Session.load(tmp_path / "rec")
    assert session.kind == "free_motion" and session.cameras == ["cam0", "cam1"]
    pixels = session.pixels
    assert set(pixels) == {"time_s", "marker", "camera", "uv"}
    rows = pixel_rows(tmp_path / "rec" / "pixels.csv")
    assert len(rows) > 100 and pixels["time_s"].shape == (len(rows),)
    names, cameras = session.marker_names, session.cameras
    got = [
        (float(t), names[int(m)], cameras[int(c)], float(uv[0]), float(uv[1]))
        for t, m, c, uv in zip(pixels["time_s"], pixels["marker"], pixels["camera"], pixels["uv"])
    ]
    assert got == [(float(t), m, c, u, v) for t, m, c, u, v in rows]


@pytest.fixture(scope="module")
def stereo_calibration() -> spmcal.Calibration:
    return spmcal.calibrate(spmcal.Session.load(ROOT / STEREO))


def test_the_calibration_refines_the_rig_and_writes_it_as_the_command_line_does(
    stereo_calibration: spmcal.Calibration, cli: str, tmp_path: Path
) -> None:
    rig = stereo_calibration.rig
    assert rig is not None
    # The report's own terms.
    assert rig == stereo_calibration.to_dict()["markers"]["rig"]
    assert rig["baseline_held_m"] == pytest.approx(0.1206, abs=1e-3)
    terms = {t["name"]: t for t in rig["terms"]}
    for name in ["cam0.fu", "cam0.pv", "cam1.fv", "cam1.k1", "cam1.rotation_x", "cam1.baseline_direction_0"]:
        assert name in terms, f"{name} not in {sorted(terms)}"
    fitted = [t for t in rig["terms"] if not t["held"]]
    assert fitted and all(t["std_error"] is not None and t["std_error"] > 0 for t in fitted)
    assert [c for c, _, _ in rig["pixel_noise_px"]] == ["cam0", "cam1"]

    # The camchain: the command line's --cameras-out, byte for byte, and read back as a session's.
    written = tmp_path / "cameras.yaml"
    stereo_calibration.write_cameras(written)
    out = run(cli, "calibrate", "--dataset", STEREO, "--out", str(tmp_path / "p.yaml"),
              "--cameras-out", str(tmp_path / "cli_cameras.yaml"))
    assert out.returncode == 0, out.stderr
    assert written.read_text() == (tmp_path / "cli_cameras.yaml").read_text()
    # Each intrinsic is the file's value plus the fit's change (the report's terms).
    text = written.read_text()
    for camera in ["cam0", "cam1"]:
        section = text.split(f"{camera}:\n")[1]
        line = next(ln for ln in section.splitlines() if ln.strip().startswith("intrinsics:"))
        values = [float(v) for v in line.split("[")[1].rstrip("]").split(",")]
        for name, value in zip(["fu", "fv", "pu", "pv"], values):
            t = terms[f"{camera}.{name}"]
            assert t["file_value"] is not None
            assert value == pytest.approx(t["file_value"] + t["change"], abs=1e-9), f"{camera}.{name}"
    folder = tmp_path / "session"
    shutil.copytree(ROOT / STEREO, folder)
    shutil.copy(written, folder / "cameras.yaml")
    again = spmcal.Session.load(folder, model=ROOT / "models/agile_wrist.urdf")
    assert again.cameras == ["cam0", "cam1"] and len(again) == 200


def test_a_calibration_of_points_has_no_rig_to_write(tmp_path: Path) -> None:
    calibration = spmcal.calibrate(spmcal.Session.load("datasets/agile_wrist_sim_20"))
    assert calibration.rig is None
    with pytest.raises(spmcal.CalibrationError, match="no camera rig"):
        calibration.write_cameras(tmp_path / "cameras.yaml")
    assert not (tmp_path / "cameras.yaml").exists()
