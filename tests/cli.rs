//! The command line end to end: IK then FDA through files, all modes, and located errors.

use std::process::Command;

fn spmcal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_spmcal")).args(args).output().unwrap()
}

/// The data rows of a CSV file (its lines less the header), counted from the file itself.
fn csv_rows(path: &str) -> usize {
    std::fs::read_to_string(path).unwrap().lines().skip(1).filter(|l| !l.trim().is_empty()).count()
}

#[test]
fn ik_then_fda_through_files_recovers_the_orientations() {
    let dir = tempfile::tempdir().unwrap();
    let orientations = dir.path().join("orientations.csv");
    let joints = dir.path().join("joints.csv");
    let back = dir.path().join("back.csv");
    // 20° about x, then 25° about (1,1,1)/√3 — quaternions written to 12 digits.
    std::fs::write(&orientations, "pose,qw,qx,qy,qz\n0,1,0,0,0\n1,0.984807753012,0.173648177667,0,0\n2,0.976296007120,0.124961469370,0.124961469370,0.124961469370\n").unwrap();
    let out = spmcal(&["ik", "--orientations", orientations.to_str().unwrap(), "--out", joints.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = spmcal(&["fda", "--joints", joints.to_str().unwrap(), "--out", back.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let a = spmcal::dataset::OrientationRecord::read(&orientations).unwrap();
    let b = spmcal::dataset::OrientationRecord::read(&back).unwrap();
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.pose, y.pose);
        // Input quaternions are exact to ~1e-12 (12 digits), and are normalised on reading.
        assert!(spmcal::math::so3::geodesic_angle(&x.rotation, &y.rotation) < 1e-10);
    }
}

#[test]
fn fda_all_modes_lists_eight_modes_with_the_working_one_first() {
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("joints.csv");
    std::fs::write(&joints, "pose,theta1_rad,theta2_rad,theta3_rad,time_s\n4,0.1,-0.2,0.3,0.5\n").unwrap();
    let out = spmcal(&["fda", "--joints", joints.to_str().unwrap(), "--all-modes"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<_> = text.lines().collect();
    assert!(lines[0].starts_with("pose,mode,qw,qx,qy,qz"), "{}", lines[0]);
    assert_eq!(lines.len(), 1 + 8, "{text}");
    assert!(lines[1].starts_with("4,0,") && lines[1].ends_with(",true"), "{}", lines[1]);
    assert_eq!(lines.iter().filter(|l| l.ends_with(",true")).count(), 1);
    let json = spmcal(&["fda", "--joints", joints.to_str().unwrap(), "--all-modes", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(v["results"][0]["modes"].as_array().unwrap().len(), 8);
}

#[test]
fn bad_joint_file_is_reported_with_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("joints.csv");
    for (body, expected) in [
        ("0,0,0,0\n1,0.1,NaN,0\n", "joints.csv:3: column `theta2_rad`: `NaN` is not finite"),
        ("0,0,0,0\n0,0.1,0,0\n", "joints.csv:3: column `pose`: pose 0 appears twice"),
        ("0,0,zero,0\n", "joints.csv:2: column `theta2_rad`: `zero` is not a number"),
    ] {
        std::fs::write(&joints, format!("pose,theta1_rad,theta2_rad,theta3_rad\n{body}")).unwrap();
        let out = spmcal(&["fda", "--joints", joints.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(expected), "{err}");
    }
    std::fs::write(&joints, "pose,theta1,theta2_rad,theta3_rad\n0,0,0,0\n").unwrap();
    let err = String::from_utf8(spmcal(&["fda", "--joints", joints.to_str().unwrap()]).stderr).unwrap();
    assert!(err.contains("joints.csv:1") && err.contains("no column `theta1_rad`"), "{err}");
}

#[test]
fn unreachable_orientation_names_the_pose() {
    // A valid shipped model (Orbita3d: link angles below 90°, so its reach is bounded), three
    // orientations it reaches and, at pose 7 on the file's fifth line, a tilt of 60° about x,
    // which no link of leg 1 reaches (its IK needs a cosine beyond 1).
    let dir = tempfile::tempdir().unwrap();
    let orientations = dir.path().join("o.csv");
    let beyond_reach = "7,0.8660254037844386,0.5,0,0";
    let reachable =
        "0,1,0,0,0\n3,0.9961946980917455,0.0871557427476582,0,0\n5,0.9961946980917455,0,0.0871557427476582,0";
    std::fs::write(&orientations, format!("pose,qw,qx,qy,qz\n{reachable}\n{beyond_reach}\n")).unwrap();
    let joints = dir.path().join("j.csv");
    let ik = |orientations: &std::path::Path| {
        let paths = [orientations.to_str().unwrap(), joints.to_str().unwrap()];
        spmcal(&["ik", "--model", "models/orbita3d.urdf", "--orientations", paths[0], "--out", paths[1]])
    };
    let out = ik(&orientations);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    // File and line, the pose's own number, and the reason with the leg and the number behind it.
    assert!(
        err.contains("o.csv:5: pose 7: orientation outside the workspace: leg 1 cannot reach it (needs |cos| = "),
        "{err}"
    );
    let needs: f64 = err.split("|cos| = ").nth(1).and_then(|t| t.split(' ').next()).unwrap().parse().unwrap();
    assert!(needs > 1.0 && needs.is_finite(), "{err}");
    assert!(!joints.exists(), "no joints file after a failure");
    // Without that pose the same file goes through: the failure was that pose's, not the model's.
    std::fs::write(&orientations, format!("pose,qw,qx,qy,qz\n{reachable}\n")).unwrap();
    let out = ik(&orientations);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(csv_rows(joints.to_str().unwrap()), 3);
}

#[test]
fn simulate_writes_a_loadable_session_and_a_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let args =
        ["simulate", "--config", "configs/simulate_agile_wrist.yaml", "--poses", "25", "--seed", "3", "--name", "t"];
    let run = spmcal(&[&args[..], &["--out", out.to_str().unwrap(), "--json"]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let envelope: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(envelope["command"], "simulate");
    let summary = &envelope["results"];
    assert_eq!(summary["poses"], 25);
    assert_eq!(summary["seed"], 3);
    let attempts = summary["attempts"].as_u64().unwrap();
    let rejected: u64 = ["rejected_unreachable", "rejected_singular", "rejected_collision"]
        .iter()
        .map(|k| summary[k].as_u64().unwrap())
        .sum();
    assert_eq!(attempts, 25 + rejected);
    let (session, _) = spmcal::dataset::Session::load(&out, None).unwrap();
    assert_eq!((session.name.as_str(), session.poses.len()), ("t", 25));
}

#[test]
fn shipped_datasets_load_with_their_truth() {
    for (dir, poses) in [("datasets/agile_wrist_sim_20", 20), ("datasets/agile_wrist_sim_400", 400)] {
        let (session, _) = spmcal::dataset::Session::load(std::path::Path::new(dir), None).unwrap();
        assert_eq!(session.poses.len(), poses);
        let truth = session.truth.expect("simulated sessions carry their truth");
        assert_eq!(truth.orientations.len(), poses);
        assert!(truth.parameters.camera.is_some());
    }
}

#[test]
fn calibrate_writes_parameters_and_compare_reports_both_sets() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.yaml");
    let run = spmcal(&["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", params.to_str().unwrap()]);
    let report = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // The marker-level fit (the default): 18 mechanism and camera-rotation parameters, t_CB and
    // four markers, all identifiable, and the camera model `auto` chose (rigid for this perfect
    // camera: no more terms); the verdict first.
    assert!(report.contains("verdict:") && report.contains("identifiability: 33 of 33"), "{report}");
    assert!(report.contains("camera model: rigid (auto: cross-validated"), "{report}");
    let written = spmcal::model::Parameters::read(&params).unwrap();
    assert_eq!(written.source, spmcal::model::ParameterSource::Calibrated);
    assert!(written.camera.is_some());
    assert_eq!(written.markers.len(), 4);
    assert!(written.markers.iter().all(|m| m.std_error.is_some()));
    let fit = written.fit.expect("the fit statistics are in the header");
    assert!(fit["markers_rms_after_mm"].as_f64().unwrap() < fit["markers_rms_before_mm"].as_f64().unwrap());
    // The orientation-level fit on request.
    let config = dir.path().join("orientations.yaml");
    std::fs::write(&config, "fit: orientations\n").unwrap();
    let orientations = dir.path().join("orientations_params.yaml");
    let run = spmcal(&[
        "calibrate",
        "--dataset",
        "datasets/agile_wrist_sim_20",
        "--config",
        config.to_str().unwrap(),
        "--out",
        orientations.to_str().unwrap(),
    ]);
    let report = String::from_utf8_lossy(&run.stdout);
    assert!(report.contains("calibrated, held out") && report.contains("identifiability: 21 of 21"), "{report}");
    let fit = spmcal::model::Parameters::read(&orientations).unwrap().fit.unwrap();
    assert!(fit["rms_after_deg"].as_f64().unwrap() < fit["rms_before_deg"].as_f64().unwrap());

    let json = spmcal(&[
        "compare",
        "--dataset",
        "datasets/agile_wrist_sim_20",
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    assert!(json.status.success(), "{}", String::from_utf8_lossy(&json.stderr));
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(v["command"], "compare");
    let sets = v["results"].as_array().unwrap();
    assert_eq!(sets.len(), 2, "nominal and calibrated");
    assert_eq!((sets[0]["label"].as_str(), sets[1]["label"].as_str()), (Some("nominal"), Some("calibrated")));
    for set in sets {
        for key in ["rms", "median", "max"] {
            assert!(set[key].as_f64().unwrap() > 0.0, "{key}");
        }
        assert_eq!(set["per_pose"].as_array().unwrap().len(), csv_rows("datasets/agile_wrist_sim_20/joints.csv"));
    }
    assert!(sets[1]["rms"].as_f64().unwrap() < sets[0]["rms"].as_f64().unwrap());
    assert!(sets.iter().all(|s| s["level"] == "orientations" && s["unit"] == "deg"));

    // The calibrated file drives the kinematics commands.
    let fda = spmcal(&["fda", "--joints", "datasets/joystick_circle/joints.csv", "--params", params.to_str().unwrap()]);
    assert!(fda.status.success(), "{}", String::from_utf8_lossy(&fda.stderr));
    let circle = csv_rows("datasets/joystick_circle/joints.csv");
    assert!(circle > 0);
    assert_eq!(String::from_utf8_lossy(&fda.stdout).lines().count(), 1 + circle);
    let json =
        spmcal(&["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", params.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let report = &v["results"];
    // Angles in `parameters` (19: mechanism, the platform's sag and camera rotation); t_CB and the
    // markers (metres) in their own fields.
    assert_eq!(report["parameters"].as_array().unwrap().len(), 19);
    assert_eq!(report["markers"]["markers"].as_array().unwrap().len(), 4);
    assert!(report["cross_validation"]["calibrated_rms"].as_f64().is_some());
    assert!(report["markers"]["stereo_noise"]["depth_m"].as_f64().is_some());
}

#[test]
fn calibrate_reports_a_bad_config_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("c.yaml");
    std::fs::write(
        &config,
        std::fs::read_to_string("configs/calibrate.yaml").unwrap().replace("loss: huber", "loss: cauchy"),
    )
    .unwrap();
    let out = dir.path().join("p.yaml");
    let run = spmcal(&[
        "calibrate",
        "--dataset",
        "datasets/agile_wrist_sim_20",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    // The line of `loss:` in the shipped config (comments and all).
    let line = std::fs::read_to_string("configs/calibrate.yaml")
        .unwrap()
        .lines()
        .position(|l| l.starts_with("loss:"))
        .unwrap()
        + 1;
    assert!(!run.status.success() && err.contains(&format!("c.yaml:{line}")) && err.contains("cauchy"), "{err}");
    assert!(!out.exists(), "no parameters file after a failure");
}

#[test]
fn compare_on_a_free_motion_recording_compares_markers_and_says_a_reason_once() {
    let dataset = "datasets/agile_wrist_free_motion_120s";
    let json = spmcal(&["compare", "--dataset", dataset, "--json"]);
    assert!(json.status.success(), "{}", String::from_utf8_lossy(&json.stderr));
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let set = &v["results"][0];
    assert_eq!((set["level"].as_str(), set["unit"].as_str()), (Some("markers"), Some("mm")));
    assert!(set["rms"].as_f64().unwrap() > 1.0, "{set}");
    // An error whose source is also in its message is printed once, not twice.
    let out = spmcal(&["compare", "--dataset", dataset, "--level", "orientations"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.matches("no pose sees 3 markers").count() == 1, "{err}");
}

#[test]
fn plan_writes_the_poses_in_order_a_summary_and_a_recording_and_simulate_captures_them() {
    let dir = tempfile::tempdir().unwrap();
    let (plan, rrd) = (dir.path().join("plan.csv"), dir.path().join("plan.rrd"));
    let args = ["plan", "--poses", "12", "--candidates", "400", "--out", plan.to_str().unwrap()];
    let run = spmcal(&[&args[..], &["--rrd", rrd.to_str().unwrap(), "--json"]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!((v["command"].as_str(), v["results"]["poses"].as_u64()), (Some("plan"), Some(12)));
    let (planned, random) =
        (v["results"]["plan"]["rms_deg"].as_f64().unwrap(), v["results"]["random"]["rms_deg"].as_f64().unwrap());
    assert!(planned < random, "{planned} vs {random}");
    let text = std::fs::read_to_string(&plan).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "step,qw,qx,qy,qz,theta1_rad,theta2_rad,theta3_rad");
    assert_eq!(lines.len(), 13);
    assert!(lines[1..].iter().enumerate().all(|(k, l)| l.starts_with(&format!("{},", k + 1))));
    assert!(std::fs::metadata(&rrd).unwrap().len() > 0);
    let session = dir.path().join("planned");
    let sim = spmcal(&[
        "simulate",
        "--config",
        "configs/simulate_agile_wrist.yaml",
        "--plan",
        plan.to_str().unwrap(),
        "--out",
        session.to_str().unwrap(),
    ]);
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
    let joints = std::fs::read_to_string(session.join("joints.csv")).unwrap();
    assert_eq!(joints.lines().count(), 13, "{joints}");
    // A human summary without --json.
    let human = spmcal(&args);
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(text.contains("random poses needed") && text.contains("tour from home"), "{text}");
    // A margin out of range is refused, naming the flag.
    let bad = spmcal(&[&args[..], &["--margin-deg", "45"]].concat());
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("--margin-deg"));
}

#[test]
fn export_writes_a_urdf_and_companion_that_drive_fda_as_the_parameters_file_does() {
    let dir = tempfile::tempdir().unwrap();
    let (params, urdf) = (dir.path().join("p.yaml"), dir.path().join("calibrated.urdf"));
    let cal = spmcal(&["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--out", params.to_str().unwrap()]);
    assert!(cal.status.success(), "{}", String::from_utf8_lossy(&cal.stderr));
    let run = spmcal(&["export", "--params", params.to_str().unwrap(), "--urdf", urdf.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(dir.path().join("calibrated.yaml").exists());
    let joints = "datasets/joystick_circle/joints.csv";
    let by_model = spmcal(&["fda", "--joints", joints, "--model", urdf.to_str().unwrap(), "--json"]);
    let by_params = spmcal(&["fda", "--joints", joints, "--params", params.to_str().unwrap(), "--json"]);
    let quaternions = |out: &std::process::Output| -> Vec<f64> {
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["results"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| p["q_wxyz"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
            .collect()
    };
    let (a, b) = (quaternions(&by_model), quaternions(&by_params));
    // A quaternion per row of the input, from both: a shorter list cannot pass by zipping.
    assert_eq!((a.len(), b.len()), (csv_rows(joints) * 4, csv_rows(joints) * 4));
    assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12));
    // A destination folder that does not exist is an error naming it, and writes nothing.
    let missing = dir.path().join("no/such/folder/x.urdf");
    let err = spmcal(&["export", "--params", params.to_str().unwrap(), "--urdf", missing.to_str().unwrap()]);
    assert!(!err.status.success() && String::from_utf8_lossy(&err.stderr).contains("no/such/folder"));
}

#[test]
fn check_describes_a_model_its_home_branches_and_its_workspace() {
    let out = spmcal(&["check", "--model", "models/orbita3d.urdf"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("a coaxial SPM") && text.matches("+ positive").count() == 3, "{text}");
    // Every orientation of the survey's grid regular: the count is the survey's own (its JSON),
    // not today's figure, and the grid is the workspace's, not the orientations reached (the same
    // grid over a workspace the Agile Wrist cannot all reach, below, counts as many).
    let json = spmcal(&["check", "--model", "models/orbita3d.urdf", "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let grid = json["results"]["orientations"].as_u64().unwrap();
    assert_eq!(json["results"]["regular"].as_u64(), Some(grid), "{json}");
    let all = format!("{grid} of {grid} orientations regular");
    assert!(grid > 1000 && text.contains(&all) && text.contains("problems: none"), "{all}: {text}");

    // The Agile Wrist over more workspace than it has: the problem is said, with numbers.
    let out = spmcal(&["check", "--max-tilt-deg", "80", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let results = &json["results"];
    assert_eq!(results["legs"][0]["home_branch"], "negative");
    let (regular, total) = (results["regular"].as_u64().unwrap(), results["orientations"].as_u64().unwrap());
    assert!(regular < total && total == grid, "{results}");
    let problems = results["problems"].as_array().unwrap();
    assert!(problems.iter().any(|p| p.as_str().unwrap().contains(&format!("{} of the {total}", total - regular))));

    let out = spmcal(&["check", "--max-tilt-deg", "120"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--max-tilt-deg 120 is outside [0, 90]"));
}

#[test]
fn completions_man_page_and_version_come_from_the_command_line_itself() {
    // Every shell's script names the commands; the man page is roff with them; `--version`
    // names the version and the commit it was built from.
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let run = spmcal(&["completions", shell]);
        assert!(run.status.success(), "{shell}: {}", String::from_utf8_lossy(&run.stderr));
        let script = String::from_utf8_lossy(&run.stdout);
        assert!(script.contains("calibrate") && script.contains("camera-model"), "{shell}: {script}");
    }
    let run = spmcal(&["man"]);
    let page = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success() && page.contains(".TH spmcal 1") && page.contains("calibrate"), "{page}");
    // `--out-dir`: a page for every command the main page names, each with every option of its
    // command (the main page's `spmcal-<command>(1)` references resolve).
    let dir = tempfile::tempdir().unwrap();
    let run = spmcal(&["man", "--out-dir", dir.path().to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let main_page = std::fs::read_to_string(dir.path().join("spmcal.1")).unwrap();
    let mut named = 0;
    for command in ["ik", "fda", "check", "simulate", "estimate", "calibrate", "compare", "replay", "plan", "export"] {
        assert!(main_page.contains(&format!("spmcal\\-{command}(1)")), "{command} not named: {main_page}");
        let page = std::fs::read_to_string(dir.path().join(format!("spmcal-{command}.1"))).unwrap();
        assert!(page.contains(&format!(".TH spmcal-{command} 1")), "{page}");
        named += 1;
    }
    assert_eq!(named, 10);
    let calibrate = std::fs::read_to_string(dir.path().join("spmcal-calibrate.1")).unwrap();
    for option in ["dataset", "model", "config", "out", "report", "rrd", "json", "verbose"] {
        assert!(calibrate.contains(&format!("\\fB\\-\\-{option}\\fR")), "--{option} undocumented: {calibrate}");
    }
    let run = spmcal(&["--version"]);
    let version = String::from_utf8_lossy(&run.stdout);
    assert!(version.starts_with(&format!("spmcal {} (commit ", env!("CARGO_PKG_VERSION"))), "{version}");
    let commit = version.trim().trim_end_matches(')').rsplit(' ').next().unwrap().trim_end_matches("-dirty");
    assert!(commit == "unknown" || (commit.len() == 12 && commit.chars().all(|c| c.is_ascii_hexdigit())), "{version}");
    // A shell that does not exist is refused with the list.
    let run = spmcal(&["completions", "cmd.exe"]);
    assert!(!run.status.success() && String::from_utf8_lossy(&run.stderr).contains("possible values"));
}

/// `--json`'s envelope carries spmcal's version, and every warning and note the command printed at
/// its top level — a calibration's own (here: a workspace beyond the session's poses; the joint
/// scales 20 poses cannot tell from the offsets) as well as the session's.
#[test]
fn the_json_envelope_carries_the_version_and_every_warning_printed() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("wide.yaml");
    std::fs::write(&config, "workspace: {max_tilt_deg: 60, max_yaw_deg: 60}\n").unwrap();
    let params = dir.path().join("p.yaml");
    let run = |json: bool| {
        let mut args = vec!["calibrate", "--dataset", "datasets/agile_wrist_sim_20", "--config"];
        args.extend([config.to_str().unwrap(), "--out", params.to_str().unwrap()]);
        args.extend(json.then_some("--json"));
        spmcal(&args)
    };
    let text = run(false);
    assert!(text.status.success(), "{}", String::from_utf8_lossy(&text.stderr));
    let printed = String::from_utf8(text.stdout).unwrap();
    let json = run(true);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(v["version"], env!("CARGO_PKG_VERSION"));
    let of = |key: &str| -> Vec<String> {
        v[key].as_array().unwrap().iter().map(|w| w.as_str().unwrap().to_string()).collect()
    };
    let (warnings, notes) = (of("warnings"), of("notes"));
    assert!(warnings.iter().any(|w| w.contains("`workspace`")), "{warnings:?}");
    assert!(notes.iter().any(|n| n.contains("joint scales")), "{notes:?}");
    for w in &warnings {
        assert!(printed.contains(&format!("WARNING: {w}")), "{w} is not what the text printed:\n{printed}");
    }
    for n in &notes {
        assert!(printed.contains(&format!("note: {n}")), "{n} is not what the text printed:\n{printed}");
    }
}

/// Whatever `calibrate` writes, its own readers read back — even from a session that determines
/// the camera model poorly (every marker ten times as far: its depth scale's standard error is then
/// larger than any depth scale a file may state, and was refused on reading).
#[test]
fn a_parameters_file_calibrate_writes_reads_back_however_poor_the_session() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("far");
    std::fs::create_dir(&session).unwrap();
    for f in ["joints.csv", "session.yaml"] {
        std::fs::copy(format!("datasets/agile_wrist_sim_20/{f}"), session.join(f)).unwrap();
    }
    let markers = std::fs::read_to_string("datasets/agile_wrist_sim_20/markers.csv").unwrap();
    let mut far = String::new();
    for (k, line) in markers.lines().enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let row = match k {
            0 => line.to_string(),
            _ => {
                let xyz: Vec<String> =
                    fields[2..].iter().map(|v| (v.parse::<f64>().unwrap() * 10.0).to_string()).collect();
                format!("{},{},{}", fields[0], fields[1], xyz.join(","))
            }
        };
        far.push_str(&row);
        far.push('\n');
    }
    std::fs::write(session.join("markers.csv"), far).unwrap();
    let params = dir.path().join("p.yaml");
    let out = spmcal(&["calibrate", "--dataset", session.to_str().unwrap(), "--out", params.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let written = std::fs::read_to_string(&params).unwrap();
    assert!(written.contains("_std_error"), "{written}");
    let check = spmcal(&["check", "--params", params.to_str().unwrap()]);
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
}

/// A warning or note printed while loading (here: the recording's last frame, after the last
/// encoder sample) is a `note:` and in the `--json` envelope's `notes`, for `convert` as for the
/// commands that calibrate or compare.
#[test]
fn convert_says_a_recordings_edge_frame_as_a_note_in_text_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let bag = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let args =
        |to: &str| ["convert", "--dataset", "datasets/agile_wrist_free_motion_120s", "--to-bag", to].map(String::from);
    let text = Command::new(env!("CARGO_BIN_EXE_spmcal")).args(args(&bag("a.mcap"))).output().unwrap();
    assert!(text.status.success(), "{}", String::from_utf8_lossy(&text.stderr));
    let stderr = String::from_utf8(text.stderr).unwrap();
    assert!(
        stderr.starts_with("note: ") && stderr.contains("captures.csv:1708") && !stderr.contains("warning"),
        "{stderr}"
    );
    let json = Command::new(env!("CARGO_BIN_EXE_spmcal")).args(args(&bag("b.mcap"))).arg("--json").output().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(v["warnings"].as_array().unwrap().len(), 0, "{v}");
    let notes = v["notes"].as_array().unwrap();
    assert!(notes.len() == 1 && notes[0].as_str().unwrap().contains("captures.csv:1708"), "{notes:?}");
}

/// A quaternion typed or printed with four digits (its norm 1 within 10⁻⁴) is normalised, in
/// `--quat` as in `--orientations`; one whose norm is off by more than 10⁻³ is refused, its norm said.
#[test]
fn a_quaternion_with_four_digits_is_read_and_a_wrong_one_is_refused_with_its_norm() {
    let exact = spmcal(&["ik", "--quat", "0.984807753012208,0.17364817766693,0,0"]);
    let typed = spmcal(&["ik", "--quat", "0.9848,0.1736,0,0"]);
    assert!(typed.status.success(), "{}", String::from_utf8_lossy(&typed.stderr));
    let joints = |o: &std::process::Output| -> Vec<f64> {
        let text = String::from_utf8_lossy(&o.stdout).to_string();
        text.lines().nth(1).unwrap().split(',').skip(1).map(|v| v.parse().unwrap()).collect()
    };
    // 20° about x typed to four digits: within 2e-5 rad of the exact rotation, so are the joints
    // (their sensitivity to the orientation is of order one here).
    for (a, b) in joints(&exact).iter().zip(joints(&typed)) {
        assert!((a - b).abs() < 1e-4, "{a} {b}");
    }
    let wrong = spmcal(&["ik", "--quat", "0.9,0.17,0,0"]);
    let err = String::from_utf8_lossy(&wrong.stderr);
    assert!(!wrong.status.success() && err.contains("--quat has norm 0.915915, not 1 (within 1e-3)"), "{err}");
}

/// An orientation whose legs' working branches give readings the working-mode FDA does not bring
/// back (the MP upside down: another assembly mode's) is warned of, its pose named, in text and
/// JSON; one the working mode reaches is not.
#[test]
fn ik_warns_of_an_orientation_beyond_the_working_mode() {
    let upside_down = spmcal(&["ik", "--quat", "0,1,0,0", "--json"]);
    assert!(upside_down.status.success(), "{}", String::from_utf8_lossy(&upside_down.stderr));
    let err = String::from_utf8_lossy(&upside_down.stderr);
    assert!(
        err.contains("warning: 1 of 1 orientations lie beyond the working mode") && err.contains("--quat: pose 0"),
        "{err}"
    );
    let json: serde_json::Value = serde_json::from_slice(&upside_down.stdout).unwrap();
    assert!(json["warnings"][0].as_str().unwrap().contains("beyond the working mode"), "{json}");
    // 20° about x: reached, and nothing said.
    let tilted = spmcal(&["ik", "--quat", "0.984807753012208,0.17364817766693,0,0"]);
    assert!(tilted.status.success() && tilted.stderr.is_empty(), "{}", String::from_utf8_lossy(&tilted.stderr));
}
