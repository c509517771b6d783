#!/usr/bin/env python3
"""Write docs/results/benchmarks.md: the README's benchmark table from what was measured.

Run from the repository root after `cargo bench` (criterion keeps its estimates under
`$CARGO_TARGET_DIR/criterion`, default `target/criterion`):

    cargo bench && python3 benches/results.py

After benchmarking some groups only (`cargo bench --bench calibration -- GROUP`),
`python3 benches/results.py --update` replaces their rows and keeps the others as they were.

Times are criterion's mean estimates. The other figures of the table are measured here with the
release binary: the fit's iterations (`--json` stages) on the shipped 400-pose session and on
simulated ten-minute and hour-long free-motion recordings, the hour-long calibration's peak
memory (the child process's maximum resident set), and the hour-long recording's size as a CSV
session and as a ROS 2 bag. `tests/readme_figures.rs` checks the README's table against the file
this writes. Only the standard library is used.
"""

import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

TARGET = Path(os.environ.get("CARGO_TARGET_DIR", "target"))
CRITERION = TARGET / "criterion"
BINARY = TARGET / "release" / "spmcal"

# (README row, criterion id: group/function as criterion's folders name it, target)
ROWS = [
    ("IK (three legs)", "ik", "≤ 200 ns"),
    ("tracking FDA (`track`, from 1 mrad away)", "fda_track", "≤ 1 µs"),
    ("working-mode FDA from home (`forward`)", "fda_forward_from_home", "—"),
    ("all assembly modes (`all_modes`, 8 solutions)", "fda_all_modes", "≤ 20 µs"),
    ("per-pose estimate, paper method, 4 markers", "estimate_pose_paper_4_markers", "≤ 500 ns"),
    ("`spmcal estimate` on 100,000 poses, end to end", "estimate_command/100000", "≤ ⅓ of before"),
    ("`spmcal calibrate` end to end, `agile_wrist_sim_400`", "calibrate_command/agile_wrist_sim_400", "≤ 100 ms"),
    ("marker-level `calibrate`, 27,000 poses (~100,000 observations)", "calibrate_markers_100k/27000", "≤ 3 s"),
    ("`spmcal calibrate` end to end, ten-minute free-motion recording", "calibrate_command_free_motion/600s", "≤ 3 s"),
    ("the same, hour-long recording", "calibrate_command_free_motion/3600s", "≤ 8 s, ≤ 400 MB"),
    ("reading the hour-long recording: CSV session", "read_hour_long_recording/csv", "—"),
    ("reading the hour-long recording: ROS 2 bag", "read_hour_long_recording/bag", "≤ 2× CSV"),
    ("`plan`: 40 poses from 2,000 candidates, end to end", "plan/command_40_of_2000", "≤ 2 s"),
    ("Rerun recording of the 400-pose calibration", "record/calibration_400_poses", "< 1 s"),
    ("`spmcal calibrate` end to end, a ten-minute recording seen as a stereo rig's pixels (the rig refined)", "calibrate_command_pixels/pixels_600s", "≤ 2× as points"),
    ("the same recording as the points its rig triangulates (`auto`)", "calibrate_command_pixels/points_600s", "—"),
]


def mean_ns(bench: str) -> float:
    path = CRITERION / bench / "new" / "estimates.json"
    if not path.exists():
        sys.exit(f"{path}: missing; run `cargo bench` first")
    return json.loads(path.read_text())["mean"]["point_estimate"]


def shown(ns: float) -> str:
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("µs", 1e3)):
        if ns >= scale:
            value = ns / scale
            return f"{value:.3g} {unit}" if value < 100 else f"{value:.0f} {unit}"
    return f"{ns:.0f} ns"


def run(*args: str) -> str:
    out = subprocess.run([str(BINARY), *args], capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"spmcal {' '.join(args)}: {out.stderr}")
    return out.stdout


def fit_iterations(dataset: Path, out: Path) -> int:
    report = json.loads(run("calibrate", "--dataset", str(dataset), "--out", str(out / "p.yaml"), "--json"))
    stages = report["results"]["stages"]
    return sum(s["iterations"] for s in stages if s["name"] == "calibration" or s["name"].startswith("refit"))


def recording(seconds: float, folder: Path) -> Path:
    config = Path("configs/simulate_agile_wrist_free_motion.yaml").read_text()
    lines = [f"  duration_s: {seconds}" if line.strip().startswith("duration_s:") else line for line in config.splitlines()]
    path = folder / f"sim_{seconds:.0f}.yaml"
    path.write_text("\n".join(lines).replace("../models/", str(Path("models").resolve()) + "/") + "\n")
    out = folder / f"recording_{seconds:.0f}"
    run("simulate", "--config", str(path), "--out", str(out))
    return out


def peak_memory_mb(*args: str) -> float:
    """The maximum resident set of one spmcal run, measured in a fresh Python child (so the
    figure is that run's alone: RUSAGE_CHILDREN keeps the maximum of all waited-for children)."""
    probe = (
        "import resource, subprocess, sys\n"
        "subprocess.run(sys.argv[1:], check=True, capture_output=True)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe, str(BINARY), *args], capture_output=True, text=True, check=True)
    return int(out.stdout) / 1024  # kB on Linux


def size_mb(path: Path) -> float:
    files = [path] if path.is_file() else [p for p in path.rglob("*") if p.is_file()]
    return sum(p.stat().st_size for p in files) / 1e6


def update() -> None:
    """`--update`: after `cargo bench` of some groups only, replace the rows criterion has
    estimates for and keep the others (and the figures) as the last full run wrote them, saying
    which rows were measured when."""
    out = Path("docs/results/benchmarks.md")
    old = out.read_text().splitlines()
    rows = {line.split(" | `")[1].split("`")[0]: line for line in old if line.startswith("| ") and " | `" in line}
    measured, lines = [], []
    for line in old:
        if line.startswith("| operation |"):
            break
        lines.append(line)
    lines += ["| operation | criterion id | mean | target |", "|---|---|---|---|"]
    for label, bench, target in ROWS:
        if (CRITERION / bench / "new" / "estimates.json").exists():
            measured.append(f"`{bench}`")
            lines.append(f"| {label} | `{bench}` | {shown(mean_ns(bench))} | {target} |")
        elif bench in rows:
            lines.append(rows[bench])
        else:
            sys.exit(f"{bench}: neither measured nor in {out}; run `cargo bench` for it")
    figures = old[old.index("| figure | value |") - 1:] if "| figure | value |" in old else []
    stamp = datetime.now(timezone.utc)
    lines.insert(lines.index("| operation | criterion id | mean | target |") - 1,
                 f"\nUpdated {stamp:%Y-%m-%d %H:%M UTC} on {machine()}, commit {commit()}: {', '.join(measured)} measured then; the other rows and the figures are the run above's.")
    temporary = out.with_suffix(".md.tmp")
    temporary.write_text("\n".join(lines + figures) + "\n")
    temporary.replace(out)
    print("\n".join(lines + figures))


def main() -> None:
    if "--update" in sys.argv[1:]:
        update()
        return
    if not BINARY.exists():
        sys.exit(f"{BINARY}: missing; `cargo build --release` first")
    lines = [
        "<!-- Written by `python3 benches/results.py` after `cargo bench`; do not edit: run them again. -->",
        "# Last benchmark results",
        "",
        f"Criterion's means from `{CRITERION}` (written {datetime.fromtimestamp(max(p.stat().st_mtime for p in CRITERION.rglob('estimates.json')), timezone.utc):%Y-%m-%d %H:%M UTC}), "
        f"on {machine()}; commit {commit()}.",
        "",
        "| operation | criterion id | mean | target |",
        "|---|---|---|---|",
    ]
    for label, bench, target in ROWS:
        lines.append(f"| {label} | `{bench}` | {shown(mean_ns(bench))} | {target} |")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        ten, hour = recording(600, folder), recording(3600, folder)
        bag = folder / "hour.mcap"
        run("convert", "--dataset", str(hour), "--to-bag", str(bag))
        lines += [
            "",
            "| figure | value |",
            "|---|---|",
            f"| fit iterations, `agile_wrist_sim_400` | {fit_iterations(Path('datasets/agile_wrist_sim_400'), folder)} |",
            f"| fit iterations, ten-minute recording | {fit_iterations(ten, folder)} |",
            f"| fit iterations, hour-long recording | {fit_iterations(hour, folder)} |",
            f"| peak memory of the hour-long calibration (MB) | {peak_memory_mb('calibrate', '--dataset', str(hour), '--out', str(folder / 'p.yaml')):.0f} |",
            f"| hour-long recording as a CSV session (MB) | {size_mb(hour):.0f} |",
            f"| hour-long recording as a ROS 2 bag, zstd (MB) | {size_mb(bag):.0f} |",
        ]
    out = Path("docs/results/benchmarks.md")
    temporary = out.with_suffix(".md.tmp")
    temporary.write_text("\n".join(lines) + "\n")
    temporary.replace(out)
    print("\n".join(lines))


def machine() -> str:
    model = next((l.split(":", 1)[1].strip() for l in Path("/proc/cpuinfo").read_text().splitlines() if l.startswith("model name")), platform.processor())
    return f"{model} ({os.cpu_count()} cores), Rust {subprocess.run(['rustc', '--version'], capture_output=True, text=True).stdout.split()[1]}"


def commit() -> str:
    out = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True, text=True)
    return out.stdout.strip() or "unknown"


if __name__ == "__main__":
    main()
