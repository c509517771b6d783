//! Session folders: the corpus of bad sessions (each rejected with its expected message), poses
//! with few markers kept as data (only the per-pose estimator skips them, and says so), the model
//! override, and the write → read round trip.

use std::path::Path;

use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

#[test]
fn every_bad_session_is_rejected_with_its_message() {
    let corpus = Path::new("tests/data/bad_sessions");
    let mut cases = 0;
    for entry in std::fs::read_dir(corpus).unwrap() {
        let dir = entry.unwrap().path();
        let expected = std::fs::read_to_string(dir.join("expected.txt")).unwrap();
        let expected = expected.trim();
        let err = Session::load(&dir, None).expect_err(&format!("{} must be rejected", dir.display()));
        let text = err.to_string();
        assert!(text.contains(expected), "{}:\n  got      {text}\n  expected {expected}", dir.display());
        assert!(text.contains(&dir.display().to_string()), "{text} does not name the session folder");
        cases += 1;
    }
    assert!(cases >= 18, "only {cases} cases in the corpus");
}

#[test]
fn poses_with_few_markers_are_data_and_the_per_pose_estimator_says_what_it_skips() {
    // Poses with 0, 1 or 2 markers load without a word: the marker-level fit uses every marker.
    let (session, warnings) = Session::load(Path::new("tests/data/session_with_blind_pose"), None).unwrap();
    assert_eq!(session.poses.len(), 3);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(session.poses[2].time_s, Some(1.0));
    assert_eq!(session.poses[2].seen(), 2);
    // The per-pose estimator, which needs three, lists them.
    let estimate = spmcal::vision::SessionEstimate::of(&session, spmcal::vision::Method::Kabsch).unwrap();
    let skipped: Vec<u64> = estimate.skipped.iter().map(|s| s.pose).collect();
    assert_eq!(skipped, [1, 2]);
}

#[test]
fn a_reference_pose_with_two_markers_loads_and_only_the_per_pose_estimator_refuses_it() {
    let (session, _) = Session::load(Path::new("tests/data/reference_with_two_markers"), None).unwrap();
    let err = spmcal::vision::SessionEstimate::of(&session, spmcal::vision::Method::Kabsch).unwrap_err().to_string();
    assert!(err.contains("pose 0") && err.contains("2 markers"), "{err}");
}

#[test]
fn model_override_replaces_the_session_model() {
    let dir = Path::new("tests/data/bad_sessions/no_model");
    let (session, _) = Session::load(dir, Some(Path::new("models/agile_wrist.urdf"))).unwrap();
    assert_eq!(session.model, Path::new("models/agile_wrist.urdf"));
}

#[test]
fn write_then_read_gives_the_same_session() {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap();
    config.poses = 30;
    config.capture.sequential = true;
    config.camera.outlier_probability = 0.1;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    session.write(&out).unwrap();
    let (back, warnings) = Session::load(&out, None).unwrap();
    assert!(warnings.is_empty());
    // Sequential capture: a pose per capture, the station recorded.
    assert_eq!(back.poses.len(), session.poses.len());
    assert!(!back.poses.is_empty() && back.poses.iter().all(|p| p.seen() <= 1 && p.station.is_some()));
    assert_eq!(back.name, session.name);
    assert_eq!(back.markers, session.markers);
    assert_eq!(back.reference_pose, 0);
    // The shipped model is recorded by its name.
    assert_eq!(back.model, Path::new("agile_wrist"));
    // Numbers are written in their shortest round-trip form: equality is exact (the line each
    // pose was read from is bookkeeping, not data).
    let unlined: Vec<_> = back
        .poses
        .iter()
        .cloned()
        .map(|p| spmcal::dataset::SessionPose { line: 0, marker_lines: vec![0; p.markers.len()], ..p })
        .collect();
    assert!(unlined == session.poses, "the poses read back differ from those written");
    assert_eq!(back.poses[3].line, 5);
    let (t, tb) = (session.truth.as_ref().unwrap(), back.truth.as_ref().unwrap());
    assert_eq!(t.orientations.len(), tb.orientations.len());
    for (k, r) in &t.orientations {
        assert!(spmcal::math::so3::geodesic_angle(r, &tb.orientations[k]) < 1e-15);
    }
    // The parameters file stores degrees: an ulp or two.
    for (a, b) in t.parameters.legs.iter().zip(&tb.parameters.legs) {
        assert!((a.alpha1 - b.alpha1).abs() < 1e-15 && (a.delta - b.delta).abs() < 1e-15 && (a.u - b.u).amax() == 0.0);
    }
    // Writing into a folder that holds something other than a session is refused.
    std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
    let err = back.write(dir.path()).unwrap_err().to_string();
    assert!(err.contains("refusing to write"), "{err}");
}

/// Joint readings in degrees under `theta*_rad` columns load with a warning that says so, at the
/// first reading beyond a turn (the fit alone would only see poses near singularities); the
/// shipped sessions, in radians, load without it.
#[test]
fn joints_in_degrees_are_said_to_be_degrees() {
    let dir = tempfile::tempdir().unwrap();
    for file in ["session.yaml", "markers.csv", "joints.csv"] {
        std::fs::copy(Path::new("datasets/agile_wrist_sim_20").join(file), dir.path().join(file)).unwrap();
    }
    let model = Path::new("models/agile_wrist.urdf");
    let (_, warnings) = Session::load(dir.path(), Some(model)).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let joints = std::fs::read_to_string(dir.path().join("joints.csv")).unwrap();
    let mut lines = joints.lines();
    let mut degrees = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let mut fields: Vec<String> = line.split(',').map(String::from).collect();
        for f in &mut fields[1..4] {
            *f = format!("{}", f.parse::<f64>().unwrap().to_degrees());
        }
        degrees += &format!("{}\n", fields.join(","));
    }
    std::fs::write(dir.path().join("joints.csv"), &degrees).unwrap();
    // Refused at the first reading beyond a turn, at its line and column, as degrees (issue 37:
    // it used to load and fail later as "a pose at or near a parallel singularity").
    let (line, column) = degrees
        .lines()
        .enumerate()
        .skip(1)
        .find_map(|(k, l)| {
            let cells: Vec<f64> = l.split(',').skip(1).take(3).map(|f| f.parse().unwrap()).collect();
            cells.iter().position(|v| v.abs() > std::f64::consts::TAU).map(|j| (k + 1, j + 1))
        })
        .unwrap();
    let e = Session::load(dir.path(), Some(model)).unwrap_err();
    assert_eq!((e.line, e.column.as_deref()), (Some(line), Some(format!("theta{column}_rad").as_str())), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("joints.csv:") && text.contains("looks like degrees; spmcal reads joints in radians"),
        "{text}"
    );
}
