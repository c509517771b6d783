//! No output may overwrite an input: every command is run with each of its outputs set to each of
//! its inputs — the path itself, the path spelled another way, a symbolic link to it and a hard
//! link to it; for `export`'s companion, a `--urdf` whose `.yaml` is one of those; for an output
//! folder, the folder that holds the input (as it is, spelled otherwise, or through a link to it)
//! and a session folder whose `session.yaml` is a hard or symbolic link to the input — and must
//! refuse before any work with one `error:` line naming the option, leaving every input byte for
//! byte as it was and no temporary file behind.
//!
//! The inputs are copies in a temporary folder laid out as the repository is (`models/`,
//! `datasets/`, `configs/`), and the commands run there, so that the paths files name relative to
//! the working directory (a parameters file's `model`) lead to the copies too.

// Symbolic and hard links as Unix makes them.
#![cfg(unix)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const SIM: &str = "datasets/sim";
const FREE: &str = "datasets/free";
const MODEL: &str = "models/agile_wrist.urdf";
const COMPANION: &str = "models/agile_wrist.yaml";
const OTHER: &str = "other/m.urdf";
const OTHER_COMPANION: &str = "other/m.yaml";
const PARAMS: &str = "params.yaml";
const SIM_CONFIG: &str = "configs/simulate.yaml";
const CALIB_CONFIG: &str = "configs/calibrate.yaml";
const PLAN: &str = "plan.csv";
const JOINTS: &str = "joystick/joints.csv";
const ORIENTATIONS: &str = "joystick/orientations.csv";

fn spmcal(dir: &Path, args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_spmcal")).current_dir(dir).args(args).output().unwrap()
}

fn copy(from: &str, to: &Path) {
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(from, to).unwrap();
}

/// The inputs every scenario may use, copied (a short stretch of the free-motion recording).
fn workspace() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    copy("models/agile_wrist.urdf", &w.join(MODEL));
    copy("models/agile_wrist.yaml", &w.join(COMPANION));
    copy("models/agile_wrist.urdf", &w.join(OTHER));
    copy("models/agile_wrist.yaml", &w.join(OTHER_COMPANION));
    for name in ["session.yaml", "joints.csv", "markers.csv", "truth.yaml", "truth_orientations.csv"] {
        copy(&format!("datasets/agile_wrist_sim_20/{name}"), &w.join(SIM).join(name));
    }
    let free = "datasets/agile_wrist_free_motion_120s";
    for name in ["session.yaml", "truth.yaml"] {
        copy(&format!("{free}/{name}"), &w.join(FREE).join(name));
    }
    // Six seconds: encoders at 100 Hz, the captures well inside them.
    let time = |line: &str| line.split(',').next().unwrap().parse::<f64>().unwrap();
    let encoders = std::fs::read_to_string(format!("{free}/encoders.csv")).unwrap();
    let mut lines = encoders.lines();
    let mut text = format!("{}\n", lines.next().unwrap());
    for line in lines.step_by(10).take_while(|l| time(l) < 6.0) {
        text += &format!("{line}\n");
    }
    std::fs::write(w.join(FREE).join("encoders.csv"), text).unwrap();
    let captures = std::fs::read_to_string(format!("{free}/captures.csv")).unwrap();
    let mut lines = captures.lines();
    let mut text = format!("{}\n", lines.next().unwrap());
    for line in lines.filter(|l| (0.3..5.5).contains(&time(l))) {
        text += &format!("{line}\n");
    }
    std::fs::write(w.join(FREE).join("captures.csv"), text).unwrap();
    copy("datasets/joystick_circle/joints.csv", &w.join(JOINTS));
    copy("datasets/joystick_circle/orientations.csv", &w.join(ORIENTATIONS));
    copy("datasets/agile_wrist_sim_20/truth.yaml", &w.join(PARAMS));
    copy("configs/simulate_agile_wrist.yaml", &w.join(SIM_CONFIG));
    copy("configs/calibrate.yaml", &w.join(CALIB_CONFIG));
    // The shipped files name the compiled-in model (`model: agile_wrist`); here they name the
    // copy by its path (relative to each file), so that every command reads a model file.
    for (file, path) in [
        (format!("{SIM}/session.yaml"), "../../models/agile_wrist.urdf"),
        (format!("{FREE}/session.yaml"), "../../models/agile_wrist.urdf"),
        (PARAMS.to_string(), "models/agile_wrist.urdf"),
        (SIM_CONFIG.to_string(), "../models/agile_wrist.urdf"),
    ] {
        let text = std::fs::read_to_string(w.join(&file)).unwrap();
        assert!(text.contains("\nmodel: agile_wrist"), "{file}");
        std::fs::write(w.join(&file), text.replacen("\nmodel: agile_wrist", &format!("\nmodel: {path}"), 1)).unwrap();
    }
    std::fs::create_dir(w.join("out")).unwrap();
    let plan = spmcal(w, &args("plan --poses 8 --candidates 100 --out plan.csv"));
    assert!(plan.status.success(), "{}", String::from_utf8_lossy(&plan.stderr));
    tmp
}

fn args(line: &str) -> Vec<String> {
    line.split_whitespace().map(String::from).collect()
}

/// What kind of output an option writes.
#[derive(Clone, Copy)]
enum Out {
    /// A file.
    File(&'static str),
    /// A URDF whose companion `.yaml` is written beside it: aimed at an input through the companion.
    Companion(&'static str),
    /// A session folder.
    Folder(&'static str),
}

/// One command line and everything it reads.
struct Scenario {
    args: &'static str,
    outputs: &'static [Out],
    inputs: Vec<&'static str>,
    /// With outputs of its own: success, or this error after reading every input (the per-pose
    /// estimator has nothing to work on in a recording of one marker a frame).
    fails_with: Option<&'static str>,
}

const SESSION_SIM: [&str; 6] = [
    SIM,
    "datasets/sim/session.yaml",
    "datasets/sim/joints.csv",
    "datasets/sim/markers.csv",
    "datasets/sim/truth.yaml",
    "datasets/sim/truth_orientations.csv",
];

const SESSION_FREE: [&str; 5] = [
    FREE,
    "datasets/free/session.yaml",
    "datasets/free/encoders.csv",
    "datasets/free/captures.csv",
    "datasets/free/truth.yaml",
];
const THE_MODEL: [&str; 2] = [MODEL, COMPANION];
const THE_OTHER_MODEL: [&str; 2] = [OTHER, OTHER_COMPANION];

/// The inputs of a scenario, from lists.
fn all(parts: &[&[&'static str]]) -> Vec<&'static str> {
    parts.concat()
}

fn scenarios() -> Vec<Scenario> {
    vec![
        Scenario {
            args: "ik --model models/agile_wrist.urdf --orientations joystick/orientations.csv --out out/ik.csv",
            outputs: &[Out::File("--out")],
            inputs: all(&[&[ORIENTATIONS], &THE_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "ik --params params.yaml --orientations joystick/orientations.csv --out out/ik.csv",
            outputs: &[Out::File("--out")],
            inputs: vec![ORIENTATIONS, PARAMS],
            fails_with: None,
        },
        Scenario {
            args: "fda --model other/m.urdf --joints joystick/joints.csv --out out/fda.csv",
            outputs: &[Out::File("--out")],
            inputs: all(&[&[JOINTS], &THE_OTHER_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "fda --params params.yaml --joints joystick/joints.csv --all-modes --out out/fda.csv",
            outputs: &[Out::File("--out")],
            inputs: vec![JOINTS, PARAMS],
            fails_with: None,
        },
        Scenario {
            args: "simulate --config configs/simulate.yaml --plan plan.csv --out out/sim --rrd out/sim.rrd",
            outputs: &[Out::File("--rrd"), Out::Folder("--out")],
            inputs: all(&[&[SIM_CONFIG, PLAN], &THE_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "simulate --config configs/simulate.yaml --model other/m.urdf --poses 3 --out out/sim --rrd out/sim.rrd",
            outputs: &[Out::File("--rrd"), Out::Folder("--out")],
            inputs: all(&[&[SIM_CONFIG], &THE_OTHER_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "estimate --dataset datasets/sim --out out/e.csv --rrd out/e.rrd",
            outputs: &[Out::File("--out"), Out::File("--rrd")],
            inputs: all(&[&SESSION_SIM, &THE_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "estimate --dataset datasets/free --model other/m.urdf --json --out out/e.csv --rrd out/e.rrd",
            outputs: &[Out::File("--out"), Out::File("--rrd")],
            inputs: all(&[&SESSION_FREE, &THE_OTHER_MODEL]),
            fails_with: Some("no pose sees 3 markers"),
        },
        Scenario {
            args: "calibrate --dataset datasets/sim --config configs/calibrate.yaml --out out/p.yaml --rrd out/c.rrd \
               --report out/r.html",
            outputs: &[Out::File("--out"), Out::File("--rrd"), Out::File("--report")],
            inputs: all(&[&SESSION_SIM, &THE_MODEL, &[CALIB_CONFIG]]),
            fails_with: None,
        },
        Scenario {
            args: "calibrate --dataset datasets/free --model other/m.urdf --out out/p.yaml --report out/r.html",
            outputs: &[Out::File("--out"), Out::File("--report")],
            inputs: all(&[&SESSION_FREE, &THE_OTHER_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "compare --dataset datasets/sim --params params.yaml --rrd out/c.rrd",
            outputs: &[Out::File("--rrd")],
            inputs: all(&[&SESSION_SIM, &THE_MODEL, &[PARAMS]]),
            fails_with: None,
        },
        Scenario {
            args: "compare --dataset datasets/free --params params.yaml --rrd out/c.rrd",
            outputs: &[Out::File("--rrd")],
            inputs: all(&[&SESSION_FREE, &THE_MODEL, &[PARAMS]]),
            fails_with: None,
        },
        Scenario {
            args: "replay --dataset datasets/sim --params params.yaml --rrd out/r.rrd",
            outputs: &[Out::File("--rrd")],
            inputs: all(&[&SESSION_SIM, &THE_MODEL, &[PARAMS]]),
            fails_with: None,
        },
        Scenario {
            args: "replay --dataset datasets/free --model other/m.urdf --rrd out/r.rrd",
            outputs: &[Out::File("--rrd")],
            inputs: all(&[&SESSION_FREE, &THE_OTHER_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "plan --poses 2 --candidates 30 --config configs/simulate.yaml --params params.yaml --augment datasets/sim \
               --out out/plan.csv --rrd out/plan.rrd",
            outputs: &[Out::File("--out"), Out::File("--rrd")],
            inputs: all(&[&[SIM_CONFIG, PARAMS], &THE_MODEL, &SESSION_SIM]),
            fails_with: None,
        },
        Scenario {
            args: "plan --poses 8 --candidates 100 --model other/m.urdf --out out/plan.csv",
            outputs: &[Out::File("--out")],
            inputs: THE_OTHER_MODEL.to_vec(),
            fails_with: None,
        },
        Scenario {
            args: "export --params params.yaml --urdf out/x.urdf",
            outputs: &[Out::File("--urdf"), Out::Companion("--urdf")],
            inputs: all(&[&[PARAMS], &THE_MODEL]),
            fails_with: None,
        },
        Scenario {
            args: "export --params params.yaml --model other/m.urdf --urdf out/x.urdf",
            outputs: &[Out::File("--urdf"), Out::Companion("--urdf")],
            inputs: all(&[&[PARAMS], &THE_OTHER_MODEL]),
            fails_with: None,
        },
    ]
}

/// How an output is aimed at an input.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Aim {
    /// The input's path as the scenario gives it.
    Path,
    /// The same path through another folder and `..`.
    Spelled,
    /// A symbolic link to the input.
    Symbolic,
    /// A hard link to the input (files only).
    Hard,
    /// An output folder only: a session folder whose `session.yaml` is a symbolic link to the input.
    SymbolicInside,
}

const AIMS: [Aim; 5] = [Aim::Path, Aim::Spelled, Aim::Symbolic, Aim::Hard, Aim::SymbolicInside];

/// Every file under `dir` but the scratch folders, with its contents.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(dir).unwrap().to_path_buf();
            if rel == Path::new("links") || rel == Path::new("out") {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                files.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    files
}

/// The value to give the output option, with the links it needs made under `links/`; `None` when
/// the aim does not apply (a hard link to a folder, a companion beside a file that is no `.yaml`).
fn aim(w: &Path, out: Out, input: &str, how: Aim) -> Option<String> {
    let links = w.join("links");
    std::fs::create_dir_all(&links).unwrap();
    let is_dir = w.join(input).is_dir();
    if how == Aim::Hard && is_dir {
        return None;
    }
    let link = |at: &Path| {
        std::fs::create_dir_all(at.parent().unwrap()).unwrap();
        match how {
            Aim::Symbolic | Aim::SymbolicInside => std::os::unix::fs::symlink(w.join(input), at).unwrap(),
            Aim::Hard => std::fs::hard_link(w.join(input), at).unwrap(),
            Aim::Path | Aim::Spelled => unreachable!(),
        }
    };
    let parent = match Path::new(input).parent().unwrap().display().to_string() {
        top if top.is_empty() => ".".to_string(),
        parent => parent,
    };
    let ext = Path::new(input).extension().map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
    match out {
        Out::File(_) | Out::Companion(_) if how == Aim::SymbolicInside => None,
        Out::File(_) => Some(match how {
            Aim::Path => input.to_string(),
            Aim::Spelled => format!("./out/../{input}"),
            Aim::Symbolic | Aim::Hard | Aim::SymbolicInside => {
                link(&links.join(format!("link{ext}")));
                format!("links/link{ext}")
            }
        }),
        // `--urdf X.urdf` writes `X.yaml`.
        Out::Companion(_) => match how {
            Aim::Path | Aim::Spelled if ext != ".yaml" => None,
            Aim::Path => Some(Path::new(input).with_extension("urdf").display().to_string()),
            Aim::Spelled => Some(format!("./out/../{}", Path::new(input).with_extension("urdf").display())),
            Aim::Symbolic | Aim::Hard | Aim::SymbolicInside => {
                link(&links.join("companion.yaml"));
                Some("links/companion.urdf".into())
            }
        },
        Out::Folder(_) => Some(match how {
            // The folder that holds the input (the working directory for a file at its top).
            Aim::Path => parent,
            Aim::Spelled => format!("./out/../{parent}"),
            // A link to that folder.
            Aim::Symbolic => {
                std::os::unix::fs::symlink(w.join(&parent), links.join("folder")).unwrap();
                "links/folder".into()
            }
            // A session folder whose file is a link to the input.
            Aim::Hard | Aim::SymbolicInside => {
                link(&links.join("session/session.yaml"));
                "links/session".into()
            }
        }),
    }
}

fn option(out: Out) -> &'static str {
    match out {
        Out::File(o) | Out::Companion(o) | Out::Folder(o) => o,
    }
}

/// The scenario's arguments with the output option's value replaced.
fn with_output(scenario: &Scenario, option: &str, value: &str) -> Vec<String> {
    let mut args = args(scenario.args);
    let k = args.iter().position(|a| a == option).unwrap_or_else(|| panic!("{option} in `{}`", scenario.args));
    args[k + 1] = value.to_string();
    args
}

/// Every temporary file of a write left anywhere under `dir`.
fn leftovers(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let entry = entry.unwrap();
            let path = entry.path();
            if entry.file_type().unwrap().is_dir() {
                stack.push(path);
            } else if entry.file_name().to_string_lossy().starts_with(".spmcal-") {
                found.push(path);
            }
        }
    }
    found
}

#[test]
fn no_command_overwrites_its_inputs_whatever_path_reaches_them() {
    let tmp = workspace();
    let w = tmp.path();
    let before = snapshot(w);
    let mut failures = Vec::new();
    let mut runs = 0;
    for scenario in &scenarios() {
        for &out in scenario.outputs {
            for &input in &scenario.inputs {
                assert!(w.join(input).exists(), "{input} of `{}` is not in the workspace", scenario.args);
                for how in AIMS {
                    let Some(value) = aim(w, out, input, how) else { continue };
                    let args = with_output(scenario, option(out), &value);
                    let run = spmcal(w, &args);
                    runs += 1;
                    let stderr = String::from_utf8_lossy(&run.stderr);
                    let case = format!("`spmcal {}` ({input}, {how:?})", args.join(" "));
                    let refused = stderr.starts_with("error: ")
                        && stderr.lines().count() == 1
                        && (stderr.contains(" is an input of this command (")
                            || stderr.contains(" contains an input of this command ("))
                        && stderr.contains("refusing to")
                        && stderr.contains(option(out));
                    if run.status.code() != Some(1) || !refused {
                        failures.push(format!("{case}: exit {:?}: {stderr}", run.status.code()));
                    }
                    if snapshot(w) != before {
                        failures.push(format!("{case}: an input changed"));
                        panic!("inputs changed; stopping:\n{}", failures.join("\n"));
                    }
                    let left = leftovers(w);
                    if !left.is_empty() {
                        failures.push(format!("{case}: temporary files left behind: {left:?}"));
                    }
                    std::fs::remove_dir_all(w.join("links")).unwrap();
                    std::fs::remove_dir_all(w.join("out")).unwrap();
                    std::fs::create_dir(w.join("out")).unwrap();
                }
            }
        }
    }
    eprintln!("{runs} refused runs");
    assert!(failures.is_empty(), "{} of {runs} runs failed:\n{}", failures.len(), failures.join("\n"));
    assert!(runs > 300, "only {runs} runs");
}

/// The scenarios are real: with their own outputs, each command reads its inputs and succeeds, so
/// that every refusal above is of a command that would otherwise have run.
#[test]
fn every_scenario_runs_with_outputs_of_its_own() {
    let tmp = workspace();
    let w = tmp.path();
    for scenario in &scenarios() {
        let run = spmcal(w, &args(scenario.args));
        let stderr = String::from_utf8_lossy(&run.stderr);
        let ok = match scenario.fails_with {
            None => run.status.success(),
            Some(expect) => run.status.code() == Some(1) && stderr.contains(expect),
        };
        assert!(ok, "`spmcal {}`: {stderr}", scenario.args);
    }
}

/// One file given as two outputs, spelled two ways, is refused as two outputs are.
#[test]
fn one_file_as_two_outputs_is_refused_however_spelled() {
    let tmp = workspace();
    let w = tmp.path();
    let run = spmcal(w, &args("calibrate --dataset datasets/sim --out out/p.yaml --report ./datasets/../out/p.yaml"));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.starts_with("error: ") && stderr.contains("p.yaml: is given as two different outputs"), "{stderr}");
    let run = spmcal(w, &args("export --params params.yaml --urdf out/x.yaml"));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("x.yaml: is given as two different outputs"), "{stderr}");
    assert!(std::fs::read_dir(w.join("out")).unwrap().next().is_none());
}
