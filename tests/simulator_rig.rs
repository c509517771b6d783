//! The simulator's stereo rig (issue 34): the pixels are the true rig's images of the true
//! markers within the configured noise (projected here once more, from the config's words alone),
//! the rig's file differs from the truth by exactly the configured miscalibration, the points the
//! file triangulates are wrong as the geometry of that miscalibration says, one camera gives
//! pixels and no points, and a config without a rig makes what it made before.

use std::path::Path;

use nalgebra::{Rotation3, Vector2, Vector3};
use spmcal::dataset::Session;
use spmcal::model::{Rig, RobotModel};
use spmcal::sim::{RigSettings, SimConfig, SimSummary};

/// The bands of a χ² and a binomial count.
#[path = "common/z_scores.rs"]
#[allow(dead_code)] // shared by the tests, each using part of it
mod z_scores;

fn stereo() -> SimConfig {
    SimConfig::read(Path::new("configs/simulate_agile_wrist_stereo.yaml")).unwrap()
}

fn simulate(config: &SimConfig) -> (Session, SimSummary) {
    let model = RobotModel::load(&config.model).unwrap();
    config.simulate(&model, &mut |_| {}).unwrap()
}

fn rig_settings(config: &SimConfig) -> &RigSettings {
    config.camera.rig.as_ref().unwrap()
}

/// The true marker positions in C (cam0's frame), per pose and marker.
fn true_points(session: &Session) -> Vec<Vec<Vector3<f64>>> {
    let truth = session.truth.as_ref().unwrap();
    let camera = truth.parameters.camera.unwrap();
    session
        .poses
        .iter()
        .map(|p| {
            let r = truth.orientations[&p.id];
            truth.parameters.markers.iter().map(|m| camera.to_camera(&(r * m.position))).collect()
        })
        .collect()
}

/// Camera `c`'s pixel of `y` (cam0's frame), written once more from the config's words and
/// docs/conventions.md's projection, sharing nothing with the library's rig: each camera's centre
/// `baseline_m` along the previous one's x axis, turned by `toe_in_deg` about its y axis towards
/// it and then by `rotation_deg`; `x = X/Z`, radtan distortion, `u = fu x_d + pu`.
fn expected_pixel(settings: &RigSettings, c: usize, y: &Vector3<f64>) -> Vector2<f64> {
    let mut z = *y;
    for camera in &settings.cameras[1..=c] {
        let toe = Rotation3::from_axis_angle(&Vector3::y_axis(), camera.toe_in_deg.to_radians());
        let turn = Rotation3::new(Vector3::from(camera.rotation_deg) * std::f64::consts::PI / 180.0);
        z = turn * toe * (z - Vector3::new(camera.baseline_m, 0.0, 0.0));
    }
    let camera = &settings.cameras[c];
    assert_eq!(camera.distortion_model, "radtan");
    let [k1, k2, r1, r2] = camera.distortion_coeffs;
    let (x, y) = (z.x / z.z, z.y / z.z);
    let rr = x * x + y * y;
    let radial = 1.0 + k1 * rr + k2 * rr * rr;
    let xd = x * radial + 2.0 * r1 * x * y + r2 * (rr + 2.0 * x * x);
    let yd = y * radial + r1 * (rr + 2.0 * y * y) + 2.0 * r2 * x * y;
    let [fu, fv, pu, pv] = camera.intrinsics;
    Vector2::new(fu * xd + pu, fv * yd + pv)
}

#[test]
fn the_pixels_are_the_true_rigs_images_of_the_true_markers_within_the_noise() {
    let config = stereo();
    let settings = rig_settings(&config);
    let sigma = settings.pixel_sigma_px;
    let (session, summary) = simulate(&config);
    let truth = true_points(&session);
    let (mut square, mut sum, mut count) = (0.0, Vector2::zeros(), 0usize);
    for (pose, points) in session.poses.iter().zip(&truth) {
        for seen in &pose.pixels {
            let [w, h] = settings.cameras[seen.camera].resolution.map(|r| f64::from(r) - 0.5);
            assert!((-0.5..=w).contains(&seen.pixel.x) && (-0.5..=h).contains(&seen.pixel.y), "{seen:?}");
            let z = (seen.pixel - expected_pixel(settings, seen.camera, &points[seen.marker])) / sigma;
            square += z.norm_squared();
            sum += z;
            count += 1;
        }
    }
    assert_eq!(count, summary.pixels_seen);
    // Both cameras see every marker the mechanism leaves in their sight (the images are far wider
    // than the wrist at 0.8 m): 200 poses × 4 markers × 2 cameras, less the hidden ones.
    assert_eq!(summary.pixels_outside_image, 0);
    assert_eq!(count + summary.markers_occluded, 200 * 4 * 2);
    // 2n independent N(0, 1) coordinates: their mean square inside the χ² band that holds it with
    // probability 99.9%, each coordinate's mean within 3.29 standard errors of 0.
    let n = 2.0 * count as f64;
    let (lo, hi) = z_scores::mean_square_band(n);
    let rms = (square / n).sqrt();
    println!(
        "{count} pixels: whitened RMS {rms:.4} (band {:.4}–{:.4}), mean {:?}",
        lo.sqrt(),
        hi.sqrt(),
        sum / count as f64
    );
    assert!((lo.sqrt()..=hi.sqrt()).contains(&rms), "whitened RMS {rms}");
    assert!((sum / count as f64).amax() < 3.29 / (count as f64).sqrt());
}

#[test]
fn a_turned_camera_is_where_its_settings_put_it() {
    // cam1 toed in 6° and turned further; a third camera beyond it: noise-free pixels agree with
    // the projection written from the settings' words to rounding.
    let mut config = stereo();
    config.poses = 20;
    let rig = config.camera.rig.as_mut().unwrap();
    rig.pixel_sigma_px = 0.0;
    rig.cameras[1].toe_in_deg = 6.0;
    rig.cameras[1].rotation_deg = [0.5, -0.3, 1.0];
    let mut third = rig.cameras[1].clone();
    third.baseline_m = 0.05;
    third.toe_in_deg = 3.0;
    third.rotation_deg = [0.0; 3];
    rig.cameras.push(third);
    config.check().unwrap();
    let settings = rig_settings(&config).clone();
    let (session, _) = simulate(&config);
    let truth = true_points(&session);
    let mut cameras = [0; 3];
    for (pose, points) in session.poses.iter().zip(&truth) {
        for seen in &pose.pixels {
            let expected = expected_pixel(&settings, seen.camera, &points[seen.marker]);
            assert!((seen.pixel - expected).amax() < 1e-9, "{seen:?} against {expected}");
            cameras[seen.camera] += 1;
        }
    }
    assert!(cameras.iter().all(|&n| n > 40), "{cameras:?}");
    // Toe-in turns cam1's optical axis towards cam0 (−x in cam0's frame), by 6° and the turn.
    let rig = &session.truth.as_ref().unwrap().rig.as_ref().unwrap();
    let axis = rig.from_cam0(1).inverse().rotation * Vector3::z();
    assert!(axis.x < -0.09, "{axis}");
}

#[test]
fn outlier_pixels_are_drawn_as_often_as_configured() {
    let mut config = stereo();
    config.camera.outlier_probability = 0.05;
    let (session, summary) = simulate(&config);
    let seen: usize = session.poses.iter().map(|p| p.pixels.len()).sum();
    let (lo, hi) = z_scores::binomial_band(seen, 0.05);
    println!("{} outliers of {seen} pixels (band {lo}–{hi})", summary.outliers);
    assert!((lo..=hi).contains(&summary.outliers));
}

/// The angle (rad) and axis of `b`'s rotation relative to `a` (`b aᵀ`).
fn turn(a: &Rig, b: &Rig, c: usize) -> Vector3<f64> {
    let (ra, rb) = (a.cameras[c].from_previous.rotation, b.cameras[c].from_previous.rotation);
    (rb * ra.inverse()).scaled_axis()
}

/// `session` written into a new folder and read back (a recording at latency 0, which may leave
/// out its last frame, stamped after the last encoder sample).
fn round_trip(session: &Session) -> (tempfile::TempDir, Session) {
    let dir = tempfile::tempdir().unwrap();
    session.write(dir.path()).unwrap();
    let (loaded, warnings) = Session::load(dir.path(), None).unwrap();
    assert!(warnings.iter().all(|w| w.message.contains("falls outside the encoder stream")), "{warnings:?}");
    (dir, loaded)
}

#[test]
fn the_files_read_back_as_simulated_and_differ_from_the_truth_by_exactly_the_miscalibration() {
    let config = stereo();
    let settings = rig_settings(&config);
    let m = &settings.miscalibration;
    let (session, _) = simulate(&config);
    let (dir, loaded) = round_trip(&session);
    for file in ["pixels.csv", "cameras.yaml", "truth_cameras.yaml", "truth.yaml", "joints.csv"] {
        assert!(dir.path().join(file).exists(), "{file}");
    }
    assert!(!dir.path().join("markers.csv").exists());
    // Pixels, the rig, the points it triangulates and the true rig: as simulated, bit for bit.
    assert_eq!(held(&loaded), held(&session));
    assert_eq!(loaded.rig, session.rig);
    let truth = session.truth.as_ref().unwrap().rig.as_ref().unwrap();
    assert_eq!(loaded.truth.as_ref().unwrap().rig.as_ref(), Some(truth));
    // The file (as read) against the truth (as read): exactly the configured errors.
    let file = loaded.rig.as_deref().unwrap();
    let truth = loaded.truth.as_ref().unwrap().rig.as_ref().unwrap();
    assert_eq!(file.cameras.len(), 2);
    for (c, (f, t)) in file.cameras.iter().zip(&truth.cameras).enumerate() {
        assert_eq!(t.lens.intrinsics, settings.cameras[c].intrinsics);
        assert_eq!(t.lens.distortion, settings.cameras[c].distortion_coeffs);
        let [fu, fv, pu, pv] = t.lens.intrinsics;
        let [gu, gv, qu, qv] = f.lens.intrinsics;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
        assert!(close(gu / fu, m.focal_scale[c][0]) && close(gv / fv, m.focal_scale[c][1]), "camera {c}");
        assert!(close(qu - pu, m.principal_point_px[c][0]) && close(qv - pv, m.principal_point_px[c][1]));
        assert_eq!(f.lens.distortion, [0.0; 4]);
        assert_eq!((f.lens.resolution, f.lens.distortion_model), (t.lens.resolution, t.lens.distortion_model));
    }
    assert!((file.baseline_m() / truth.baseline_m() - m.baseline_scale).abs() < 1e-12);
    assert!((truth.baseline_m() - 0.12).abs() < 1e-12);
    let error = Vector3::from(m.rotation_deg).map(f64::to_radians);
    assert!((turn(truth, file, 1) - error).amax() < 1e-12, "{}", turn(truth, file, 1));
    // The file's cam1 is turned about its own centre: the centres differ by the baseline's scale.
    let centre = |rig: &Rig| rig.from_cam0(1).inverse().translation.vector;
    assert!((centre(file) - centre(truth) * m.baseline_scale).amax() < 1e-12);
    // A session of points written over it leaves no pixels, rig or true rig behind.
    let mut points = stereo();
    (points.camera.rig, points.poses) = (None, 10);
    simulate(&points).0.write(dir.path()).unwrap();
    for file in ["pixels.csv", "cameras.yaml", "truth_cameras.yaml"] {
        assert!(!dir.path().join(file).exists(), "{file} left behind");
    }
    assert!(Session::load(dir.path(), None).unwrap().0.truth.unwrap().rig.is_none());
}

/// The point the file's rig triangulates from `y`'s noise-free pixels, to first order in its
/// errors, from the geometry of a parallel rig (cam1 `b` along cam0's x, neither turned): each
/// camera's normalised coordinates as the file reads the true pixels (its own intrinsics, no
/// distortion), cam1's ray turned by the file's rotation error; the depth from the disparity over
/// the file's baseline, x along cam0's ray, y halfway between the two rays.
fn predicted_point(settings: &RigSettings, y: &Vector3<f64>) -> Vector3<f64> {
    let m = &settings.miscalibration;
    let read = |c: usize| {
        let pixel = expected_pixel(settings, c, y);
        let [fu, fv, pu, pv] = settings.cameras[c].intrinsics;
        let ([su, sv], [du, dv]) = (m.focal_scale[c], m.principal_point_px[c]);
        Vector2::new((pixel.x - pu - du) / (fu * su), (pixel.y - pv - dv) / (fv * sv))
    };
    let (p0, p1) = (read(0), read(1));
    let d = Vector3::from(m.rotation_deg).map(f64::to_radians);
    // cam1's ray in cam0's frame: R_fileᵀ (x, y, 1) = v − d × v for a small turn d.
    let v = Vector3::new(p1.x, p1.y, 1.0);
    let ray = v - d.cross(&v);
    let (x1, y1) = (ray.x / ray.z, ray.y / ray.z);
    let depth = m.baseline_scale * settings.cameras[1].baseline_m / (p0.x - x1);
    Vector3::new(p0.x * depth, 0.5 * (p0.y + y1) * depth, depth)
}

#[test]
fn the_files_points_are_wrong_as_the_geometry_of_its_miscalibration_says() {
    let mut config = stereo();
    config.camera.rig.as_mut().unwrap().pixel_sigma_px = 0.0;
    let settings = rig_settings(&config).clone();
    let (session, _) = simulate(&config);
    let truth = true_points(&session);
    // Per marker: the errors' mean along the line of sight from cam0, RMS across it, the true
    // distance; and over all, the RMS of the measured error less the geometry's prediction.
    let (mut along, mut across, mut distance, mut count) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
    let (mut miss, mut size, mut predicted_along) = (0.0, 0.0, 0.0);
    for (pose, points) in session.poses.iter().zip(&truth) {
        for (k, (seen, y)) in pose.markers.iter().zip(points).enumerate() {
            let Some(p) = seen else { continue };
            let (e, sight) = (p - y, y.normalize());
            along[k] += e.dot(&sight);
            across[k] += (e - sight * e.dot(&sight)).norm_squared();
            distance[k] += y.norm();
            count[k] += 1.0;
            let predicted = predicted_point(&settings, y) - y;
            predicted_along += predicted.dot(&sight);
            miss += (e - predicted).norm_squared();
            size += e.norm_squared();
        }
    }
    let n: f64 = count.iter().sum();
    let measured_along = along.iter().sum::<f64>() / n;
    let across_rms = (across.iter().sum::<f64>() / n).sqrt();
    let mean_distance = distance.iter().sum::<f64>() / n;
    let (miss, size) = ((miss / n).sqrt(), (size / n).sqrt());
    println!(
        "{n} points {mean_distance:.3} m from cam0: {:.2} mm deep (first order {:.2} mm), {:.2} mm across (RMS); the first-order prediction misses by {:.3} mm RMS of {:.2} mm",
        measured_along * 1e3,
        predicted_along / n * 1e3,
        across_rms * 1e3,
        miss * 1e3,
        size * 1e3
    );
    for k in 0..4 {
        println!(
            "  marker {}: {:.3} m, {:.2} mm deep, {:.2} mm across",
            k + 1,
            distance[k] / count[k],
            along[k] / count[k] * 1e3,
            (across[k] / count[k]).sqrt() * 1e3
        );
    }
    // The errors are the miscalibration's, point by point: what the first-order geometry leaves
    // out is second order in relative errors of ~3% (the disparity's), a few per cent of the
    // error, and the least-squares point differs from the parallel-rig construction by as little.
    assert!(miss < 0.005 * size, "the geometry predicts the errors to {miss} m of {size} m");
    // The figures: about 22 mm deep and 1.6–1.9 mm across at the working distance
    // (~0.7 m), the depth error growing with the distance — as the square of it, the disparity's
    // error being a constant angle — so the column's top marker (m4, 0.16 m nearer) errs by
    // (d4 / d1)² as much as the platform's.
    assert!((0.020..=0.025).contains(&measured_along), "{measured_along}");
    assert!((0.0015..=0.0020).contains(&across_rms), "{across_rms}");
    let ratio = (along[3] / count[3]) / (along[0] / count[0]);
    let geometry = (distance[3] / count[3] / (distance[0] / count[0])).powi(2);
    assert!((ratio / geometry - 1.0).abs() < 0.1, "m4/m1 depth errors {ratio}, distances² {geometry}");
}

/// The stereo config's 30 first poses through its cam0 alone.
fn one_camera() -> SimConfig {
    let mut config = stereo();
    config.poses = 30;
    let rig = config.camera.rig.as_mut().unwrap();
    rig.cameras.truncate(1);
    rig.miscalibration.focal_scale.truncate(1);
    rig.miscalibration.principal_point_px.truncate(1);
    rig.miscalibration.rotation_deg = [0.0; 3];
    config.check().unwrap();
    config
}

#[test]
fn a_one_camera_rig_gives_pixels_and_no_points() {
    let (session, summary) = simulate(&one_camera());
    assert_eq!(session.rig.as_ref().unwrap().cameras.len(), 1);
    assert!(session.poses.iter().all(|p| p.seen() == 0 && !p.pixels.is_empty()));
    assert!(session.poses.iter().flat_map(|p| &p.pixels).all(|p| p.camera == 0));
    assert_eq!(summary.markers_seen, 0);
    assert_eq!(summary.pixels_seen, session.poses.iter().map(|p| p.pixels.len()).sum::<usize>());
}

#[test]
fn a_pixel_outside_its_image_is_lost() {
    // One camera with a 160 × 160 image, ±0.09 rad: the platform's markers (0.075 m out, 0.74 m
    // away) fall near its edge and often outside; every pixel kept lies inside.
    let mut config = one_camera();
    let camera = &mut config.camera.rig.as_mut().unwrap().cameras[0];
    camera.resolution = [160, 160];
    camera.intrinsics[2] = 79.5;
    camera.intrinsics[3] = 79.5;
    let (session, summary) = simulate(&config);
    assert!(summary.pixels_outside_image > 30, "{summary:?}");
    for seen in session.poses.iter().flat_map(|p| &p.pixels) {
        assert!(seen.pixel.iter().all(|x| (-0.5..=159.5).contains(x)), "{seen:?}");
    }
    assert_eq!(summary.pixels_seen + summary.pixels_outside_image + summary.markers_occluded, 30 * 4);
}

/// The shipped ten-minute recording's config, cut to `seconds`.
fn free_motion(seconds: f64) -> SimConfig {
    let mut config = SimConfig::read(Path::new("configs/simulate_agile_wrist_stereo_free_motion.yaml")).unwrap();
    config.recording.as_mut().unwrap().duration_s = seconds;
    config
}

/// A pose's id, joints, time, pixels and points: what its files hold (not their lines).
type Held = (u64, Vector3<f64>, Option<f64>, Vec<(usize, usize, Vector2<f64>)>, Vec<Option<Vector3<f64>>>);

fn held(session: &Session) -> Vec<Held> {
    let pixels = |p: &spmcal::dataset::SessionPose| p.pixels.iter().map(|x| (x.marker, x.camera, x.pixel)).collect();
    session.poses.iter().map(|p| (p.id, p.joints, p.time_s, pixels(p), p.markers.clone())).collect()
}

#[test]
fn a_recording_through_the_rig_carries_each_frames_pixels_at_its_time() {
    let config = free_motion(40.0);
    let r = config.recording.clone().unwrap();
    let (session, summary) = simulate(&config);
    let rig = session.rig.as_deref().unwrap();
    // A frame whose marker both cameras lost has no pixels, and no pose.
    let frames = (40.0 * r.camera_rate_hz) as usize;
    assert!((frames - 20..=frames).contains(&session.poses.len()), "{} poses", session.poses.len());
    let mut stereo_frames = 0;
    let mut last = None;
    for pose in &session.poses {
        // Frame f is taken at (f + ½) / 15 s and stamped late by the latency, with 1 ms of
        // jitter: its pose's time within 5 jitters of that, each frame once.
        let stamp = pose.time_s.unwrap() - r.latency_s;
        let f = (stamp * r.camera_rate_hz - 0.5).round() as usize;
        assert!((stamp - (f as f64 + 0.5) / r.camera_rate_hz).abs() < 5.0 * r.jitter_s, "frame {f}");
        assert!(last.is_none_or(|l| f > l), "frame {f} after {last:?}");
        last = Some(f);
        // One marker a frame, round robin, its point the file's rig's triangulation of its pixels.
        assert!(pose.pixels.iter().all(|p| p.marker == f % 4), "frame {f}: {:?}", pose.pixels);
        let rays: Vec<_> = pose.pixels.iter().map(|p| (p.camera, p.pixel)).collect();
        if rays.len() == 2 {
            stereo_frames += 1;
            assert_eq!(pose.markers[f % 4], rig.triangulate(&rays), "frame {f}");
        } else {
            assert!(pose.markers.iter().all(Option::is_none));
        }
    }
    assert_eq!(summary.pixels_seen, session.poses.iter().map(|p| p.pixels.len()).sum::<usize>());
    assert_eq!(summary.markers_seen, stereo_frames);
    assert!(stereo_frames > 550, "{stereo_frames} of 600 frames seen by both cameras");
    // Written (pixels.csv with each frame's time) and read back: the same frames at any latency.
    let (_dir, loaded) = round_trip(&session);
    assert_eq!(held(&loaded.at_latency(r.latency_s).0), held(&session));
    assert_eq!(loaded.truth.as_ref().unwrap().rig, session.truth.as_ref().unwrap().rig);
}

#[test]
fn a_recording_through_one_camera_gives_pixels_and_no_points() {
    let mut config = one_camera();
    config.recording = free_motion(20.0).recording;
    let (session, summary) = simulate(&config);
    assert_eq!(summary.markers_seen, 0);
    assert!(session.poses.iter().all(|p| p.seen() == 0));
    assert!(session.poses.iter().filter(|p| !p.pixels.is_empty()).count() > 250);
    let (_dir, loaded) = round_trip(&session);
    assert_eq!(held(&loaded.at_latency(0.04).0), held(&session));
}

#[test]
fn a_config_without_a_rig_makes_what_it_made_before() {
    // The shipped sequential session, from its committed config: byte for byte.
    let config = SimConfig::read(Path::new("configs/simulate_agile_wrist_sequential.yaml")).unwrap();
    assert!(config.camera.rig.is_none());
    let (session, summary) = simulate(&config);
    assert!(session.rig.is_none() && session.truth.as_ref().unwrap().rig.is_none());
    assert!(session.poses.iter().all(|p| p.pixels.is_empty()));
    assert_eq!(summary.pixels_seen, 0);
    let dir = tempfile::tempdir().unwrap();
    session.write(dir.path()).unwrap();
    for file in ["joints.csv", "markers.csv", "truth.yaml", "truth_orientations.csv"] {
        let made = std::fs::read(dir.path().join(file)).unwrap();
        let shipped = std::fs::read(Path::new("datasets/agile_wrist_sequential_200").join(file)).unwrap();
        assert!(made == shipped, "{file} differs from the shipped dataset");
    }
    // The summary a person reads of a session of points says nothing of pixels.
    assert!(!summary.to_string().contains("pixel"));
    // And the shipped free-motion recording from its own.
    let config = SimConfig::read(Path::new("configs/simulate_agile_wrist_free_motion.yaml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    simulate(&config).0.write(dir.path()).unwrap();
    for file in ["encoders.csv", "captures.csv", "truth.yaml"] {
        let made = std::fs::read(dir.path().join(file)).unwrap();
        let shipped = std::fs::read(Path::new("datasets/agile_wrist_free_motion_120s").join(file)).unwrap();
        assert!(made == shipped, "{file} differs from the shipped recording");
    }
}

#[test]
fn bad_rig_settings_are_refused_naming_their_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("    cameras: []", "camera.rig.cameras", "from 1 to"),
        ("    cameras:\n      - {}\n      - {baseline_m: 0.0}", "camera.rig.cameras[1].baseline_m", "(0, 10]"),
        ("    cameras:\n      - {baseline_m: 0.1}", "camera.rig.cameras[0].baseline_m", "defines the camera frame"),
        ("    cameras:\n      - {distortion_model: fisheye}", "distortion_model", "`radtan` or `equidistant`"),
        (
            "    cameras:\n      - {distortion_coeffs: [-0.9, 0, 0, 0]}",
            "distortion_coeffs",
            "folds the image back on itself",
        ),
        ("    cameras:\n      - {intrinsics: [0, 900, 640, 400]}", "intrinsics", "positive focal"),
        ("    pixel_sigma_px: -1", "camera.rig.pixel_sigma_px", "must be from 0 to 1000 px"),
        ("    miscalibration:\n      focal_scale: [[1, 1], [1, 1], [1, 1]]", "focal_scale", "lists 3 cameras"),
        ("    miscalibration:\n      baseline_scale: 3", "baseline_scale", "[0.5, 2]"),
        ("    cameras: [{}]\n    miscalibration:\n      rotation_deg: [0, 0.1, 0]", "rotation_deg", "one camera"),
        ("    cameras: [{}]\n    surprise: 1", "surprise", "unknown field"),
    ];
    for (k, (rig, key, reason)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad_{k}.yaml"));
        std::fs::write(&path, format!("name: bad\ncamera:\n  rig:\n{rig}\n")).unwrap();
        let message = SimConfig::read(&path).unwrap_err().to_string();
        assert!(message.contains(&format!("bad_{k}.yaml:")), "{message}");
        assert!(message.contains(key) && message.contains(reason), "case {k}: {message}");
    }
    // The terms of a camera of points do not mix with a rig.
    let path = dir.path().join("depth_scale.yaml");
    std::fs::write(&path, "name: bad\ncamera:\n  depth_scale: 1.02\n  rig: {}\n").unwrap();
    let message = SimConfig::read(&path).unwrap_err().to_string();
    assert!(message.contains("depth_scale.yaml:4") && message.contains("perfect values"), "{message}");
}
