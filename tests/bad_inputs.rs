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
