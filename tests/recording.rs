//! Rerun recordings, decoded with the rerun crate's own decoder: entity paths, the poses on the
//! timeline, and logged values against what the library computed. And `rerun rrd verify` by the
//! official Rerun CLI of the same version (missing: a failure under `CI=true`, elsewhere a
//! visible skip).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

#[path = "common/outside_tool.rs"]
mod outside_tool;

use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};
use spmcal::calib::{CalibConfig, FitLevel, calibrate};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;

/// The recording's data chunks (the blueprint's are left out).
fn chunks(path: &Path) -> Vec<Chunk> {
    let reader = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    DecoderApp::decode_lazy(reader)
        .filter_map(|msg| match msg.expect("a well-formed rrd stream") {
            LogMsg::ArrowMsg(store, arrow) if store.is_recording() => Some(Chunk::from_arrow_msg(&arrow).unwrap()),
            _ => None,
        })
        .collect()
}

/// `(timeline value, scalar)` of every row logged at `entity` on `timeline`.
fn scalars(chunks: &[Chunk], entity: &str, timeline: &'static str) -> BTreeMap<i64, f64> {
    let component = rerun::Scalars::descriptor_scalars().component;
    let mut out = BTreeMap::new();
    for c in chunks
        .iter()
        .filter(|c| c.entity_path().to_string() == format!("/{entity}") || c.entity_path().to_string() == entity)
    {
        let Some(times) = c.timelines().get(&timeline.into()) else { continue };
        // A time per row where the chunk holds the scalars: a shorter column of values would
        // otherwise drop rows unseen.
        let rows = c.iter_slices::<f64>(component).count();
        if rows == 0 {
            continue;
        }
        assert_eq!(times.times_raw().len(), rows, "{entity} on {timeline}");
        for (t, v) in times.times_raw().iter().zip(c.iter_slices::<f64>(component)) {
            out.insert(*t, v[0]);
        }
    }
    out
}

fn entities(chunks: &[Chunk]) -> BTreeSet<String> {
    chunks.iter().map(|c| c.entity_path().to_string().trim_start_matches('/').to_string()).collect()
}

#[test]
fn calibration_recording_has_the_entities_poses_and_values() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sim_400"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let config = CalibConfig { fit: FitLevel::Orientations, ..CalibConfig::default() };
    let calibration = calibrate(&session, &model, &config, &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("calibration.rrd");
    let scene = spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap();
    let summary = scene.write(&path).unwrap();
    assert!(summary.bytes > 0 && summary.poses == session.poses.len());

    let chunks = chunks(&path);
    let found = entities(&chunks);
    for e in [
        "world/base",
        "world/base/actuated_axes",
        "world/camera",
        "world/legs/leg1/proximal",
        "world/legs/leg3/distal",
        "world/mp/fda_nominal",
        "world/mp/fda_calibrated",
        "world/mp/vision",
        "world/markers/measured",
        "world/markers/predicted",
        "errors/e_j",
        "errors/fda_vs_vision/nominal",
        "errors/fda_vs_vision/calibrated",
        "fit/cost",
        "fit/step",
        "parameters/before",
        "parameters/after",
    ] {
        assert!(found.contains(e), "{e} missing; found {found:?}");
    }
    // Every pose on the `pose` timeline, and the capture time beside it.
    let poses: BTreeSet<i64> = chunks
        .iter()
        .filter(|c| c.entity_path().to_string().contains("legs/leg1/proximal"))
        .flat_map(|c| c.timelines().get(&"pose".into()).map(|t| t.times_raw().to_vec()).unwrap_or_default())
        .collect();
    assert_eq!(poses.len(), session.poses.len());
    assert!(chunks.iter().any(|c| c.timelines().contains_key(&"time".into())));
    // Logged values are the computed ones: e_j per pose, and the fit's cost per iteration.
    let e = scalars(&chunks, "errors/e_j", "pose");
    let spmcal::calib::Fitted::Orientations { vision, .. } = &calibration.fitted else { panic!("orientation level") };
    assert_eq!(e.len(), vision.poses.len());
    for (pose, estimate) in &vision.poses {
        assert_eq!(e[&(*pose as i64)], estimate.error);
    }
    let cost = scalars(&chunks, "fit/cost", "iteration");
    assert_eq!(cost.len(), calibration.calibrated.log.len());
    assert_eq!(cost[&1], calibration.calibrated.log[0].cost);
    let after = scalars(&chunks, "errors/fda_vs_vision/calibrated", "pose");
    let rms = (after.values().map(|d| d * d).sum::<f64>() / after.len() as f64).sqrt();
    let report = &calibration.report.after;
    let expected = ((report.fit.rms.powi(2) * report.fit.count as f64
        + report.held_out.unwrap().rms.powi(2) * report.held_out.unwrap().count as f64)
        / session.poses.len() as f64)
        .sqrt();
    assert!((rms - expected).abs() < 1e-12, "{rms} vs {expected}");
}

#[test]
fn replay_recording_shows_every_pose_and_the_markers_where_the_camera_saw_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("replay.rrd");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["replay", "--dataset", "datasets/agile_wrist_sim_20", "--rrd", path.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let chunks = chunks(&path);
    let found = entities(&chunks);
    assert!(
        found.contains("world/mp/fda_nominal")
            && found.contains("world/mp/vision")
            && found.contains("world/markers/measured")
    );
    let poses: BTreeSet<i64> = chunks
        .iter()
        .filter(|c| c.entity_path().to_string().contains("markers/measured"))
        .flat_map(|c| c.timelines().get(&"pose".into()).map(|t| t.times_raw().to_vec()).unwrap_or_default())
        .collect();
    assert_eq!(poses.len(), 20);
    // No temporary file is left beside the recording.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn every_command_writes_a_recording() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal")).args(args).output().unwrap();
        assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    };
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run(&[
        "simulate",
        "--config",
        "configs/simulate_agile_wrist.yaml",
        "--poses",
        "15",
        "--out",
        &path("sim"),
        "--rrd",
        &path("sim.rrd"),
    ]);
    run(&["estimate", "--dataset", &path("sim"), "--out", &path("e.csv"), "--rrd", &path("estimate.rrd")]);
    run(&[
        "calibrate",
        "--dataset",
        "datasets/agile_wrist_sim_20",
        "--out",
        &path("p.yaml"),
        "--rrd",
        &path("cal.rrd"),
    ]);
    run(&[
        "compare",
        "--dataset",
        "datasets/agile_wrist_sim_20",
        "--params",
        &path("p.yaml"),
        "--json",
        "--rrd",
        &path("cmp.rrd"),
    ]);
    let sim = entities(&chunks(Path::new(&path("sim.rrd"))));
    assert!(sim.contains("world/mp/truth") && sim.contains("parameters/truth"), "{sim:?}");
    assert!(entities(&chunks(Path::new(&path("estimate.rrd")))).contains("errors/e_j"));
    let cmp = entities(&chunks(Path::new(&path("cmp.rrd"))));
    assert!(cmp.contains("errors/fda_vs_vision/nominal") && cmp.contains("errors/fda_vs_vision/calibrated"), "{cmp:?}");
    assert!(cmp.contains("world/mp/fda_calibrated"));
}

#[test]
fn the_official_rerun_cli_verifies_the_recording() {
    let Ok(version) = std::process::Command::new("rerun").arg("--version").output() else {
        return outside_tool::missing("the Rerun CLI", "pip install rerun-sdk==0.36.3");
    };
    let version = String::from_utf8_lossy(&version.stdout);
    if !version.contains("0.36") {
        return outside_tool::missing(
            &format!("the Rerun CLI 0.36.x (found {version})"),
            "pip install rerun-sdk==0.36.3",
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("replay.rrd");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal"))
        .args(["replay", "--dataset", "datasets/agile_wrist_sim_20", "--rrd", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success());
    let verify = std::process::Command::new("rerun").args(["rrd", "verify", path.to_str().unwrap()]).output().unwrap();
    assert!(
        verify.status.success(),
        "rerun rrd verify: {}{}",
        String::from_utf8_lossy(&verify.stdout),
        String::from_utf8_lossy(&verify.stderr)
    );
}

/// `(origin, contents)` of every view in the recording's default blueprint.
fn blueprint_views(path: &Path) -> Vec<String> {
    let reader = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut origins = Vec::new();
    for msg in DecoderApp::decode_lazy(reader) {
        let LogMsg::ArrowMsg(store, arrow) = msg.unwrap() else { continue };
        if store.is_recording() {
            continue;
        }
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap();
        for component in chunk.components_identifiers() {
            if component.as_str().contains("space_origin") {
                origins
                    .extend(chunk.iter_slices::<String>(component).flat_map(|s| s.into_iter().map(|s| s.to_string())));
            }
        }
    }
    origins
}

#[test]
fn the_default_blueprint_shows_only_panels_with_data() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sim_20"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let calibration = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let settings = spmcal::plan::PlanSettings { poses: 12, candidates: 300, ..Default::default() };
    let config = spmcal::sim::SimConfig::default();
    let plan = spmcal::plan::Plan::design(&model, None, &config, &settings, None).unwrap();
    let planned = plan.session(&model);
    for (name, scene) in [
        ("replay", spmcal::record::Scene::replay(&session, &model, None).unwrap()),
        ("calibration", spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap()),
        ("plan", spmcal::record::Scene::plan(&planned, &model, &plan, None).unwrap()),
    ] {
        let path = dir.path().join(format!("{name}.rrd"));
        scene.write(&path).unwrap();
        let found = entities(&chunks(&path));
        let origins = blueprint_views(&path);
        assert!(origins.iter().any(|o| o == "/world"), "{name}: no 3-D view in {origins:?}");
        for origin in &origins {
            let origin = origin.trim_start_matches('/');
            // Every view looks at something the recording holds (no empty panel on opening).
            assert!(found.iter().any(|e| e.starts_with(origin)), "{name}: view of `{origin}` has no data; {found:?}");
        }
        // The fit is shown as a static table, which needs no timeline; a replay has none.
        assert_eq!(origins.iter().any(|o| o == "/fit/iterations"), name == "calibration", "{name}: {origins:?}");
    }
}

#[test]
fn marker_level_calibration_recording_shows_fitted_and_model_markers_and_per_pose_errors() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sequential_200"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let calibration = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("markers.rrd");
    let scene = spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap();
    scene.write(&path).unwrap();
    let chunks = chunks(&path);
    let found = entities(&chunks);
    for e in
        ["world/markers/model", "world/markers/predicted", "world/markers/measured", "errors/markers_mm/calibrated"]
    {
        assert!(found.contains(e), "{e} missing; found {found:?}");
    }
    // The per-pose values are the fit's: their RMS over observations is the report's.
    let after = scalars(&chunks, "errors/markers_mm/calibrated", "pose");
    assert_eq!(after.len(), calibration.report.markers.as_ref().unwrap().poses);
    // One marker per capture here, so each pose's value is its one residual.
    let rms = (after.values().map(|d| d * d).sum::<f64>() / after.len() as f64).sqrt();
    let report = calibration.report.markers.as_ref().unwrap().after.errors.rms;
    assert!((rms - report).abs() < 1e-9, "{rms} vs {report}");
}

#[test]
fn a_session_captured_one_marker_at_a_time_replays_with_calibrated_parameters() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_sequential_200"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let calibration =
        calibrate(&session, &model, &CalibConfig { folds: 0, ..CalibConfig::default() }, &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("replay.rrd");
    let scene = spmcal::record::Scene::replay(&session, &model, Some(&calibration.parameters)).unwrap();
    scene.write(&path).unwrap();
    let found = entities(&chunks(&path));
    for e in ["world/mp/fda_calibrated", "world/markers/measured", "world/markers/predicted", "world/markers/model"] {
        assert!(found.contains(e), "{e} missing; found {found:?}");
    }
}

#[test]
fn a_free_motion_calibration_is_recorded_at_its_fitted_latency() {
    let (session, _) = Session::load(Path::new("datasets/agile_wrist_free_motion_120s"), None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let calibration =
        calibrate(&session, &model, &CalibConfig { folds: 0, ..CalibConfig::default() }, &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("free_motion.rrd");
    let scene = spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap();
    scene.write(&path).unwrap();
    // One marker per frame: each frame's logged error is its residual, and their RMS is the fit's
    // (the recording sees the joints at the fitted latency, not at the start's).
    let chunks = chunks(&path);
    let after = scalars(&chunks, "errors/markers_mm/calibrated", "pose");
    let rms = (after.values().map(|d| d * d).sum::<f64>() / after.len() as f64).sqrt();
    let report = calibration.report.markers.as_ref().unwrap().after.errors.rms;
    assert!((rms - report).abs() < 1e-9 * report.max(1.0), "{rms} vs {report}");
    // The frames are on the `time` timeline too (camera time, seconds), which the layout selects.
    let frame_times = scalars(&chunks, "errors/markers_mm/calibrated", "time");
    assert_eq!(frame_times.len(), after.len());
}

/// `(pose, 2-D points)` of every row logged at `entity` on the `pose` timeline.
fn points2d(chunks: &[Chunk], entity: &str) -> BTreeMap<i64, Vec<[f32; 2]>> {
    let component = rerun::Points2D::descriptor_positions().component;
    let mut out = BTreeMap::new();
    for c in chunks.iter().filter(|c| c.entity_path().to_string().trim_start_matches('/') == entity) {
        let Some(times) = c.timelines().get(&"pose".into()) else { continue };
        let rows: Vec<Vec<[f32; 2]>> = c.iter_slices::<[f32; 2]>(component).map(|s| s.to_vec()).collect();
        assert_eq!(times.times_raw().len(), rows.len(), "{entity}");
        out.extend(times.times_raw().iter().copied().zip(rows));
    }
    out
}

/// The names of the components logged at `entity` (static or not).
fn components_at(chunks: &[Chunk], entity: &str) -> BTreeSet<String> {
    chunks
        .iter()
        .filter(|c| c.entity_path().to_string().trim_start_matches('/') == entity)
        .flat_map(|c| c.components_identifiers().map(|k| k.as_str().to_string()).collect::<Vec<_>>())
        .collect()
}

#[test]
fn a_pixel_session_is_recorded_in_each_cameras_image_plane() {
    let dataset = Path::new("datasets/agile_wrist_stereo_200");
    let (session, _) = Session::load(dataset, None).unwrap();
    let model = RobotModel::load(&session.model).unwrap();
    let calibration = calibrate(&session, &model, &CalibConfig::default(), &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pixels.rrd");
    spmcal::record::Scene::calibration(&session, &model, &calibration).unwrap().write(&path).unwrap();
    let chunks = chunks(&path);
    let found = entities(&chunks);
    // pixels.csv's rows per (pose, camera), read independently of the session reader.
    let text = std::fs::read_to_string(dataset.join("pixels.csv")).unwrap();
    let mut rows: BTreeMap<(i64, String), usize> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        *rows.entry((f[0].parse().unwrap(), f[2].to_string())).or_default() += 1;
    }
    let rig = &calibration.report.markers.as_ref().unwrap().rig.as_ref().unwrap().refined;
    let registration = calibration.parameters.camera.unwrap();
    let spm = calibration.parameters.spm().unwrap();
    for (c, camera) in rig.cameras.iter().enumerate() {
        let plane = format!("world/camera/{}", camera.name);
        // The Pinhole: intrinsics and resolution.
        let components = components_at(&chunks, &plane);
        for k in ["Pinhole:image_from_camera", "Pinhole:resolution", "Transform3D:translation"] {
            assert!(components.contains(k), "{plane}: {k} missing; {components:?}");
        }
        assert!(found.contains(&format!("{plane}/border")), "{plane}/border missing");
        let measured = points2d(&chunks, &format!("{plane}/measured"));
        let predicted = points2d(&chunks, &format!("{plane}/predicted"));
        let nominal = points2d(&chunks, &format!("{plane}/nominal"));
        assert_eq!(measured.len(), session.poses.len(), "{plane}: a row for every pose");
        for (pose, points) in &measured {
            let expected = rows.get(&(*pose, camera.name.clone())).copied().unwrap_or(0);
            assert_eq!(points.len(), expected, "{plane}/measured at pose {pose}");
            assert_eq!(predicted[pose].len(), expected, "{plane}/predicted at pose {pose}");
            assert_eq!(nominal[pose].len(), expected, "{plane}/nominal at pose {pose}");
        }
        // The predicted pixels are the calibrated model's: FDA, the fitted markers, the registration
        // and the refined rig, projected here through the public API (Rerun's pixel centres are
        // Kalibr's + 0.5; f32 in the file: 1e-3 px).
        let mut compared = 0;
        for pose in &session.poses {
            let r = spm.forward(&pose.joints).unwrap();
            let mut expected: Vec<[f64; 2]> = pose
                .pixels
                .iter()
                .filter(|p| p.camera == c)
                .map(|p| {
                    let marker = calibration.parameters.marker(&session.markers[p.marker]).unwrap();
                    let y = registration.to_camera(&(r * marker));
                    let q = rig.project(c, &y).unwrap().lens.pixel;
                    [q.x + 0.5, q.y + 0.5]
                })
                .collect();
            let logged = &predicted[&(pose.id as i64)];
            expected.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let mut logged: Vec<[f64; 2]> = logged.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
            logged.sort_by(|a, b| a.partial_cmp(b).unwrap());
            for (a, b) in expected.iter().zip(&logged) {
                assert!((a[0] - b[0]).abs() < 1e-3 && (a[1] - b[1]).abs() < 1e-3, "pose {}: {a:?} vs {b:?}", pose.id);
                compared += 1;
            }
        }
        assert!(compared > 500, "{compared} pixels compared in {}", camera.name);
    }
    // The fit's residuals in pixels, not in mm.
    assert!(found.contains("errors/pixels_px/calibrated") && !found.contains("errors/markers_mm/calibrated"));
    assert!(found.contains("errors/predicted_error_px") && !found.contains("errors/predicted_error_mm"), "{found:?}");
    // The default layout shows each camera's image.
    let origins = blueprint_views(&path);
    for camera in ["/world/camera/cam0", "/world/camera/cam1"] {
        assert!(origins.iter().any(|o| o == camera), "{camera} not in {origins:?}");
    }

    // `replay` with the calibrated parameters: measured and predicted pixels in each camera. Seen
    // through the refined rig (`--cameras`, the camchain `calibrate --cameras-out` writes), its
    // predictions (projected by the recording) are the fit's (measured less residual) to f32's
    // precision; through the file's rig they are pixels off.
    let params = dir.path().join("p.yaml");
    calibration.parameters.write(&params).unwrap();
    let refined = dir.path().join("cameras.yaml");
    std::fs::write(&refined, rig.to_camchain()).unwrap();
    let rms = |chunks: &[Chunk]| {
        let (mut sum, mut n) = (0.0, 0usize);
        for camera in ["cam0", "cam1"] {
            let measured = points2d(chunks, &format!("world/camera/{camera}/measured"));
            let predicted = points2d(chunks, &format!("world/camera/{camera}/predicted"));
            let total: usize = measured.values().map(Vec::len).sum();
            assert_eq!(total, rows.iter().filter(|((_, c), _)| c == camera).map(|(_, n)| n).sum::<usize>());
            assert_eq!(predicted.values().map(Vec::len).sum::<usize>(), total, "{camera}");
            for (pose, m) in &measured {
                for (a, b) in m.iter().zip(&predicted[pose]) {
                    sum += f64::from(a[0] - b[0]).powi(2) + f64::from(a[1] - b[1]).powi(2);
                    n += 1;
                }
            }
        }
        (sum / n as f64).sqrt()
    };
    let fitted = rms(&chunks);
    let replay = |name: &str, cameras: Option<&Path>| {
        let path = dir.path().join(name);
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_spmcal"));
        command.args(["replay", "--dataset", dataset.to_str().unwrap(), "--params", params.to_str().unwrap()]);
        command.args(["--rrd", path.to_str().unwrap()]);
        if let Some(c) = cameras {
            command.arg("--cameras").arg(c);
        }
        let out = command.output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        path
    };
    let replayed = replay("replay.rrd", Some(&refined));
    let through_refined = rms(&self::chunks(&replayed));
    assert!((through_refined - fitted).abs() < 1e-3 * fitted, "{through_refined} px vs the fit's {fitted} px");
    let through_file = rms(&self::chunks(&replay("replay_file_rig.rrd", None)));
    eprintln!(
        "pixel RMS: fit {fitted} px, replay through the refined rig {through_refined} px, through the file's {through_file} px"
    );
    assert!(through_file > 3.0 * fitted, "{through_file} px through the file's rig vs {fitted} px");
    if let Ok(v) = std::process::Command::new("rerun").arg("--version").output()
        && String::from_utf8_lossy(&v.stdout).contains("0.36")
    {
        for file in [&path, &replayed] {
            let verify = std::process::Command::new("rerun").args(["rrd", "verify"]).arg(file).output().unwrap();
            assert!(
                verify.status.success(),
                "rerun rrd verify {}: {}",
                file.display(),
                String::from_utf8_lossy(&verify.stderr)
            );
        }
    }
}
