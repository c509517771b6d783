//! The URDF model, its companion and parameters files: loading, validation, round trips, the
//! calibrated URDF export, and urdfdom's `check_urdf` on both URDFs (missing: a failure under
//! `CI=true`, elsewhere a visible skip).

use std::path::{Path, PathBuf};

#[path = "common/outside_tool.rs"]
mod outside_tool;

use nalgebra::{Rotation3, Vector3};
use spmcal::model::{Body, CameraRegistration, ModelError, ParameterSource, Parameters, RobotModel, Spm};

const URDF: &str = "models/agile_wrist.urdf";

fn assert_same_geometry(a: &Spm, b: &Spm, tol: f64) {
    for (ga, gb) in a.geometry().iter().zip(b.geometry()) {
        assert!(
            (ga.u - gb.u).amax() < tol && (ga.z - gb.z).amax() < tol && (ga.v0 - gb.v0).amax() < tol,
            "{ga:?} vs {gb:?}"
        );
        assert!(
            (ga.alpha1 - gb.alpha1).abs() < tol
                && (ga.alpha2 - gb.alpha2).abs() < tol
                && (ga.delta - gb.delta).abs() < tol
        );
    }
}

#[test]
fn shipped_urdf_is_the_nominal_agile_wrist() {
    let model = RobotModel::load(Path::new(URDF)).unwrap();
    // The URDF prints axes with 12 decimals.
    assert_same_geometry(&model.spm, &Spm::agile_wrist_nominal(), 1e-11);
    assert!(model.spm.home_joints().amax() < 1e-12, "home joints {:?}", model.spm.home_joints());
    let names: Vec<_> = model.markers.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["m1", "m2", "m3", "m4"]);
    for m in &model.markers[..3] {
        let p = m.position;
        assert!((p.xy().norm() - 0.075).abs() < 1e-9 && (p.z - 0.06).abs() < 1e-12);
    }
    assert_eq!(model.markers[3].position, Vector3::new(0.0, 0.0, 0.22));
    for body in [Body::Base, Body::Platform, Body::Proximal(0), Body::Proximal(2), Body::Distal(1)] {
        assert!(model.shapes.iter().any(|s| s.body == body), "{body:?} has no collision shape");
    }
}

/// The shipped model copied to a temporary folder with one edit applied to the URDF or companion.
fn edited_model(urdf_edit: (&str, &str), companion_edit: (&str, &str)) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let urdf = std::fs::read_to_string(URDF).unwrap();
    let companion = std::fs::read_to_string("models/agile_wrist.yaml").unwrap();
    assert!(urdf.contains(urdf_edit.0) && companion.contains(companion_edit.0), "edit does not apply");
    let path = dir.path().join("robot.urdf");
    std::fs::write(&path, urdf.replacen(urdf_edit.0, urdf_edit.1, 1)).unwrap();
    std::fs::write(dir.path().join("robot.yaml"), companion.replacen(companion_edit.0, companion_edit.1, 1)).unwrap();
    (dir, path)
}

fn load_error(urdf_edit: (&str, &str), companion_edit: (&str, &str)) -> (ModelError, String) {
    let (_dir, path) = edited_model(urdf_edit, companion_edit);
    let err = RobotModel::load(&path).expect_err("the edited model must be rejected");
    let text = err.to_string();
    assert!(text.contains("robot."), "error does not name the file: {text}");
    (err, text)
}

const NO_EDIT: (&str, &str) = ("legs", "legs");

#[test]
fn axis_that_misses_the_centre_is_rejected_with_the_distance() {
    // Shift elbow2's origin 10 mm along x: its axis z2 = (cos 120°, sin 120°, 0) then misses O
    // by 10 mm · sin 120° = 8.6603 mm.
    let marker = "<parent link=\"proximal2\"/><child link=\"distal2\"/>\n    <origin xyz=\"0 0 0\"";
    let shifted = "<parent link=\"proximal2\"/><child link=\"distal2\"/>\n    <origin xyz=\"0.01 0 0\"";
    let (err, text) = load_error((marker, shifted), NO_EDIT);
    assert!(matches!(err, ModelError::AxisMissesCentre { .. }), "{text}");
    assert!(text.contains("elbow2") && text.contains("8.6603 mm"), "{text}");
}

#[test]
fn zero_length_axis_is_rejected() {
    let urdf = std::fs::read_to_string(URDF).unwrap();
    let start = urdf.find("<joint name=\"theta1\"").unwrap();
    let axis_at = start + urdf[start..].find("<axis xyz=\"").unwrap() + "<axis xyz=\"".len();
    let axis_end = axis_at + urdf[axis_at..].find('"').unwrap();
    let old = format!("<axis xyz=\"{}\"", &urdf[axis_at..axis_end]);
    let (_, text) = load_error((&old, "<axis xyz=\"0 0 0\""), NO_EDIT);
    assert!(text.contains("theta1") && text.contains("zero-length"), "{text}");
}

#[test]
fn missing_joint_is_named() {
    let (_, text) = load_error(NO_EDIT, ("platform: wrist3", "platform: wrist9"));
    assert!(text.contains("wrist9") && text.contains("missing"), "{text}");
}

#[test]
fn closure_link_off_the_platform_has_no_solution_at_home() {
    let marker = "<child link=\"platform_closure3\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\"";
    let rotated = "<child link=\"platform_closure3\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0.05\"";
    let (err, text) = load_error((marker, rotated), NO_EDIT);
    assert!(matches!(err, ModelError::Closure { leg: 2, .. }), "{text}");
    assert!(text.contains("2.8648°"), "{text}");
}

#[test]
fn companion_typo_is_an_error_with_its_line() {
    let (_, text) = load_error(NO_EDIT, ("\nmarkers_m:", "\nmarker_m:"));
    assert!(text.contains("robot.yaml:") && text.contains("marker_m"), "{text}");
}

#[test]
fn encoder_offsets_in_the_companion_are_read_and_a_bad_one_is_located() {
    // Offsets shift every reading: the model with offsets δ at readings θ is the plain one at θ + δ.
    let (_dir, path) = edited_model(NO_EDIT, ("\nmarkers_m:", "\nencoder_offsets_deg: [1.5, -2.0, 0.25]\nmarkers_m:"));
    let shifted = RobotModel::load(&path).unwrap();
    let plain = RobotModel::load(Path::new(URDF)).unwrap();
    let joints = Vector3::new(0.1, -0.2, 0.05);
    let offsets = Vector3::new(1.5f64, -2.0, 0.25).map(f64::to_radians);
    let (a, b) = (shifted.spm.forward(&joints).unwrap(), plain.spm.forward(&(joints + offsets)).unwrap());
    assert!(spmcal::math::so3::geodesic_angle(&a, &b) < 1e-12);
    let (_, text) = load_error(NO_EDIT, ("\nmarkers_m:", "\nencoder_offsets_deg: [1.5, .nan, 0.25]\nmarkers_m:"));
    assert!(text.contains("robot.yaml:") && text.contains("encoder_offsets_deg") && text.contains("finite"), "{text}");
}

#[test]
fn urdf_passes_the_ros_checker_when_installed() {
    let Ok(out) = std::process::Command::new("check_urdf").arg(URDF).output() else {
        return outside_tool::missing("check_urdf", "Debian: apt-get install liburdfdom-tools");
    };
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("Successfully Parsed"), "{text}");
    assert!(text.contains("platform_closure3") && text.contains("root Link: base_link"));
}

#[test]
fn parameters_file_round_trip() {
    let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(7);
    let spread = spmcal::model::GeometrySpread { axis_tilt: 0.02, link_angle: 0.01, joint_offset: 0.05 };
    let spm = Spm::new(spread.perturb(Spm::agile_wrist_nominal().geometry(), &mut rng)).unwrap();
    let mut params = Parameters::nominal(&spm, Some(URDF.into()));
    params.source = ParameterSource::Calibrated;
    params.camera = Some(CameraRegistration {
        rotation: Rotation3::from_euler_angles(3.1, 0.02, -0.4),
        translation: Vector3::new(0.01, -0.02, 0.81),
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("params.yaml");
    params.write(&path).unwrap();
    let back = Parameters::read(&path).unwrap();
    assert_eq!(back.source, ParameterSource::Calibrated);
    // The shipped model's file is recorded by its name (its content is the compiled-in model's),
    // with its identity.
    assert_eq!(back.model.as_deref(), Some("agile_wrist"));
    // Degrees in the file: radians → degrees → radians costs an ulp or two.
    assert_same_geometry(&back.spm().unwrap(), &spm, 1e-14);
    let (c, b) = (params.camera.unwrap(), back.camera.unwrap());
    assert!(
        spmcal::math::so3::geodesic_angle(&c.rotation, &b.rotation) < 1e-14
            && (c.translation - b.translation).amax() == 0.0
    );
}

#[test]
fn parameters_file_errors_name_file_line_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("params.yaml");
    Parameters::nominal(&Spm::agile_wrist_nominal(), None).write(&path).unwrap();
    let good = std::fs::read_to_string(&path).unwrap();
    let cases = [
        ("alpha1_deg:", "alpha_1_deg:", "unknown field `alpha_1_deg`"),
        ("delta_deg: 0.0", "delta_deg: .nan", "leg 1: delta is not finite"),
        ("- 1.0\n", "- 1.5\n", "has length"),
        ("source: nominal", "source: guessed", "unknown variant `guessed`"),
    ];
    for (from, to, expected) in cases {
        assert!(good.contains(from), "{from} not in {good}");
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        let text = Parameters::read(&path).unwrap_err().to_string();
        assert!(text.contains("params.yaml") && text.contains(expected), "{from} → {to}: {text}");
    }
    std::fs::write(&path, good.replacen("alpha1_deg:", "alpha_1_deg:", 1)).unwrap();
    let err = Parameters::read(&path).unwrap_err();
    assert!(err.line.is_some(), "a YAML typo must carry its line: {err}");
}

#[test]
fn an_exported_urdf_gives_the_parameters_files_forward_kinematics_and_check_urdf_accepts_it() {
    use rand::{Rng, SeedableRng};
    // A calibrated-like parameter set: the true geometry of a simulated session (axes tilted,
    // link angles and encoder offsets off nominal) with its misplaced markers.
    let params =
        spmcal::model::Parameters::read(std::path::Path::new("datasets/agile_wrist_sim_400/truth.yaml")).unwrap();
    let model = spmcal::model::RobotModel::load(std::path::Path::new("models/agile_wrist.urdf")).unwrap();
    let provenance = vec!["test export -- with a double dash".to_string(), "and\na newline".to_string()];
    let exported = spmcal::model::export(&model, &params, &provenance).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("calibrated.urdf");
    std::fs::write(&urdf, &exported.urdf).unwrap();
    std::fs::write(spmcal::model::RobotModel::companion_path(&urdf), &exported.companion).unwrap();
    let loaded = spmcal::model::RobotModel::load(&urdf).unwrap();
    assert_eq!(
        loaded.markers.iter().map(|m| m.position).collect::<Vec<_>>(),
        params.markers.iter().map(|m| m.position).collect::<Vec<_>>()
    );
    // The same FDA, from the same encoder readings, on 1,000 poses of the workspace.
    let from_params = params.spm().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let mut worst: f64 = 0.0;
    let mut tested = 0;
    while tested < 1000 {
        let omega = nalgebra::Vector3::new(
            rng.random_range(-0.45..0.45),
            rng.random_range(-0.45..0.45),
            rng.random_range(-0.5..0.5),
        );
        let Ok(joints) = from_params.ik(&spmcal::math::so3::exp(&omega)) else { continue };
        let (Ok(a), Ok(b)) = (from_params.forward(&joints), loaded.spm.forward(&joints)) else { continue };
        worst = worst.max(spmcal::math::so3::geodesic_angle(&a, &b));
        tested += 1;
    }
    assert!(worst < 1e-12, "{worst:e} rad");
    // The offsets are what the URDF's joints are ahead of the readings; home is all zeros there.
    let home = from_params.ik(&nalgebra::Rotation3::identity()).unwrap();
    assert!(exported.companion.contains("encoder_offsets_deg: ["), "{}", exported.companion);
    assert!(home.iter().any(|t| t.abs() > 1e-3), "the truth's home readings are not zero: {home:?}");
    // urdfdom's parser (an independent one) accepts it, where installed.
    match std::process::Command::new("check_urdf").arg(&urdf).output() {
        Ok(out) => assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stdout)),
        Err(_) => outside_tool::missing("check_urdf", "Debian: apt-get install liburdfdom-tools"),
    }
}

/// A parameter set with joint scales off by a few tenths of a percent (a transmission's error):
/// the true geometry of a simulated session with scales `+0.4 / −0.3 / +0.2 %`.
fn scaled_truth() -> Parameters {
    let mut params = Parameters::read(Path::new("datasets/agile_wrist_sim_400/truth.yaml")).unwrap();
    for (g, s) in params.legs.iter_mut().zip([1.004, 0.997, 1.002]) {
        g.scale = s;
    }
    params
}

#[test]
fn joint_scales_are_written_only_when_not_1_and_a_file_without_them_reads_as_1() {
    let params = scaled_truth();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("params.yaml");
    params.write(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.matches("  scale: ").count(), 3, "{text}");
    let back = Parameters::read(&path).unwrap();
    assert_eq!(back.legs.map(|g| g.scale), [1.004, 0.997, 1.002]);
    // A scale of 1 is not written: the file reads as one written before scales existed.
    let mut one = params.clone();
    one.legs[1].scale = 1.0;
    one.write(&path).unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap().matches("  scale: ").count(), 2);
    // A file written before scales existed (the shipped truth, from before them) loads with 1.
    let old = std::fs::read_to_string("datasets/agile_wrist_sim_400/truth.yaml").unwrap();
    assert!(!old.contains("scale:"), "the shipped file predates the scales");
    assert_eq!(
        Parameters::read(Path::new("datasets/agile_wrist_sim_400/truth.yaml")).unwrap().legs.map(|g| g.scale),
        [1.0; 3]
    );
    // A scale out of range is located at its line and key.
    let bad = text.replacen("scale: 0.997", "scale: 3.0", 1);
    std::fs::write(&path, &bad).unwrap();
    let err = Parameters::read(&path).unwrap_err();
    let line = bad.lines().position(|l| l.contains("scale: 3.0")).unwrap() + 1;
    assert_eq!(err.line, Some(line), "{err}");
    assert!(err.to_string().contains("leg 2: scale = 3") && err.to_string().contains("ratio"), "{err}");
}

#[test]
fn with_joint_scales_ik_returns_readings_that_the_fda_maps_back_and_a_scale_turns_the_joint_further() {
    let params = scaled_truth();
    let scaled = params.spm().unwrap();
    let mut unscaled_legs = params.legs;
    unscaled_legs.iter_mut().for_each(|g| g.scale = 1.0);
    let unscaled = Spm::new(unscaled_legs).unwrap();
    let r = spmcal::math::so3::exp(&Vector3::new(0.3, -0.2, 0.25));
    let (theta_s, theta_1) = (scaled.ik(&r).unwrap(), unscaled.ik(&r).unwrap());
    for i in 0..3 {
        // φ = sθ + δ is the same joint angle: the reading is the unscaled one over s (about home's
        // own offset: both share δ).
        let s = params.legs[i].scale;
        let delta = params.legs[i].delta;
        assert!(((s * theta_s[i] + delta) - (theta_1[i] + delta)).abs() < 1e-12, "leg {i}");
    }
    for mechanism in [&scaled, &unscaled] {
        let joints = mechanism.ik(&r).unwrap();
        assert!(spmcal::math::so3::geodesic_angle(&mechanism.forward(&joints).unwrap(), &r) < 1e-12);
        // Tracking from a pose a degree away (the haptic loop's previous orientation).
        let previous = spmcal::math::so3::exp(&Vector3::new(0.01, 0.01, -0.01)) * r;
        assert!(spmcal::math::so3::geodesic_angle(&mechanism.track(&joints, &previous).unwrap(), &r) < 1e-12);
    }
    // The same readings put the scaled mechanism elsewhere, by about the scale error times the turn.
    let off = spmcal::math::so3::geodesic_angle(&scaled.forward(&theta_1).unwrap(), &r);
    assert!(off > 1e-4, "{off}");
    // The velocity relation carries the scale: J = A⁻¹B maps reading rates to the angular velocity
    // (central differences of the FDA).
    let j = scaled.jacobians(&theta_s, &r).forward().unwrap();
    let h = 1e-6;
    for k in 0..3 {
        let mut step = nalgebra::Vector3::zeros();
        step[k] = h;
        let (plus, minus) = (scaled.forward(&(theta_s + step)).unwrap(), scaled.forward(&(theta_s - step)).unwrap());
        let omega = spmcal::math::so3::log(&(plus * minus.inverse())) / (2.0 * h);
        assert!((omega - j.column(k)).amax() < 1e-6, "column {k}: {omega} vs {}", j.column(k));
    }
}

#[test]
fn an_exported_urdf_with_joint_scales_gives_the_parameters_files_forward_kinematics() {
    use rand::{Rng, SeedableRng};
    let params = scaled_truth();
    let model = RobotModel::load(Path::new(URDF)).unwrap();
    let exported = spmcal::model::export(&model, &params, &[]).unwrap();
    assert!(exported.companion.contains("encoder_scales: [1.004, 0.997, 1.002]"), "{}", exported.companion);
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("calibrated.urdf");
    exported.write(&urdf).unwrap();
    let loaded = RobotModel::load(&urdf).unwrap();
    let from_params = params.spm().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    let (mut worst, mut tested): (f64, usize) = (0.0, 0);
    while tested < 1000 {
        let omega =
            Vector3::new(rng.random_range(-0.45..0.45), rng.random_range(-0.45..0.45), rng.random_range(-0.5..0.5));
        let Ok(joints) = from_params.ik(&spmcal::math::so3::exp(&omega)) else { continue };
        let (Ok(a), Ok(b)) = (from_params.forward(&joints), loaded.spm.forward(&joints)) else { continue };
        worst = worst.max(spmcal::math::so3::geodesic_angle(&a, &b));
        tested += 1;
    }
    assert!(worst < 1e-12, "{worst:e} rad");
    // IK of the loaded model returns the same encoder readings.
    let r = spmcal::math::so3::exp(&Vector3::new(0.2, 0.1, -0.3));
    assert!((loaded.spm.ik(&r).unwrap() - from_params.ik(&r).unwrap()).amax() < 1e-12);
    // A companion's bad scale is located at its line.
    let companion = RobotModel::companion_path(&urdf);
    let text =
        std::fs::read_to_string(&companion).unwrap().replace("encoder_scales: [1.004,", "encoder_scales: [-1.0,");
    std::fs::write(&companion, &text).unwrap();
    let err = RobotModel::load(&urdf).unwrap_err().to_string();
    assert!(err.contains("encoder scale of leg 1") && err.contains("calibrated.yaml:"), "{err}");
}
