//! The program as a user runs it once installed: from an empty folder far from the checkout, with
//! the shipped models by name (compiled in), files that name their model relative to themselves,
//! and a parameters file that finds its model after it was copied elsewhere (issue 37).
//!
//! Every command runs with its working folder in a fresh temporary folder that holds nothing of
//! the repository but what the test copies there (a session, joint readings).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The checkout: where the test copies its inputs from (never the commands' working folder).
fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Run spmcal in `dir` and require success.
fn run(dir: &Path, args: &[&str]) -> String {
    let out = spmcal(dir, args);
    assert!(
        out.status.success(),
        "spmcal {} (in {}) failed:\n{}",
        args.join(" "),
        dir.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn spmcal(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_spmcal")).current_dir(dir).args(args).output().unwrap()
}

/// Copy the session folder `name` of `datasets/` into `to`.
fn copy_session(name: &str, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(repo().join("datasets").join(name)).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
    }
}

fn yaml_value(text: &str, key: &str) -> Option<String> {
    text.lines().find_map(|l| l.strip_prefix(&format!("{key}: ")).map(str::to_string))
}

/// The SHA-256 of `bytes` by the system's `sha256sum` (an implementation independent of
/// spmcal's), when it is installed.
fn system_sha256(bytes: &[u8]) -> Option<String> {
    use std::io::Write;
    let mut child = Command::new("sha256sum")
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .ok()?;
    child.stdin.take()?.write_all(bytes).ok()?;
    let out = child.wait_with_output().ok()?;
    Some(String::from_utf8(out.stdout).ok()?.split_whitespace().next()?.to_string())
}

/// The README's tour from an empty folder: plan, check, fda, calibrate a copied session, export
/// a parameters file copied to another folder — every model by name or by default.
#[test]
fn the_readme_tour_runs_from_an_empty_folder_with_models_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    assert_eq!(std::fs::read_dir(w).unwrap().count(), 0);

    // Plan (the default model), check both shipped models by name.
    let text = run(w, &["plan", "--poses", "12", "--candidates", "200", "--out", "plan.csv"]);
    assert!(text.contains("wrote plan.csv"), "{text}");
    assert_eq!(std::fs::read_to_string(w.join("plan.csv")).unwrap().lines().count(), 1 + 12);
    let text = run(w, &["check", "--model", "orbita3d"]);
    assert!(text.starts_with("orbita3d: a coaxial SPM") && text.contains("problems: none"), "{text}");
    let text = run(w, &["check"]);
    assert!(text.starts_with("agile_wrist:") && text.contains("problems: none"), "{text}");

    // fda of joint readings, by name and by default: the same orientations.
    std::fs::copy(repo().join("datasets/joystick_circle/joints.csv"), w.join("joints.csv")).unwrap();
    let by_default = run(w, &["fda", "--joints", "joints.csv"]);
    assert_eq!(by_default, run(w, &["fda", "--joints", "joints.csv", "--model", "agile_wrist"]));
    assert_eq!(by_default.lines().count(), 1 + 36, "{by_default}");

    // Calibrate a copied session (its session.yaml names `agile_wrist`).
    copy_session("agile_wrist_sim_20", &w.join("session"));
    run(w, &["calibrate", "--dataset", "session", "--out", "params.yaml", "--report", "report.html", "--rrd", "c.rrd"]);
    assert!(w.join("report.html").is_file() && w.join("c.rrd").is_file());
    let text = run(w, &["compare", "--dataset", "session", "--params", "params.yaml"]);
    assert!(text.starts_with("pose,nominal_deg,calibrated_deg") && text.lines().count() > 10, "{text}");
    let params = std::fs::read_to_string(w.join("params.yaml")).unwrap();
    assert_eq!(yaml_value(&params, "model").as_deref(), Some("agile_wrist"), "{params}");
    let sha = yaml_value(&params, "model_sha256").unwrap();
    let mut content = std::fs::read(repo().join("models/agile_wrist.urdf")).unwrap();
    content.extend(std::fs::read(repo().join("models/agile_wrist.yaml")).unwrap());
    match system_sha256(&content) {
        Some(independent) => assert_eq!(sha, independent, "`cat agile_wrist.urdf agile_wrist.yaml | sha256sum`"),
        None => eprintln!("sha256sum is not installed: the identity is checked against FIPS vectors in the unit tests"),
    }

    // The parameters file copied to another folder exports, and the exported URDF gives the FDA
    // the parameters give.
    std::fs::create_dir_all(w.join("elsewhere/deeper")).unwrap();
    std::fs::copy(w.join("params.yaml"), w.join("elsewhere/deeper/p.yaml")).unwrap();
    let deeper = w.join("elsewhere/deeper");
    let text = run(&deeper, &["export", "--params", "p.yaml", "--urdf", "calibrated.urdf"]);
    assert!(text.contains("wrote calibrated.urdf and calibrated.yaml"), "{text}");
    let via_urdf = run(&deeper, &["fda", "--joints", "../../joints.csv", "--model", "calibrated.urdf"]);
    let via_params = run(&deeper, &["fda", "--joints", "../../joints.csv", "--params", "p.yaml"]);
    // Quaternion components (qw ≥ 0 fixes the sign), row by row.
    let angles = |a: &str, b: &str| -> f64 {
        let q = |l: &str| l.split(',').skip(1).map(|x| x.parse::<f64>().unwrap()).collect::<Vec<_>>();
        assert_eq!(a.lines().count(), b.lines().count());
        a.lines()
            .zip(b.lines())
            .skip(1)
            .flat_map(|(x, y)| q(x).into_iter().zip(q(y)).map(|(p, r)| (p - r).abs()))
            .fold(0.0, f64::max)
    };
    assert!(angles(&via_urdf, &via_params) < 1e-9, "{}", angles(&via_urdf, &via_params));
}

/// A model named by path inside a file is relative to that file, and written relative to the
/// file that records it; a parameters file whose model cannot be found says where the path came
/// from and that `--model` fixes it; one whose model changed is refused, and `--model` overrides.
#[test]
fn paths_inside_files_are_relative_to_the_file_and_a_lost_model_is_explained() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    // A model of one's own: the Agile Wrist under another name, with one comment changed (so its
    // content is no shipped model's).
    std::fs::create_dir_all(w.join("lab/models")).unwrap();
    let urdf = std::fs::read_to_string(repo().join("models/agile_wrist.urdf")).unwrap();
    std::fs::write(w.join("lab/models/wrist.urdf"), urdf.replacen("<robot", "<!-- our wrist -->\n<robot", 1)).unwrap();
    std::fs::copy(repo().join("models/agile_wrist.yaml"), w.join("lab/models/wrist.yaml")).unwrap();
    copy_session("agile_wrist_sim_20", &w.join("lab/sessions/s1"));
    let yaml = w.join("lab/sessions/s1/session.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap().replace("model: agile_wrist", "model: ../../models/wrist.urdf");
    std::fs::write(&yaml, text).unwrap();

    // Run from a folder that is neither the session's nor the model's.
    std::fs::create_dir_all(w.join("work/out")).unwrap();
    let work = w.join("work");
    run(&work, &["calibrate", "--dataset", "../lab/sessions/s1", "--out", "out/p.yaml"]);
    let params = std::fs::read_to_string(work.join("out/p.yaml")).unwrap();
    // Relative to out/p.yaml: up to the temporary folder, down to the model.
    assert_eq!(yaml_value(&params, "model").as_deref(), Some("../../lab/models/wrist.urdf"), "{params}");
    // Read from anywhere, the file finds its model.
    run(w, &["export", "--params", "work/out/p.yaml", "--urdf", "x.urdf"]);

    // Copied where the relative path leads nowhere, and no shipped model has its identity.
    std::fs::copy(work.join("out/p.yaml"), w.join("p.yaml")).unwrap();
    let out = spmcal(w, &["export", "--params", "p.yaml", "--urdf", "y.urdf"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && !w.join("y.urdf").exists(), "{e}");
    let line = params.lines().position(|l| l.starts_with("model: ")).unwrap() + 1;
    assert!(
        e.contains(&format!("p.yaml:{line}: the model `../../lab/models/wrist.urdf` named by this parameters file")),
        "{e}"
    );
    assert!(e.contains("give the model with --model"), "{e}");
    run(w, &["export", "--params", "p.yaml", "--urdf", "y.urdf", "--model", "lab/models/wrist.urdf"]);

    // The model changed since: refused under the file's own name, used (with a warning) when given.
    let changed =
        std::fs::read_to_string(w.join("lab/models/wrist.urdf")).unwrap().replace("our wrist", "our new wrist");
    std::fs::write(w.join("lab/models/wrist.urdf"), changed).unwrap();
    let out = spmcal(w, &["export", "--params", "work/out/p.yaml", "--urdf", "z.urdf"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("has changed since these parameters were made"), "{e}");
    let out =
        spmcal(w, &["export", "--params", "work/out/p.yaml", "--urdf", "z.urdf", "--model", "lab/models/wrist.urdf"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && e.contains("warning:") && e.contains("used as asked"), "{e}");

    // A parameters file of the shipped model, copied anywhere with a stale path, finds it by its
    // identity.
    let truth = std::fs::read_to_string(repo().join("datasets/agile_wrist_sim_20/truth.yaml")).unwrap();
    std::fs::write(
        w.join("stale.yaml"),
        truth.replace("model: agile_wrist", "model: /no/such/checkout/agile_wrist.urdf"),
    )
    .unwrap();
    run(w, &["export", "--params", "stale.yaml", "--urdf", "t.urdf"]);
}

/// A bag without a model uses the default model; a session converted from it names the shipped
/// model (no `../../../../` path); two simulated sessions of one config get their folders' names.
#[test]
fn bags_and_simulations_outside_the_checkout() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    copy_session("agile_wrist_free_motion_120s", &w.join("rec"));
    run(w, &["convert", "--dataset", "rec", "--to-bag", "rec.mcap"]);
    let out = spmcal(w, &["calibrate", "--dataset", "rec.mcap", "--out", "bag.yaml"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // The recording's last frame falls outside the encoders at latency 0: the note cites the
    // bag's message on its topic, not a line of a text file (a frame at the end: not a warning).
    assert!(stderr.contains("note: rec.mcap: marker topic `/markers`, message "), "{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
    assert!(!stderr.contains("rec.mcap:1") && stderr.contains("falls outside the encoder stream"), "{stderr}");
    let params = std::fs::read_to_string(w.join("bag.yaml")).unwrap();
    assert_eq!(yaml_value(&params, "model").as_deref(), Some("agile_wrist"), "{params}");
    std::fs::create_dir_all(w.join("a/b")).unwrap();
    run(w, &["convert", "--bag", "rec.mcap", "--out", "a/b/conv"]);
    let session = std::fs::read_to_string(w.join("a/b/conv/session.yaml")).unwrap();
    assert_eq!(yaml_value(&session, "model").as_deref(), Some("agile_wrist"), "{session}");

    std::fs::copy(repo().join("configs/simulate_agile_wrist.yaml"), w.join("sim.yaml")).unwrap();
    for out in ["sim_a", "sim_b"] {
        run(w, &["simulate", "--config", "sim.yaml", "--poses", "6", "--out", out]);
        let yaml = std::fs::read_to_string(w.join(out).join("session.yaml")).unwrap();
        assert_eq!(yaml_value(&yaml, "name").as_deref(), Some(out), "{yaml}");
        assert_eq!(yaml_value(&yaml, "model").as_deref(), Some("agile_wrist"), "{yaml}");
    }
}
