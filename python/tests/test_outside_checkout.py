"""The installed module away from the checkout (issue 37): shipped models by name and by default,
a parameters file that finds its model after it was copied, from an empty working folder.

Each check runs in a fresh interpreter whose working folder is an empty temporary folder and whose
import path holds no part of the repository, so the module can only be the installed wheel and
the models only the compiled-in ones.
"""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

from conftest import ROOT


def run_outside(tmp_path: Path, code: str) -> str:
    """Run `code` in a fresh interpreter in `tmp_path`, with nothing of the checkout importable."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run(
        [sys.executable, "-I", "-c", textwrap.dedent(code)],
        cwd=tmp_path, env=env, capture_output=True, text=True, check=False,
    )
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_the_wheel_plans_and_loads_shipped_models_from_an_empty_folder(tmp_path: Path) -> None:
    assert not any(tmp_path.iterdir())
    text = run_outside(tmp_path, """
        import os, spmcal
        assert not os.path.exists("models"), "the working folder must be empty"
        summary, quaternions, joints = spmcal.plan(10, candidates=200)
        print(quaternions.shape, joints.shape)
        for name in ("agile_wrist", "orbita3d"):
            model = spmcal.Model.load(name)
            print(name, (model.forward([0.0, 0.0, 0.0]).round(12) + 0.0).tolist())
    """)
    assert "(10, 4) (10, 3)" in text
    assert "agile_wrist [1.0, 0.0, 0.0, 0.0]" in text
    assert "orbita3d [1.0, 0.0, 0.0, 0.0]" in text


def test_a_copied_parameters_file_finds_its_model_and_exports(tmp_path: Path) -> None:
    # A simulated session's truth, its `model:` made a path that does not exist here: its
    # `model_sha256` is the shipped Agile Wrist's, which the module finds by it.
    truth = (ROOT / "datasets/agile_wrist_sim_20/truth.yaml").read_text()
    (tmp_path / "p.yaml").write_text(truth.replace("model: agile_wrist", "model: ../gone/agile_wrist.urdf"))
    session = tmp_path / "session"
    shutil.copytree(ROOT / "datasets/agile_wrist_sim_20", session)
    text = run_outside(tmp_path, """
        import spmcal
        model = spmcal.Model.from_params("p.yaml")
        exported = spmcal.export("p.yaml", "calibrated.urdf")
        back = spmcal.Model.load("calibrated.urdf")
        joints = [[0.1, -0.2, 0.15], [0.0, 0.05, -0.1]]
        print(abs(back.forward(joints) - model.forward(joints)).max() < 1e-9, exported.urdf)
        calibration = spmcal.calibrate(spmcal.Session.load("session"))
        print(calibration.verdict)
    """)
    lines = text.splitlines()
    assert lines[0] == "True calibrated.urdf", text
    assert lines[1] in ("PASS", "WARN"), text
