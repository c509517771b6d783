//! The simulator against the model: noise-free markers reproduce the joint readings, and a seed
//! fixes every byte. Occlusion, collisions and the camera's noise are unit tests inside the crate
//! (`sim::scene`, `sim::camera`).

use std::path::Path;

use nalgebra::Matrix3;
use spmcal::dataset::Session;
use spmcal::math::so3;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

/// The bands of a χ² (`mean_square_band`).
#[path = "common/z_scores.rs"]
#[allow(dead_code)] // shared by the tests, each using part of it
mod z_scores;

fn config() -> SimConfig {
    SimConfig::read(Path::new("configs/simulate_agile_wrist.yaml")).unwrap()
}

#[test]
fn noise_free_markers_reproduce_the_joint_readings_to_quantisation() {
    let mut config = config();
    config.poses = 200;
    config.camera.lateral_sigma_m = 0.0;
    config.camera.depth_sigma_m = 0.0;
    config.encoders.noise_deg = 0.0;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let truth = session.truth.as_ref().unwrap();
    let spm = truth.parameters.spm().unwrap();
    let camera = truth.parameters.camera.unwrap();
    let step = std::f64::consts::TAU / config.encoders.counts_per_revolution as f64;
    for pose in &session.poses {
        // Markers back into B through the true registration, then the rotation that best maps
        // the model's marker positions onto them (Kabsch, via the nearest rotation).
        // The true markers are misplaced from the model's by a few mm: use the truth's.
        let mut cross = Matrix3::zeros();
        for (m, seen) in truth.parameters.markers.iter().zip(&pose.markers) {
            if let Some(c) = seen {
                let b = camera.rotation.inverse() * (c - camera.translation);
                cross += b * m.position.transpose();
            }
        }
        let r = so3::nearest_rotation(&cross).unwrap();
        assert!(so3::geodesic_angle(&r, &truth.orientations[&pose.id]) < 1e-12);
        let joints = spm.ik(&r).unwrap();
        let worst = (joints - pose.joints).amax();
        // Rounding to the nearest count moves a reading by at most half a count.
        assert!(worst <= step / 2.0 + 1e-12, "pose {}: {worst:e} rad off, half a count is {:e}", pose.id, step / 2.0);
    }
}

#[test]
fn the_same_seed_gives_identical_files_and_another_seed_does_not() {
    let mut config = config();
    config.poses = 40;
    config.capture.sequential = true;
    config.camera.outlier_probability = 0.05;
    let model = RobotModel::load(&config.model).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let write = |seed: u64, name: &str| {
        let mut c = config.clone();
        c.seed = seed;
        let (session, _) = c.simulate(&model, &mut |_| {}).unwrap();
        session.write(&dir.path().join(name)).unwrap();
    };
    write(7, "a");
    write(7, "b");
    write(8, "c");
    for file in ["session.yaml", "joints.csv", "markers.csv", "truth.yaml", "truth_orientations.csv"] {
        let read = |d: &str| std::fs::read(dir.path().join(d).join(file)).unwrap();
        assert_eq!(read("a"), read("b"), "{file} differs for the same seed");
        if file != "session.yaml" {
            assert_ne!(read("a"), read("c"), "{file} is the same for another seed");
        }
    }
    // 40 stations captured one marker at a time: a pose per visible capture, four per station at most.
    let (session, _) = Session::load(&dir.path().join("a"), None).unwrap();
    let stations: std::collections::BTreeSet<u64> = session.poses.iter().filter_map(|p| p.station).collect();
    assert_eq!(stations.len(), 40);
    assert!(session.poses.len() > 3 * 40 && session.poses.len() <= 4 * 40, "{}", session.poses.len());
    assert!(session.poses.iter().all(|p| p.seen() == 1));
}

#[test]
fn markers_are_misplaced_in_the_truth_and_sequential_captures_drift() {
    let mut config = config();
    config.poses = 30;
    config.capture.sequential = true;
    config.capture.motion_deg = 0.3;
    let model = RobotModel::load(&config.model).unwrap();
    // Each marker moved by N(0, σ = 3 mm) per axis, a new draw per seed: over 20 seeds × 4 markers
    // × 3 axes the mean square over σ² is χ²₂₄₀ / 240, within 0.73–1.32 with probability 99.9%
    // (`z_scores`; 0.90 measured); a misplacement missing (0), 1.5× (2.25) or doubled (4) leaves
    // it. (One seed's 12 draws allow 0.15–2.9: a doubled misplacement could pass.)
    let sigma = config.truth.marker_position_m;
    let (mut sq, mut draws) = (0.0, 0.0);
    for seed in 0..20 {
        let mut c = config.clone();
        c.seed = 50_000 + seed;
        let (session, _) = c.simulate(&model, &mut |_| {}).unwrap();
        let truth = session.truth.as_ref().unwrap();
        let moved = truth.parameters.markers.iter().zip(&model.markers).map(|(t, m)| t.position - m.position);
        sq += moved.map(|d| d.norm_squared()).sum::<f64>() / (sigma * sigma);
        draws += 3.0 * model.markers.len() as f64;
    }
    let (lo, hi) = z_scores::mean_square_band(draws);
    assert!((lo..=hi).contains(&(sq / draws)), "misplacement: mean square / σ² = {} outside [{lo}, {hi}]", sq / draws);
    // Consecutive captures of a station differ by the drift: a random walk of N(0, 0.3°) per axis
    // per capture (per skipped capture too), its squared angle 3σ² a step: the steps' mean square
    // over σ² per degree of freedom within its 99.9% χ² band (261 degrees of freedom here:
    // 0.74–1.31; 0.96 measured): a drift 1.5× too large or small, or a new station's jump,
    // leaves it; never zero.
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let truth = session.truth.as_ref().unwrap();
    let step_sigma = config.capture.motion_deg.to_radians();
    let marker = |p: &spmcal::dataset::SessionPose| p.markers.iter().position(Option::is_some).unwrap();
    let (mut sq, mut dof) = (0.0, 0.0);
    for pair in session.poses.windows(2).filter(|w| w[0].station == w[1].station) {
        let step = so3::geodesic_angle(&truth.orientations[&pair[0].id], &truth.orientations[&pair[1].id]);
        assert!(step > 0.0);
        sq += (step / step_sigma).powi(2);
        dof += 3.0 * (marker(&pair[1]) - marker(&pair[0])) as f64;
    }
    let (lo, hi) = z_scores::mean_square_band(dof);
    assert!((lo..=hi).contains(&(sq / dof)), "drift: {} outside [{lo}, {hi}] ({dof} dof)", sq / dof);
}

#[test]
fn the_spiral_is_a_continuous_trajectory() {
    let mut config = config();
    config.poses = 300;
    config.workspace.trajectory = spmcal::sim::Trajectory::Spiral;
    // Within ±10° of yaw no corner collides, so every candidate is kept and the steps are visible.
    config.workspace.max_yaw_deg = 10.0;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, summary) = config.simulate(&model, &mut |_| {}).unwrap();
    let truth = session.truth.unwrap();
    let rotations: Vec<_> = truth.orientations.values().collect();
    assert_eq!((summary.attempts, summary.poses), (300, 300), "{summary:?}");
    // Three turns of up to 30° tilt and five yaw swings of ±10° over 300 poses: steps of a few degrees.
    let max_step = rotations.windows(2).map(|w| so3::geodesic_angle(w[0], w[1])).fold(0.0, f64::max).to_degrees();
    assert!(max_step < 4.0, "largest step {max_step:.2}°");
    // It reaches the edge of the tilt range at the end.
    let last_tilt = (rotations.last().unwrap().matrix() * nalgebra::Vector3::z()).z.acos().to_degrees();
    assert!(last_tilt > 20.0, "final tilt {last_tilt:.1}°");
}

#[test]
fn poses_near_a_singularity_are_rejected() {
    let mut config = config();
    config.poses = 60;
    config.workspace.min_conditioning = 0.78;
    let model = RobotModel::load(&config.model).unwrap();
    let (session, summary) = config.simulate(&model, &mut |_| {}).unwrap();
    assert!(summary.rejected_singular > 0, "{summary:?}");
    let truth = session.truth.unwrap();
    let spm = truth.parameters.spm().unwrap();
    for r in truth.orientations.values() {
        let joints = spm.ik(r).unwrap();
        assert!(spm.jacobians(&joints, r).conditioning() >= 0.78);
    }
}

#[test]
fn the_shipped_20_pose_dataset_is_what_the_committed_config_makes() {
    // As the README says: --poses 20 --seed 20 --name agile_wrist_sim_20. A simulator change that
    // alters the data must come with regenerated datasets.
    let mut config = config();
    config.poses = 20;
    config.seed = 20;
    config.name = "agile_wrist_sim_20".into();
    let model = RobotModel::load(&config.model).unwrap();
    let (session, _) = config.simulate(&model, &mut |_| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    session.write(dir.path()).unwrap();
    for file in ["joints.csv", "markers.csv", "truth.yaml", "truth_orientations.csv"] {
        let made = std::fs::read(dir.path().join(file)).unwrap();
        let shipped = std::fs::read(Path::new("datasets/agile_wrist_sim_20").join(file)).unwrap();
        assert!(made == shipped, "{file} differs from the shipped dataset: regenerate it (see README)");
    }
}
