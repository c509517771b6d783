//! The bad-input corpus (`tests/data/bad_inputs`, made by its `make_corpus.py`): every case runs
//! the spmcal binary as a user would and must end with its expected message — a clear error that
//! names the file (and line where there is one) and the reason, never a panic — and must leave
//! every input and every existing output exactly as it was, and a failed run must write nothing:
//! the scratch folder of existing outputs holds exactly those outputs afterwards, nothing more at
//! any depth (no output, no half-written temporary file, no folder).

use std::path::{Path, PathBuf};

#[derive(serde::Deserialize)]
struct Case {
    args: Vec<String>,
    expect: Expect,
    status: String,
}

/// The message a case must produce: one piece, or several that must all appear in this order
/// (where a computed number stands between the file and line and the reason).
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum Expect {
    One(String),
    All(Vec<String>),
}

impl Expect {
    fn pieces(&self) -> Vec<&str> {
        match self {
            Expect::One(piece) => vec![piece],
            Expect::All(pieces) => pieces.iter().map(String::as_str).collect(),
        }
    }
}

/// Words of two letters or more in `text` once every argument of the command (and each one's
/// file name) is taken out, not counting the words that only locate (`column`, `line`, `pose`,
/// `leg`, `step`): what an expected message says beyond where. An expectation of an error must
/// say why (three such words at least: "more than 64 aliases"), not only which file, line or
/// column ("c.yaml:1: column `max_iterations`" says nothing of what is wrong there).
fn words_beyond_the_arguments(text: &str, args: &[String]) -> usize {
    let mut rest = text.to_string();
    let mut echoes: Vec<&str> = args.iter().map(String::as_str).collect();
    echoes.extend(args.iter().filter_map(|a| Path::new(a).file_name().and_then(|n| n.to_str())));
    echoes.sort_by_key(|e| std::cmp::Reverse(e.len()));
    for echo in echoes.iter().filter(|e| !e.is_empty()) {
        rest = rest.replace(echo, " ");
    }
    const LOCATING: [&str; 5] = ["column", "line", "pose", "leg", "step"];
    rest.split(|c: char| !c.is_alphanumeric() && c != '_')
        .filter(|w| w.chars().filter(|c| c.is_alphabetic()).count() >= 2 && !LOCATING.contains(w))
        .count()
}

const SENTINELS: [&str; 3] = ["existing.yaml", "existing.csv", "existing.rrd"];
const SENTINEL: &str = "an existing output that a failed run must not change\n";

fn run_case(dir: &Path) -> Result<(), String> {
    let case: Case = serde_yaml::from_str(&std::fs::read_to_string(dir.join("case.yaml")).unwrap()).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    for name in SENTINELS {
        std::fs::write(tmp.path().join(name), SENTINEL).unwrap();
    }
    let fill =
        |s: &str| s.replace("{case}", &dir.display().to_string()).replace("{tmp}", &tmp.path().display().to_string());
    let args: Vec<String> = case.args.iter().map(|a| fill(a)).collect();
    // Every input — the case's own files and any existing file or folder an argument names — must
    // be left exactly as it was, whatever the command does.
    let scratch = tmp.path().display().to_string();
    let named: Vec<String> = args.iter().filter(|a| !a.starts_with(&scratch)).cloned().collect();
    let inputs = || snapshot(dir, &named);
    let before = inputs();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal")).args(&args).output().unwrap();
    if inputs() != before {
        return Err("an input file was changed".into());
    }
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    let pieces: Vec<String> = case.expect.pieces().into_iter().map(fill).collect();
    let code = out.status.code();
    if stderr.contains("panicked") || code == Some(101) || code.is_none() {
        return Err(format!("panicked or was killed ({code:?}): {stderr}"));
    }
    let ok = case.status == "ok";
    if ok != out.status.success() {
        return Err(format!("exit {code:?}, expected {}: {stderr}", case.status));
    }
    let text = if ok { stdout.to_string() } else { stderr.to_string() };
    let mut from = 0;
    for piece in &pieces {
        match text[from..].find(piece.as_str()) {
            Some(at) => from += at + piece.len(),
            None => return Err(format!("expected `{piece}` (after the pieces before it) in:\n{text}")),
        }
    }
    if !ok && words_beyond_the_arguments(&pieces.join(" "), &args) < 3 {
        return Err(format!("the expected message {pieces:?} says too little beyond the file names given"));
    }
    if !ok {
        if !text.starts_with("error: ") || text.lines().count() > 1 {
            return Err(format!("not one `error:` line: {text}"));
        }
        for name in SENTINELS {
            if std::fs::read_to_string(tmp.path().join(name)).unwrap() != SENTINEL {
                return Err(format!("{name} was changed by a failed run"));
            }
        }
        let kept: Vec<PathBuf> = everything_under(tmp.path())
            .into_iter()
            .filter(|p| !SENTINELS.iter().any(|name| *p == tmp.path().join(name)))
            .collect();
        if !kept.is_empty() {
            return Err(format!("a failed run wrote {kept:?}"));
        }
    }
    let leftovers: Vec<PathBuf> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with(".spmcal-"))
        .collect();
    if !leftovers.is_empty() {
        return Err(format!("temporary files left behind: {leftovers:?}"));
    }
    Ok(())
}

/// Every file and folder under `dir`, at any depth.
fn everything_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            out.extend(everything_under(&path));
        }
        out.push(path);
    }
    out
}

/// The contents of every file in the case folder and of every existing path an argument names
/// (folders: their files, one level deep), by path.
fn snapshot(case: &Path, args: &[String]) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    let add_folder = |dir: &Path, out: &mut std::collections::BTreeMap<PathBuf, Vec<u8>>| {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_file() {
                out.insert(path.clone(), std::fs::read(&path).unwrap_or_default());
            }
        }
    };
    add_folder(case, &mut out);
    for arg in args {
        let path = Path::new(arg);
        if path.is_file() {
            out.insert(path.to_path_buf(), std::fs::read(path).unwrap_or_default());
        } else if path.is_dir() {
            add_folder(path, &mut out);
        }
    }
    out
}

#[test]
fn every_bad_input_gets_its_message_no_panic_and_no_changed_output() {
    let corpus = Path::new("tests/data/bad_inputs");
    let mut dirs: Vec<PathBuf> =
        std::fs::read_dir(corpus).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_dir()).collect();
    dirs.sort();
    let failures: Vec<String> =
        dirs.iter().filter_map(|dir| run_case(dir).err().map(|e| format!("{}: {e}", dir.display()))).collect();
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), dirs.len(), failures.join("\n"));
    assert!(dirs.len() >= 120, "only {} cases", dirs.len());
}

#[test]
fn a_closed_standard_output_ends_the_program_quietly() {
    use std::io::Read;
    use std::process::{Command, Stdio};
    // Far more than a pipe buffers (64 KiB), so that the writer meets the closed pipe.
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("j.csv");
    let mut text = String::from("pose,theta1_rad,theta2_rad,theta3_rad\n");
    for p in 0..5000 {
        text.push_str(&format!("{p},{},0.1,-0.1\n", 0.2 * (p as f64 * 0.01).sin()));
    }
    std::fs::write(&joints, text).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["fda", "--joints", joints.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then close the pipe, as `| head -c 1` would.
    let mut byte = [0u8; 1];
    child.stdout.take().unwrap().read_exact(&mut byte).unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked") && !stderr.contains("error"), "{stderr}");
    assert!(out.status.success(), "{:?}", out.status);
}

/// Every YAML input — `session.yaml` (read twice by `calibrate`: for the model it names, then by
/// the session reader), the calibrate and simulate configs, a parameters file, a URDF's companion,
/// a bag's `metadata.yaml` and its `spmcal.yaml` mapping — is refused in time linear in its size:
/// the depth is checked while a streaming parser reads it, before anything builds a tree. 10^5 and
/// 2·10^5 nested brackets are each refused with the located message; the time of the larger may
/// grow in proportion (≈2×, or less where starting the program dominates) but not as its square
/// (4×: serde_yaml's parse of `session.yaml` for the model took 18 s at 10^5 levels and 72 s at
/// 2·10^5). Best of three runs each, with a generous ceiling; the times are printed (`--nocapture`).
#[test]
fn deeply_nested_yaml_is_refused_in_linear_time() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let session = root.join("session");
    std::fs::create_dir(&session).unwrap();
    for name in ["joints.csv", "markers.csv"] {
        std::fs::copy(Path::new("datasets/agile_wrist_sim_20").join(name), session.join(name)).unwrap();
    }
    std::fs::copy("models/agile_wrist.urdf", root.join("m.urdf")).unwrap();
    std::fs::create_dir(root.join("rec")).unwrap();
    std::fs::create_dir(root.join("rec2")).unwrap();
    // A bag folder is one with a `metadata.yaml` (or `.mcap` files); its mapping is read first.
    std::fs::write(root.join("rec2/metadata.yaml"), "rosbag2_bagfile_information:\n  storage_identifier: mcap\n")
        .unwrap();
    let r = |p: &str| root.join(p).display().to_string();
    let calibrate =
        |dataset: String| vec!["calibrate".into(), "--dataset".into(), dataset, "--out".into(), r("out.yaml")];
    let bag = |folder: &str| {
        let mut args = calibrate(r(folder));
        args.extend(["--model".to_string(), "models/agile_wrist.urdf".to_string()]);
        args
    };
    let mut sim20 = calibrate("datasets/agile_wrist_sim_20".into());
    sim20.extend(["--config".to_string(), r("c.yaml")]);
    let fda = |option: &str, file: &str| {
        ["fda", "--joints", "datasets/joystick_circle/joints.csv", option]
            .map(String::from)
            .into_iter()
            .chain([r(file)])
    };
    // (the YAML file written, the key its brackets are the value of, the command)
    let inputs: Vec<(&str, &str, Vec<String>)> = vec![
        ("session/session.yaml", "name", calibrate(r("session"))),
        ("session/session.yaml", "name", vec!["estimate".into(), "--dataset".into(), r("session")]),
        ("c.yaml", "loss", sim20),
        (
            "s.yaml",
            "camera",
            ["simulate", "--config"]
                .map(String::from)
                .into_iter()
                .chain([r("s.yaml"), "--out".into(), r("sim")])
                .collect(),
        ),
        ("p.yaml", "legs", fda("--params", "p.yaml").collect()),
        ("m.yaml", "markers_m", fda("--model", "m.urdf").collect()),
        ("rec/metadata.yaml", "rosbag2_bagfile_information", bag("rec")),
        ("rec2/spmcal.yaml", "joints", bag("rec2")),
    ];
    let mut failures = Vec::new();
    for (file, key, args) in &inputs {
        let mut times = Vec::new();
        for levels in [100_000, 200_000] {
            std::fs::write(root.join(file), format!("{key}: {}", "[".repeat(levels))).unwrap();
            let mut best = f64::INFINITY;
            for _ in 0..3 {
                let start = std::time::Instant::now();
                let out = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal")).args(args).output().unwrap();
                best = best.min(start.elapsed().as_secs_f64());
                let stderr = String::from_utf8_lossy(&out.stderr);
                let expected = format!("{}:1: nested more than 16 levels deep", r(file));
                assert!(
                    !out.status.success() && stderr.contains(&expected),
                    "{args:?}: expected `{expected}` in {stderr}"
                );
            }
            times.push(best);
        }
        let (t1, t2) = (times[0], times[1]);
        println!("{file} ({}): 10^5 levels refused in {t1:.4} s, 2·10^5 in {t2:.4} s", args[0]);
        if t2 > 3.0 * t1 + 0.25 || t1 > 5.0 || t2 > 10.0 {
            failures.push(format!("{file} ({}): {t1:.3} s at 10^5 levels, {t2:.3} s at 2·10^5", args[0]));
        }
        std::fs::remove_file(root.join(file)).unwrap();
    }
    assert!(failures.is_empty(), "not linear, or slow:\n{}", failures.join("\n"));
}

/// YAML is parsed in one place, `io::yaml`, which checks the limits (depth, size, aliases) while
/// it scans and before serde_yaml builds anything: no other file of `src/` hands text to
/// serde_yaml (the exporter's read-back of the companion it has just written is its own output,
/// not an input). A new reader that called serde_yaml directly would bring back the quadratic parse.
#[test]
fn every_yaml_input_is_parsed_through_the_limits() {
    fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                rust_files(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    rust_files(Path::new("src"), &mut files);
    let allowed = [Path::new("src/io/yaml.rs"), Path::new("src/model/export.rs")];
    let mut found = Vec::new();
    for file in files.iter().filter(|f| !allowed.contains(&f.as_path())) {
        let text = std::fs::read_to_string(file).unwrap();
        for (k, line) in text.lines().enumerate() {
            if ["serde_yaml::from_", "serde_yaml::Deserializer"].iter().any(|call| line.contains(call)) {
                found.push(format!("{}:{}: {}", file.display(), k + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "YAML parsed outside io::yaml (use io::yaml::read or parse):\n{}", found.join("\n"));
}

/// A copy of a shipped session in a scratch folder (its model named by absolute path), with
/// `edit` applied to the text of each of its files by name.
fn session_copy(from: &str, edit: impl Fn(&str, String) -> String) -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["session.yaml", "joints.csv", "markers.csv"] {
        let text = std::fs::read_to_string(Path::new(from).join(name)).unwrap();
        let model = std::fs::canonicalize("models").unwrap().display().to_string();
        std::fs::write(tmp.path().join(name), edit(name, text.replace("../../models", &model))).unwrap();
    }
    tmp
}

/// A station that captures a marker twice where every marker was captured (a retake) is data: it
/// loads, with a warning at the second capture's row; the per-pose estimator merges the first.
/// Captured twice while another is never captured, it is refused at that row (a mislabel).
#[test]
fn a_station_retake_is_said_and_a_station_mislabel_refused() {
    let retake = session_copy("datasets/agile_wrist_sequential_200", |name, text| match name {
        // A fifth capture in station 0 (poses 0–3 saw m1–m4): m2 again, at pose 1's joints.
        "joints.csv" => {
            let pose1 = text.lines().nth(2).unwrap().split(',').skip(1).take(3).collect::<Vec<_>>().join(",");
            text + &format!("765,{pose1},382.5,0\n")
        }
        "markers.csv" => text + "765,m2,-0.0726,0.0494,0.7581\n",
        _ => text,
    });
    let (session, warnings) = spmcal::dataset::Session::load(retake.path(), None).unwrap();
    let expected = "markers.csv:767: pose 765: station 0 captures marker `m2` twice (markers.csv lines 3 and 767, poses 1 and 765): a retake? The marker-level fit uses both; the per-pose estimator the first";
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].to_string().ends_with(expected), "{}", warnings[0]);
    assert!(spmcal::vision::SessionEstimate::of(&session, spmcal::vision::Method::Kabsch).is_ok());

    let mislabel = session_copy("datasets/agile_wrist_sequential_200", |name, text| match name {
        "markers.csv" => text.replacen("\n2,m3,", "\n2,m1,", 1),
        _ => text,
    });
    let e = spmcal::dataset::Session::load(mislabel.path(), None).unwrap_err();
    assert_eq!((e.line, e.column.as_deref()), (Some(4), Some("marker")), "{e}");
    assert!(e.path.ends_with("markers.csv") && e.reason.contains("and `m3` never: a mislabelled capture?"), "{e}");
}

/// The per-pose estimator's refusals about a pose are located at the file and row of the marker
/// they are about, even where the session was changed after loading (here the reference pose's
/// second marker moved onto its first, as a camera model's correction could): the error type
/// carries the file and line, not only the pose.
#[test]
fn the_estimators_refusals_name_the_marker_row() {
    let dir = session_copy("datasets/agile_wrist_sim_20", |_, text| text);
    let (mut session, _) = spmcal::dataset::Session::load(dir.path(), None).unwrap();
    let reference = session.poses.iter().position(|p| p.id == session.reference_pose).unwrap();
    let first = session.poses[reference].markers[0].unwrap();
    session.poses[reference].markers[1] = Some(first + nalgebra::Vector3::new(1e-4, 0.0, 0.0));
    let e = spmcal::vision::SessionEstimate::of(&session, spmcal::vision::Method::Kabsch).unwrap_err();
    // The file in full (the session's folder joined), so that a message read away from the command
    // line still says which session.
    let markers = dir.path().join("markers.csv");
    assert_eq!((e.file.as_deref(), e.line), (Some(markers.as_path()), 3), "{e}");
    let start = format!("{}:3: pose 0: markers #1 and #2 are 0.100 mm apart", markers.display());
    assert!(e.to_string().starts_with(&start), "{e}");
}

/// A marker coordinate beyond 10 m is refused where it is read, in each kind of input that holds
/// marker positions: `markers.csv` (the corpus), and a bag's `/markers` point, named by topic and
/// message — never left to overflow the distances between markers (`1e200` made "NaN mm apart").
#[test]
fn an_absurd_marker_coordinate_is_refused_where_it_is_read() {
    let dir = session_copy("datasets/agile_wrist_sim_20", |_, text| text);
    let (mut session, _) = spmcal::dataset::Session::load(dir.path(), None).unwrap();
    session.poses[2].markers[1] = Some(nalgebra::Vector3::new(0.01, 1e200, 0.7));
    let bag = dir.path().join("rec.mcap");
    session.write_bag(&bag).unwrap();
    let e = spmcal::dataset::Session::load(&bag, None).unwrap_err().to_string();
    assert!(e.contains("rec.mcap") && e.contains("topic `/markers`, message"), "{e}");
    assert!(e.contains("1e200 m is no marker position: a camera measures this mechanism's markers within 10 m"), "{e}");
}
