"""numpy as numpy users expect (issue 37, point 3): any array-like in, one-line errors naming the
argument, a Model wherever a model is expected, results in the report's units with names."""

import re
from pathlib import Path
from typing import Any, Callable

import numpy as np
import numpy.typing as npt
import pytest

import spmcal
from conftest import run

MODEL = "models/agile_wrist.urdf"
SESSION = "datasets/agile_wrist_sim_20"
JOINTS_EXPECTED = "joints: expected an (n, 3) array of joint readings in rad or one reading (3,)"


def reachable_joints(n: int = 6) -> npt.NDArray[np.float64]:
    """Readings of the working mode at tilts and yaws within 17 degrees (the IK of rotations)."""
    rng = np.random.default_rng(11)
    rotvec = rng.uniform(-0.2, 0.2, size=(n, 3))
    angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
    q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * rotvec / angle])
    return spmcal.Model.load(MODEL).ik(q)


# --- Any array-like, converted as np.asarray(x, dtype=float64) converts it -----------------------
# Each conversion must give bit for bit what the float64 array of the same values gives: the
# same numbers reach the same Rust code, so any difference would be a conversion bug.


def test_a_list_of_rows_is_the_array() -> None:
    model, joints = spmcal.Model.load(MODEL), reachable_joints()
    assert np.array_equal(model.forward(joints.tolist()), model.forward(joints))
    assert np.array_equal(model.forward(list(joints[0])), model.forward(joints[0]))


def test_a_tuple_is_the_array() -> None:
    model, joints = spmcal.Model.load(MODEL), reachable_joints()
    rows = tuple(tuple(float(v) for v in row) for row in joints)
    assert np.array_equal(model.forward(rows), model.forward(joints))
    q = model.forward(joints)
    assert np.array_equal(model.track(rows, tuple(q[0])), model.track(joints, q[0]))


def test_float32_is_read_as_its_float64_values() -> None:
    model, joints = spmcal.Model.load(MODEL), reachable_joints()
    single = joints.astype(np.float32)
    assert np.array_equal(model.forward(single), model.forward(single.astype(np.float64)))
    # float32 holds the readings to ~1e-8 rad, so the orientations agree to that order.
    assert np.abs(model.forward(single) - model.forward(joints)).max() < 1e-6
    q = model.forward(joints)
    assert np.array_equal(model.ik(q.astype(np.float32)), model.ik(q.astype(np.float32).astype(np.float64)))


def test_integers_are_read_as_floats() -> None:
    model = spmcal.Model.load(MODEL)
    for dtype in (np.int64, np.int32, np.uint8):
        home = model.forward(np.zeros((2, 3), dtype=dtype))
        assert np.array_equal(home, model.forward(np.zeros((2, 3))))
    assert np.array_equal(model.ik([1, 0, 0, 0]), model.ik(np.array([1.0, 0.0, 0.0, 0.0])))
    assert np.array_equal(model.conditioning([[0, 0, 0]]), model.conditioning(np.zeros((1, 3))))


def test_non_contiguous_views_are_read_through_their_strides() -> None:
    model, joints = spmcal.Model.load(MODEL), reachable_joints()
    wide = np.zeros((len(joints), 6))
    wide[:, ::2] = joints
    column_slice = wide[:, ::2]  # every other column: strides (48, 16)
    assert not column_slice.flags.c_contiguous
    assert np.array_equal(model.forward(column_slice), model.forward(joints))
    fortran = np.asfortranarray(joints)
    assert np.array_equal(model.jacobians(fortran), model.jacobians(joints))
    reversed_rows = joints[::-1]  # negative strides
    assert np.array_equal(model.forward(reversed_rows), model.forward(joints)[::-1])


def test_a_session_from_lists_and_float32_is_the_session_from_arrays() -> None:
    loaded = spmcal.Session.load(SESSION)
    from_arrays = spmcal.Session.from_arrays(loaded.joints, loaded.markers, loaded.marker_names, model=MODEL)
    from_lists = spmcal.Session.from_arrays(
        loaded.joints.tolist(), loaded.markers.tolist(), tuple(loaded.marker_names), model=MODEL,
        poses=loaded.poses, times=np.arange(len(loaded), dtype=np.float32))
    assert np.array_equal(from_lists.joints, from_arrays.joints)
    assert np.array_equal(from_lists.markers, from_arrays.markers, equal_nan=True)
    assert np.array_equal(from_lists.poses, loaded.poses)
    assert np.array_equal(from_lists.times, np.arange(len(loaded), dtype=np.float64))


# --- Wrong shapes and wrong contents: one line, naming the argument ------------------------------


@pytest.mark.parametrize("shape", [(4,), (2, 4), (5, 3, 1), (), (0,)])
def test_a_wrong_shape_is_one_shape_error_naming_the_argument(shape: tuple[int, ...]) -> None:
    model = spmcal.Model.load(MODEL)
    given = "(" + ", ".join(map(str, shape)) + ("," if len(shape) == 1 else "") + ")"
    for call in (model.forward, model.jacobians, model.conditioning):
        with pytest.raises(spmcal.ShapeError) as raised:
            call(np.zeros(shape))
        assert str(raised.value) == f"{JOINTS_EXPECTED}, got shape {given}"
    assert isinstance(raised.value, ValueError) and isinstance(raised.value, spmcal.SpmcalError)


def test_the_other_shapes_name_their_argument() -> None:
    model = spmcal.Model.load(MODEL)
    cases: list[tuple[Callable[[], Any], str]] = [
        (lambda: model.ik(np.zeros((3, 3))),
         "q: expected an (n, 4) array of unit quaternions qw, qx, qy, qz or one quaternion (4,), got shape (3, 3)"),
        (lambda: model.track(np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1))),
         "previous: expected one quaternion qw, qx, qy, qz (of unit norm), shape (4,), got shape (2, 4)"),
        (lambda: model.all_modes(np.zeros((2, 3))),
         "joints: expected one set of joint readings in rad, shape (3,) (all_modes solves one), got shape (2, 3)"),
        (lambda: model.forward([[0.0, 0.0, 0.0], [0.0, 0.0]]),
         f"{JOINTS_EXPECTED}, got a ragged sequence (rows of different lengths)"),
    ]
    loaded = spmcal.Session.load(SESSION)
    n, m = len(loaded), len(loaded.marker_names)
    cases.append((
        lambda: spmcal.Session.from_arrays(loaded.joints, loaded.markers[:, :, :2], loaded.marker_names, model=MODEL),
        f"markers: expected shape ({n}, {m}, 3), marker positions in m (poses, marker_names, xyz; NaN where unseen), "
        f"got shape ({n}, {m}, 2)"))
    cases.append((
        lambda: spmcal.Session.from_arrays(loaded.joints, loaded.markers, loaded.marker_names, model=MODEL,
                                           times=np.zeros(n + 1)),
        f"times: expected ({n},): a time in s per row of joints, got shape ({n + 1},)"))
    for call, message in cases:
        with pytest.raises(spmcal.ShapeError) as raised:
            call()
        assert str(raised.value) == message


def test_strings_and_other_non_numbers_are_one_array_error() -> None:
    model = spmcal.Model.load(MODEL)
    cases: list[tuple[Any, str]] = [
        (np.array(["a", "b", "c"]), "numpy cannot read the ndarray of dtype <U1 as float64: could not convert string to float"),
        ([["0.1", "x", "0"]], "numpy cannot read the list as float64: could not convert string to float"),
        ({"theta1": 0.1}, "numpy cannot read the dict as float64: float() argument must be"),
    ]
    for bad, reason in cases:
        with pytest.raises(spmcal.ArrayError) as raised:
            model.forward(bad)
        text = str(raised.value)
        assert text.startswith(f"{JOINTS_EXPECTED}; {reason}"), text
        assert "\n" not in text and not isinstance(raised.value, spmcal.ShapeError)
        assert isinstance(raised.value, ValueError)
    with pytest.raises(spmcal.ArrayError, match=r"^joints: row 1 is \[0, NaN, 0\], not finite: expected"):
        model.forward([[0.0, 0.0, 0.0], [0.0, np.nan, 0.0]])
    with pytest.raises(spmcal.ArrayError, match=r"^poses: expected \(20,\): an integer pose id per row of joints, got dtype float64$"):
        loaded = spmcal.Session.load(SESSION)
        spmcal.Session.from_arrays(loaded.joints, loaded.markers, loaded.marker_names, model=MODEL,
                                   poses=np.arange(20) * 1.5)


# --- A Model wherever a model is expected --------------------------------------------------------


def test_a_unit_mistake_is_named_as_one() -> None:
    """Joints in degrees and markers in millimetres are said to be so (issue 37), not left to the
    FDA's "near a singularity" or the fit's iterations."""
    loaded = spmcal.Session.load(SESSION)
    with pytest.raises(spmcal.KinematicsError, match="look like degrees; spmcal reads joints in radians"):
        spmcal.Model.load("agile_wrist").forward(np.degrees(loaded.joints[:5]) + 20.0)
    with pytest.raises(spmcal.FileError, match="looks like degrees; spmcal reads joints in radians"):
        spmcal.Session.from_arrays(np.degrees(loaded.joints) + 20.0, loaded.markers, loaded.marker_names, model=MODEL)
    with pytest.raises(spmcal.FileError, match="looks like millimetres; spmcal reads metres"):
        spmcal.Session.from_arrays(loaded.joints, loaded.markers * 1000.0, loaded.marker_names, model=MODEL)


def test_a_model_is_accepted_wherever_a_model_path_is(tmp_path: Path) -> None:
    model = spmcal.Model.load(MODEL)
    session = spmcal.Session.load(SESSION, model=model)
    assert session.model == spmcal.Session.load(SESSION, model=MODEL).model
    by_model, by_path = spmcal.calibrate(session, model=model), spmcal.calibrate(session, model=MODEL)
    assert np.array_equal(by_model.covariance, by_path.covariance)
    made = spmcal.Session.from_arrays(session.joints, session.markers, session.marker_names, model=model)
    assert np.array_equal(spmcal.calibrate(made).covariance, by_path.covariance)
    # As parameters: a calibration's Model compares and exports as its saved file does.
    by_path.save(tmp_path / "params.yaml")
    from_model = spmcal.compare(session, params=[by_path.model], model=model)
    from_file = spmcal.compare(session, params=tmp_path / "params.yaml")
    # The file holds the parameters as text (the geometry re-derived when read): they agree to
    # ~1e-8 relative; the nominal model's error is 3x the calibrated one, so 1e-6 tells them apart.
    assert [c["rms"] for c in from_model] == pytest.approx([c["rms"] for c in from_file], rel=1e-6)
    assert from_model[1]["rms"] < from_model[0]["rms"] / 3
    exported = spmcal.export(by_path.model, tmp_path / "calibrated.urdf")
    joints = reachable_joints()
    back = spmcal.Model.load(exported.urdf).forward(joints)
    assert np.abs(back - by_path.model.forward(joints)).max() < 1e-9
    summary, q, _ = spmcal.plan(12, model=model, params=by_path.model, candidates=300)
    assert q.shape == (12, 4) and summary["poses"] == 12
    assert spmcal.Model.from_params(tmp_path / "params.yaml", urdf=model).marker_names == model.marker_names


def test_a_model_argument_of_another_type_or_without_urdf_says_so(tmp_path: Path) -> None:
    session = spmcal.Session.load(SESSION)
    with pytest.raises(TypeError) as raised:
        spmcal.calibrate(session, model=3)  # type: ignore[arg-type]
    assert str(raised.value) == "model: expected a spmcal.Model or the path of a model's URDF (str or os.PathLike), got int"
    with pytest.raises(TypeError) as not_params:
        spmcal.compare(session, params=[2.5])  # type: ignore[list-item]
    assert str(not_params.value) == \
        "params[0]: expected a spmcal.Model or the path of a parameters file (str or os.PathLike), got float"
    with pytest.raises(TypeError, match="^params: expected a spmcal.Model, the path of a parameters file, or a list"):
        spmcal.compare(session, params=7)  # type: ignore[arg-type]
    calibration = spmcal.calibrate(session)
    calibration.save(tmp_path / "params.yaml")
    # Moved where its `model:` leads nowhere: found by its `model_sha256` (the shipped model's) ...
    text = (tmp_path / "params.yaml").read_text().replace("model: agile_wrist", "model: elsewhere/agile_wrist.urdf")
    (tmp_path / "moved.yaml").write_text(text)
    moved = spmcal.Model.from_params(tmp_path / "moved.yaml")
    assert np.abs(moved.forward([0.1, -0.2, 0.15]) - calibration.model.forward([0.1, -0.2, 0.15])).max() < 1e-12
    # ... and without it, a one-line error naming the file's `model:` line and what gives the model.
    orphan_text = "".join(l for l in text.splitlines(keepends=True) if not l.startswith("model_sha256:"))
    (tmp_path / "orphan.yaml").write_text(orphan_text)
    line = orphan_text.splitlines().index("model: elsewhere/agile_wrist.urdf") + 1
    with pytest.raises(spmcal.ModelError) as no_urdf:
        spmcal.Model.from_params(tmp_path / "orphan.yaml")
    message = str(no_urdf.value)
    assert "\n" not in message
    assert message.startswith(
        f"{tmp_path / 'orphan.yaml'}:{line}: the model `{tmp_path / 'elsewhere/agile_wrist.urdf'}` named by this "
        "parameters file (its `model:`) cannot be loaded"), message
    assert "give the model with --model (Python: urdf=)" in message, message
    assert spmcal.Model.from_params(tmp_path / "orphan.yaml", urdf="agile_wrist").forward([0.0, 0.0, 0.0])[0] > 0.99


# --- Results in the report's units, with names ---------------------------------------------------


def report_figures(text: str) -> dict[str, list[str]]:
    """The text report's figures by parameter name, as printed."""
    figures: dict[str, list[str]] = {}
    lines = text.splitlines()
    start = lines.index("parameter                    change (deg)   std error (deg)")
    for line in lines[start + 1:]:
        row = re.fullmatch(r"  (\S+)\s+([+-]\d+\.\d{5})\s+(\d+\.\d{5})", line)
        held = re.fullmatch(r"  (\S+)\s+([+-]\d+\.\d{5})\s+(frozen|at bound)", line)
        if held:  # a parameter held (the sag `auto` held): its change only
            figures[held[1]] = [held[2]]
            continue
        if not row:
            break
        figures[row[1]] = [row[2], row[3]]
    # The joint scales, after the angles: the scale, its change and standard error in ppm, or held.
    for row in re.finditer(r"^  (leg\d\.scale)\s+(\d\.\d{6}) \((?:([+-]\d+) ± (\d+) ppm|held.*|frozen)\)$", text, re.MULTILINE):
        figures[row[1]] = [row[2]] + ([row[3], row[4]] if row[3] else [])
    number = r"([+-]?\d+\.\d+)"
    t = re.search(rf"camera translation t_CB: \[{number}, {number}, {number}\] m "
                  rf"\(± \[{number}, {number}, {number}\] mm\)", text)
    assert t, text
    for k, axis in enumerate("xyz"):
        figures[f"camera.t_{axis}"] = [t[1 + k], t[4 + k]]
    scale = re.search(rf"camera model: depth_scale — depth_scale {number} ± {number}", text)
    assert scale, text
    figures["camera.depth_scale"] = [scale[1], scale[2]]
    latency = re.search(rf"camera latency: {number} ± {number} ms", text)
    if latency:
        figures["camera.latency"] = [latency[1], latency[2]]
    clock = re.search(rf"camera clock rate: {number} ± {number} ppm", text)
    if clock:
        figures["camera.clock_rate"] = [clock[1], clock[2]]
    triple = rf"\[\s*{number},\s*{number},\s*{number}\]"
    for row in re.finditer(rf"^  (\S+)\s+{triple}\s+{triple}\s+{triple}$", text, re.MULTILINE):
        for k, axis in enumerate("xyz"):
            figures[f"{row[1]}.{axis}"] = [row[2 + k], row[5 + k], row[8 + k]]
    return figures


def table_rows(table: spmcal.ParametersTable) -> list[dict[str, Any]]:
    """The table's columns as rows; every column must have a value for every row."""
    columns: dict[str, list[Any]] = {
        "name": table["name"], "value": table["value"], "change": table["change"],
        "std_error": table["std_error"], "unit": table["unit"], "status": table["status"]}
    assert list(columns) == list(table)  # these columns, in this order, and no other
    n = len(table["name"])
    assert all(len(column) == n for column in columns.values())
    return [{key: column[i] for key, column in columns.items()} for i in range(n)]


def assert_table_is_the_report(calibration: spmcal.Calibration) -> int:
    """Every row of the table printed as the report prints it gives the report's figures: a unit
    off by 1000 or by 180/pi, or a figure from elsewhere, changes the printed digits. Returns the
    number of rows compared."""
    table = calibration.parameters_table()
    figures = report_figures(str(calibration))
    rows = table_rows(table)
    assert [r["name"] for r in rows] and set(figures) == {r["name"] for r in rows}
    for r in rows:
        printed = figures[r["name"]]
        if r["name"] == "platform.sag":  # degrees per unit of arm; held by `auto` on a clean session
            fitted = r["status"] == "fitted"
            assert [f"{r['change']:+.5f}"] + ([f"{r['std_error']:.5f}"] if fitted else []) == printed, r
            continue
        if r["unit"] == "deg":
            assert [f"{r['change']:+.5f}", f"{r['std_error']:.5f}"] == printed, r
        elif r["name"].startswith("camera.t_"):
            assert [f"{r['value'] / 1e3:.4f}", f"{r['std_error']:.4f}"] == printed, r
        elif r["name"].endswith(".scale"):  # a joint scale: the scale, its change and σ in ppm
            held = r["status"] != "fitted"
            assert [f"{r['value']:.6f}"] + ([] if held else [f"{r['change']:+.0f}", f"{r['std_error']:.0f}"]) == printed, r
            continue
        elif r["unit"] == "ms":
            assert [f"{r['value']:.3f}", f"{r['std_error']:.3f}"] == printed, r
        elif r["unit"] == "ppm":
            assert [f"{r['value']:+.2f}", f"{r['std_error']:.2f}"] == printed, r
        elif r["unit"] == "":
            assert [f"{r['value']:.5f}", f"{r['std_error']:.5f}"] == printed, r
        else:  # a marker: fitted position in m, change and standard error in mm
            assert r["unit"] == "mm"
            assert [f"{r['value'] / 1e3:+.5f}", f"{r['change']:+.3f}", f"{r['std_error']:.3f}"] == printed, r
        assert r["status"] == "fitted"
    return len(rows)


def test_the_parameters_table_is_the_text_reports_figures_in_its_units() -> None:
    # The depth-scale model named: the table's depth-scale row against the report's (the default,
    # `auto`, chooses a perfect camera here and holds the depth scale).
    calibration = spmcal.calibrate(spmcal.Session.load(SESSION), camera_model="depth_scale")
    # 18 angles, the sag, 3 scales, t_CB, the depth scale, 4 markers.
    assert assert_table_is_the_report(calibration) == 18 + 1 + 3 + 3 + 1 + 4 * 3
    rows = {r["name"]: r for r in table_rows(calibration.parameters_table())}
    # A link angle's value is the calibrated angle: the nominal model's plus the change.
    nominal = spmcal.Model.load(MODEL).to_dict()["legs"][0]["alpha1_deg"]
    assert rows["leg1.alpha1"]["value"] == pytest.approx(nominal + rows["leg1.alpha1"]["change"], abs=1e-9)
    # The table's standard errors are the covariance's, converted: rad to deg, m to mm.
    se = calibration.std_errors
    assert rows["leg1.alpha1"]["std_error"] == pytest.approx(np.degrees(se["leg1.alpha1"]), rel=1e-12)
    assert rows["m2.y"]["std_error"] == pytest.approx(se["m2.y"] * 1e3, rel=1e-12)


def test_a_free_motion_calibrations_latency_is_in_the_table_in_ms() -> None:
    # Its last frame, after the last encoder sample, is a note: no Python warning.
    session = spmcal.Session.load("datasets/agile_wrist_free_motion_120s")
    calibration = spmcal.calibrate(session, camera_model="depth_scale")
    assert assert_table_is_the_report(calibration) > 18
    table = calibration.parameters_table()
    latency = table["value"][table["name"].index("camera.latency")]
    # The session was simulated with a 40 ms latency (README): the table says ms, not s.
    assert 30 < latency < 50


def test_std_errors_are_in_the_covariances_order_and_units() -> None:
    calibration = spmcal.calibrate(spmcal.Session.load(SESSION))
    names, units = calibration.parameter_names, calibration.parameter_units
    assert list(calibration.std_errors) == [n for n in names if n in calibration.std_errors]
    assert dict(zip(names, units))["leg1.alpha1"] == "rad" and dict(zip(names, units))["camera.t_z"] == "m"
    assert dict(zip(names, units))["camera.depth_scale"] == "" and dict(zip(names, units))["m1.x"] == "m"
    diagonal = np.sqrt(np.diag(calibration.covariance))
    assert list(calibration.std_errors.values()) == [d for d in diagonal if d > 0]


def test_str_is_the_text_report_and_the_verdict_is_its_word(cli: str, tmp_path: Path) -> None:
    out = run(cli, "calibrate", "--dataset", SESSION, "--out", str(tmp_path / "p.yaml"))
    assert out.returncode == 0, out.stderr
    calibration = spmcal.calibrate(spmcal.Session.load(SESSION))
    assert str(calibration) + f"wrote {tmp_path / 'p.yaml'}\n" == out.stdout
    assert f"verdict: {calibration.verdict}: {calibration.verdict_reason}\n" in out.stdout
    assert calibration.verdict == "PASS" and calibration.passed and calibration.verdict_reasons == []
    check = calibration.model_check
    assert check is not None and check["passed"] and 0.0 <= check["p_value"] <= 1.0
    # An accuracy no calibration of 20 poses reaches: the report says FAIL with the reason, and so
    # does Python; the camera's noise (the old `pass_held_out_mm`) decides nothing any more.
    strict = spmcal.calibrate(spmcal.Session.load(SESSION), required_accuracy_deg=1e-4)
    assert strict.verdict == "FAIL" and not strict.passed
    assert f"verdict: FAIL: {strict.verdict_reason}\n" in str(strict)
    assert [r["level"] for r in strict.verdict_reasons] == ["FAIL"]
    assert "required" in strict.verdict_reasons[0]["finding"]
    assert repr(strict).startswith("Calibration(agile_wrist_sim_20: FAIL, predicted error ")
    assert spmcal.calibrate(spmcal.Session.load(SESSION), pass_held_out_mm=0.01).verdict == "PASS"


def test_export_returns_what_it_wrote(tmp_path: Path) -> None:
    calibration = spmcal.calibrate(spmcal.Session.load(SESSION))
    calibration.save(tmp_path / "params.yaml")
    exported = spmcal.export(tmp_path / "params.yaml", tmp_path / "calibrated.urdf", model=MODEL)
    assert isinstance(exported, spmcal.Exported)
    assert exported.urdf == tmp_path / "calibrated.urdf" and exported.urdf.exists()
    assert exported.companion == tmp_path / "calibrated.yaml" and exported.companion.exists()
    assert exported.warnings == []
    # The companion of `params.urdf` would be `params.yaml`, the input: refused before writing.
    with pytest.raises(spmcal.FileError, match=r"params\.yaml: is an input of this call: refusing to overwrite it$"):
        spmcal.export(tmp_path / "params.yaml", tmp_path / "params.urdf", model=MODEL)
    assert not (tmp_path / "params.urdf").exists()


def test_numpy_scalars_are_settings_as_python_numbers_are() -> None:
    session = spmcal.Session.load(SESSION)
    plain = spmcal.calibrate(session, folds=5, pass_held_out_mm=0.5)
    from_numpy = spmcal.calibrate(session, folds=np.int64(5), pass_held_out_mm=np.float32(0.5))
    assert np.array_equal(plain.covariance, from_numpy.covariance)
    assert plain.verdict_reason == from_numpy.verdict_reason
    with pytest.raises(spmcal.ConfigError, match="^settings are numbers, strings, lists or dicts of them: "):
        spmcal.calibrate(session, folds=object())
