"""Shared fixtures: the repository root (datasets, models) and the command-line program."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def at_root(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every test runs at the repository root, as the command line's examples do."""
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="session")
def cli() -> str:
    """The `spmcal` program of the same build: `SPMCAL_BIN`, else the one on PATH."""
    program = os.environ.get("SPMCAL_BIN") or shutil.which("spmcal")
    if not program:
        pytest.fail("set SPMCAL_BIN to the spmcal program (e.g. $CARGO_TARGET_DIR/release/spmcal)")
    return program


def run(cli: str, *args: str) -> subprocess.CompletedProcess[str]:
    """Run the command line at the repository root."""
    return subprocess.run([cli, *args], cwd=ROOT, capture_output=True, text=True, check=False)
