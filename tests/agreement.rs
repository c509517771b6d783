//! Files that must agree with each other and with themselves (issue 19): a session folder holds
//! one kind of session, the captures of a station are one pose, a plan's steps number its rows
//! and its rows agree with the model and the workspace, a recording holds enough to calibrate
//! from, and name lists are checked in linear time (a 200,000-name list with one repeat at its
//! end is refused, naming the repeat).

use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::plan::PlannedPose;
use spmcal::sim::SimConfig;

fn model_path() -> PathBuf {
    std::fs::canonicalize("models/agile_wrist.urdf").unwrap()
}

/// A copy of a shipped session's files into `dir`, its `model:` made absolute.
fn copy_session(from: &str, dir: &Path, files: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    for f in files {
        std::fs::copy(Path::new(from).join(f), dir.join(f)).unwrap();
    }
    let yaml = std::fs::read_to_string(Path::new(from).join("session.yaml")).unwrap();
    let yaml: String = yaml
        .lines()
        .map(|l| if l.starts_with("model:") { format!("model: {}", model_path().display()) } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.join("session.yaml"), yaml + "\n").unwrap();
}

fn load_error(dir: &Path) -> String {
    Session::load(dir, None).expect_err("must be refused").to_string()
}

/// A short free-motion recording written into `dir`.
fn recording(dir: &Path) {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
    config.recording.as_mut().unwrap().duration_s = 3.0;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    session.write(dir).unwrap();
}

#[test]
fn a_folder_with_static_and_stream_files_is_refused_naming_both_pairs() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("both");
    recording(&dir);
    assert!(Session::load(&dir, None).unwrap().0.streams.is_some());
    for f in ["joints.csv", "markers.csv"] {
        std::fs::copy(Path::new("datasets/agile_wrist_sim_20").join(f), dir.join(f)).unwrap();
    }
    let err = load_error(&dir);
    for name in ["joints.csv", "markers.csv", "encoders.csv", "captures.csv", "both"] {
        assert!(err.contains(name), "{name} not named: {err}");
    }
    // One file of each kind is as ambiguous as two.
    std::fs::remove_file(dir.join("markers.csv")).unwrap();
    std::fs::remove_file(dir.join("captures.csv")).unwrap();
    let err = load_error(&dir);
    assert!(err.contains("joints.csv") && err.contains("encoders.csv") && err.contains("one pair"), "{err}");
}

#[test]
fn a_session_written_over_another_kind_leaves_one_session() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    copy_session("datasets/agile_wrist_sim_20", &dir, &["joints.csv", "markers.csv", "truth.yaml"]);
    let (static_session, _) = Session::load(&dir, None).unwrap();
    // A recording written where a static session was: the static files go.
    recording(&dir);
    let (back, _) = Session::load(&dir, None).unwrap();
    assert!(back.streams.is_some());
    assert!(!dir.join("joints.csv").exists() && !dir.join("markers.csv").exists());
    // And back: the stream files go, and the truth the new session lacks.
    let without_truth = Session { truth: None, ..static_session };
    without_truth.write(&dir).unwrap();
    let (again, _) = Session::load(&dir, None).unwrap();
    assert!(again.streams.is_none() && again.truth.is_none());
    assert!(!dir.join("encoders.csv").exists() && !dir.join("truth.yaml").exists());
}

/// The shipped sequential session with `edit` applied to its `joints.csv` lines (0 = header).
fn sequential_with(dir: &Path, edit: impl Fn(&mut Vec<String>)) -> String {
    copy_session("datasets/agile_wrist_sequential_200", dir, &["joints.csv", "markers.csv"]);
    let text = std::fs::read_to_string(dir.join("joints.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    edit(&mut lines);
    std::fs::write(dir.join("joints.csv"), lines.join("\n") + "\n").unwrap();
    load_error(dir)
}

fn with_station(line: &str, station: &str) -> String {
    let cut = line.rfind(',').unwrap();
    format!("{},{station}", &line[..cut])
}

#[test]
fn stations_must_be_given_and_their_captures_one_pose() {
    // The shipped sequential session (a drift of 0.2° per axis between captures) loads.
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sequential_200"), None).unwrap();
    assert!(!session.poses.is_empty() && session.poses.iter().all(|p| p.station.is_some()));
    let tmp = tempfile::tempdir().unwrap();
    // An empty station is refused at its line, like `nan`, and so is a fraction.
    for (k, (bad, expected)) in
        [("", "the station is empty"), ("nan", "`nan` is not a station number"), ("1.5", "`1.5` is not a station")]
            .into_iter()
            .enumerate()
    {
        let err = sequential_with(&tmp.path().join(format!("e{k}")), |l| l[6] = with_station(&l[6], bad));
        assert!(err.contains("joints.csv:7: column `station`") && err.contains(expected), "{err}");
    }
    // Line 6 (station 1's first capture) given station 0: tens of degrees from station 0's captures.
    let err = sequential_with(&tmp.path().join("far"), |l| l[5] = with_station(&l[5], "0"));
    assert!(err.contains("joints.csv:6: column `station`: station 0:"), "{err}");
    assert!(err.contains("at line 5") && err.contains("cannot be one pose"), "{err}");
    // A station number used again far down the file: its line and the station's earlier capture.
    let err = sequential_with(&tmp.path().join("reused"), |l| l[400] = with_station(&l[400], "2"));
    assert!(err.contains("joints.csv:401: column `station`: station 2:") && err.contains("at line "), "{err}");
    // Within the limit: a capture moved by 4° in one joint stays in its station.
    let near = tmp.path().join("near");
    copy_session("datasets/agile_wrist_sequential_200", &near, &["joints.csv", "markers.csv"]);
    let text = std::fs::read_to_string(near.join("joints.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let first: Vec<f64> = lines[1].split(',').map(|x| x.parse().unwrap()).collect();
    let mut fields: Vec<String> = lines[2].split(',').map(str::to_string).collect();
    fields[1] = (first[1] + 4f64.to_radians()).to_string();
    lines[2] = fields.join(",");
    std::fs::write(near.join("joints.csv"), lines.join("\n") + "\n").unwrap();
    assert!(Session::load(&near, None).is_ok());
}

#[test]
fn a_session_whose_stations_would_not_load_is_not_written() {
    let mut config = sim_config();
    (config.poses, config.capture.sequential, config.capture.motion_deg) = (10, true, 3.0);
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let err = session.write(&tmp.path().join("drift")).unwrap_err().to_string();
    assert!(err.contains("joints.csv: station ") && err.contains("lower `capture.motion_deg`"), "{err}");
    assert!(!tmp.path().join("drift").exists());
    // A station on some poses only would be lost on writing: refused too.
    config.capture.motion_deg = 0.05;
    let (mut session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    session.write(&tmp.path().join("held")).unwrap();
    session.poses[3].station = None;
    let err = session.write(&tmp.path().join("partial")).unwrap_err().to_string();
    assert!(err.contains(&format!("pose {} has no station", session.poses[3].id)), "{err}");
}

#[test]
fn a_recording_with_almost_no_captures_is_refused_at_load_naming_captures_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let good = tmp.path().join("good");
    recording(&good);
    let captures = std::fs::read_to_string(good.join("captures.csv")).unwrap();
    let lines: Vec<&str> = captures.lines().collect();
    let same_frame = |l: &str| {
        let (_, rest) = l.split_once(',').unwrap();
        format!("{},{rest}", lines[1].split(',').next().unwrap())
    };
    let cases = [
        ("header only", lines[..1].join("\n"), "holds no captures"),
        ("one capture", lines[..2].join("\n"), "holds only 1 capture"),
        ("two captures", lines[..3].join("\n"), "holds only 2 captures, in 2 camera frames"),
        (
            "one frame",
            [lines[0].to_string(), lines[1].to_string(), same_frame(lines[2]), same_frame(lines[3])].join("\n"),
            "in 1 camera frame",
        ),
    ];
    for (what, text, expected) in cases {
        let dir = tmp.path().join(what.replace(' ', "_"));
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["session.yaml", "encoders.csv"] {
            std::fs::copy(good.join(f), dir.join(f)).unwrap();
        }
        std::fs::write(dir.join("captures.csv"), text + "\n").unwrap();
        let err = load_error(&dir);
        assert!(err.contains("captures.csv: ") && err.contains(expected), "{what}: {err}");
        assert!(err.contains("at least 3 camera frames"), "{what}: {err}");
    }
}

/// Up to 200,000 distinct names short enough for a settings file: a letter, then two or three
/// letters or digits.
fn names(n: usize) -> Vec<String> {
    let letters: Vec<char> = ('a'..='z').chain('A'..='Z').collect();
    let alnum: Vec<char> = letters.iter().copied().chain('0'..='9').collect();
    let three = letters.iter().flat_map(|&a| {
        let alnum = alnum.clone();
        alnum.clone().into_iter().flat_map(move |b| alnum.clone().into_iter().map(move |c| format!("{a}{b}{c}")))
    });
    let four = alnum.iter().flat_map(|&d| alnum.iter().map(move |&e| format!("zz{d}{e}")));
    three.chain(four).take(n).collect()
}

#[test]
fn a_200000_name_list_with_a_repeat_at_its_end_is_refused_naming_the_repeat() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("many");
    copy_session("datasets/agile_wrist_sim_20", &dir, &["joints.csv", "markers.csv"]);
    let mut list = names(199_999);
    let repeat = list[77_777].clone();
    list.push(repeat.clone());
    assert_eq!(list.len(), 200_000);
    let yaml = format!("name: many\nmodel: {}\nmarkers: [{}]\n", model_path().display(), list.join(","));
    std::fs::write(dir.join("session.yaml"), yaml).unwrap();
    let err = load_error(&dir);
    assert!(err.contains(&format!("marker name `{repeat}`")), "{err}");
    assert!(err.contains("markers 77778 and 200000"), "{err}");
    // Without the repeat the list is accepted, and the markers file is read against it with one
    // look-up per row: its unknown name is named, the list shown only in part.
    list.pop();
    let yaml = format!("name: many\nmodel: {}\nmarkers: [{}]\n", model_path().display(), list.join(","));
    std::fs::write(dir.join("session.yaml"), yaml).unwrap();
    let err = load_error(&dir);
    assert!(err.contains("markers.csv:2: column `marker`: unknown marker `m1`"), "{err}");
    assert!(err.contains("(199999 in all)") && err.len() < 1000, "{err}");
}

/// `R = exp(tilt a) exp(yaw z)`, `a` horizontal at `azimuth` (degrees), as the workspace is drawn.
fn tilt_yaw(azimuth: f64, tilt: f64, yaw: f64) -> Rotation3<f64> {
    let (a, t, y) = (azimuth.to_radians(), tilt.to_radians(), yaw.to_radians());
    so3::exp(&(Vector3::new(a.cos(), a.sin(), 0.0) * t)) * so3::exp(&(Vector3::z() * y))
}

/// A plan of orientations `(azimuth, tilt, yaw)` in degrees with the model's joints there.
fn plan_text(model: &RobotModel, poses: &[(f64, f64, f64)]) -> String {
    let planned: Vec<PlannedPose> = poses
        .iter()
        .enumerate()
        .map(|(k, &(azimuth, tilt, yaw))| {
            let rotation = tilt_yaw(azimuth, tilt, yaw);
            PlannedPose { step: k as u64 + 1, rotation, joints: model.spm.ik(&rotation).unwrap() }
        })
        .collect();
    PlannedPose::csv(&planned)
}

const POSES: [(f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0),
    (30.0, 15.0, 10.0),
    (150.0, 20.0, -15.0),
    (270.0, 25.0, 5.0),
    (90.0, 10.0, 20.0),
    (200.0, 5.0, -5.0),
];

fn edit_line(text: &str, k: usize, edit: impl Fn(&str) -> String) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[k] = edit(&lines[k]);
    lines.join("\n") + "\n"
}

#[test]
fn a_plans_steps_number_its_rows_and_every_gap_repeat_or_swap_is_located() {
    let model = RobotModel::load(&model_path()).unwrap();
    let good = plan_text(&model, &POSES);
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("plan.csv");
    let read = |text: &str| {
        std::fs::write(&path, text).unwrap();
        PlannedPose::read(&path)
    };
    assert_eq!(read(&good).unwrap().len(), 6);
    let step = |k: usize, s: &str| edit_line(&good, k, |l| format!("{s}{}", &l[l.find(',').unwrap()..]));
    let mut lines: Vec<&str> = good.lines().collect();
    lines.remove(4);
    let gap = lines.join("\n");
    lines = good.lines().collect();
    lines.swap(3, 4);
    let swapped = lines.join("\n");
    let cases = [
        (gap, "plan.csv:5: column `step`: step 5 follows step 3: step 4 is missing"),
        (step(6, "2"), "plan.csv:7: column `step`: step 2 appears twice (also at line 3)"),
        (step(2, "1"), "plan.csv:3: column `step`: step 1 appears twice (also at line 2)"),
        (step(1, "0"), "plan.csv:2: column `step`: step 0"),
        (step(1, "2"), "plan.csv:2: column `step`: the first step is 2"),
        (step(6, "9"), "plan.csv:7: column `step`: step 9 follows step 5: step 6 is missing"),
        (swapped, "plan.csv:4: column `step`: step 4 comes before step 3 (line 5)"),
    ];
    for (text, expected) in cases {
        let err = read(&text).unwrap_err().to_string();
        assert!(err.contains(expected), "expected `{expected}` in {err}");
    }
    // The steps of a plan starting at 2 are all one off: the first row says so.
    let shifted: String = good
        .lines()
        .enumerate()
        .map(|(k, l)| if k == 0 { l.to_string() } else { format!("{}{}", k + 1, &l[l.find(',').unwrap()..]) })
        .collect::<Vec<_>>()
        .join("\n");
    let err = read(&shifted).unwrap_err().to_string();
    assert!(err.contains("plan.csv:2: column `step`: the first step is 2"), "{err}");
}

fn sim_config() -> SimConfig {
    SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap()
}

/// Simulate the plan `text` (written as `plan.csv`) read into the config: the error, if any.
fn simulate_plan(text: &str, config: &SimConfig) -> Result<Session, String> {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("plan.csv");
    std::fs::write(&path, text).unwrap();
    let mut config = config.clone();
    PlannedPose::read_into(&path, &mut config).map_err(|e| e.to_string())?;
    assert_eq!(config.poses, text.lines().count() - 1);
    let model = RobotModel::load(&config.model).unwrap();
    config.simulate(&model, &mut |_| {}).map(|(s, _)| s).map_err(|e| e.to_string())
}

#[test]
fn a_plan_row_must_agree_with_the_model_and_lie_inside_the_workspace() {
    let config = sim_config();
    let model = RobotModel::load(&config.model).unwrap();
    let good = plan_text(&model, &POSES);
    let session = simulate_plan(&good, &config).unwrap();
    assert_eq!(session.poses.len(), 6);
    let joint = |k: usize, delta: f64| {
        edit_line(&good, k, |l| {
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            f[6] = (f[6].parse::<f64>().unwrap() + delta).to_string();
            f.join(",")
        })
    };
    // Joints that contradict the quaternion: a degree off, and 1e-5 rad off.
    let err = simulate_plan(&joint(3, 1f64.to_radians()), &config).unwrap_err();
    eprintln!("{err}");
    assert!(err.contains("plan.csv:4: step 3: its joints") && err.contains("from its quaternion"), "{err}");
    assert!(err.contains("under the model agile_wrist"), "{err}");
    let err = simulate_plan(&joint(5, 1e-5), &config).unwrap_err();
    assert!(err.contains("plan.csv:6: step 5: its joints"), "{err}");
    // Rounding (a few ulps) is not a contradiction.
    simulate_plan(&joint(5, 1e-12), &config).unwrap();
    // An orientation the model cannot reach: leg 1's platform axis on its actuated axis.
    let edited = edit_line(&good, 2, |l| {
        let f: Vec<&str> = l.split(',').collect();
        let (c, s) = (35.264389682754654f64.to_radians().cos(), 35.264389682754654f64.to_radians().sin());
        format!("{},{c},{},0,0,{}", f[0], -s, f[5..].join(","))
    });
    let err = simulate_plan(&edited, &config).unwrap_err();
    assert!(err.contains("plan.csv:3: step 2: the model") && err.contains("cannot reach"), "{err}");
    // Rows that agree with the model, outside the config's workspace (tilt 30°, yaw 30°).
    let mut poses = POSES.to_vec();
    poses[3] = (0.0, 40.0, 0.0);
    let err = simulate_plan(&plan_text(&model, &poses), &config).unwrap_err();
    assert!(err.contains("plan.csv:5: step 4: its orientation tilts 40.000°"), "{err}");
    assert!(err.contains("`workspace.max_tilt_deg`: 30°"), "{err}");
    poses[3] = (0.0, 10.0, -40.0);
    let err = simulate_plan(&plan_text(&model, &poses), &config).unwrap_err();
    assert!(err.contains("plan.csv:5: step 4: its orientation yaws -40.000°"), "{err}");
    // A config with a stricter workspace than the plan's.
    let mut strict = config.clone();
    strict.workspace.min_conditioning = 0.999;
    let err = simulate_plan(&good, &strict).unwrap_err();
    assert!(err.contains("plan.csv:2: step 1:") && err.contains("`workspace.min_conditioning` (0.999)"), "{err}");
    // A free-motion recording takes no plan.
    let mut recording = config.clone();
    recording.recording = Some(spmcal::sim::Recording::default());
    let err = simulate_plan(&good, &recording).unwrap_err();
    assert!(err.contains("plan.csv: ") && err.contains("free-motion recording"), "{err}");
}

#[test]
fn a_plan_given_as_orientations_alone_is_checked_against_the_workspace_by_step() {
    let mut config = sim_config();
    let model = RobotModel::load(&config.model).unwrap();
    let tilt = so3::exp(&(Vector3::x() * 40f64.to_radians()));
    config.plan = Some(vec![Rotation3::identity(), tilt, Rotation3::identity()]);
    let err = config.simulate(&model, &mut |_| {}).unwrap_err().to_string();
    assert!(err.starts_with("plan step 2: its orientation tilts 40.000°"), "{err}");
}
