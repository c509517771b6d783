//! The simulator: draws a true geometry and camera, walks the workspace, rejects poses that are
//! unreachable, near a singularity or colliding, and records what encoders and camera would see.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use super::camera::lenses;
use super::config::{Recording, RigidBodySettings, SimConfig, Trajectory, Workspace};
use super::rig::{PixelCameras, Sighting};
use super::scene::CollisionScene;
use crate::dataset::{
    BodyCapture, BodyPose, Capture, EncoderSample, MIN_MARKERS, PixelRow, SeenPixel, Session, SessionPose, Streams,
    Truth, triangulate,
};
use crate::math::so3;
use crate::model::{
    Body, CameraRegistration, GeometrySpread, MarkerPosition, ParameterSource, Parameters, RobotModel, Spm, SpmError,
};

/// What a simulation did, for reports and `--json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SimSummary {
    /// Session name.
    pub name: String,
    /// Random seed.
    pub seed: u64,
    /// Poses written.
    pub poses: usize,
    /// Candidate orientations drawn.
    pub attempts: usize,
    /// Candidates outside the workspace.
    pub rejected_unreachable: usize,
    /// Candidates too near a singularity.
    pub rejected_singular: usize,
    /// Candidates with colliding links.
    pub rejected_collision: usize,
    /// Marker observations written.
    pub markers_seen: usize,
    /// Markers hidden by the mechanism.
    pub markers_occluded: usize,
    /// Outlier measurements drawn.
    pub outliers: usize,
    /// Poses the per-pose estimator cannot use (fewer than 3 markers).
    pub poses_with_too_few_markers: usize,
    /// Pixels written (a rig's cameras; with a rig, `markers_seen` counts the points its file
    /// triangulates, `markers_occluded` a marker hidden from one camera, `outliers` pixels).
    pub pixels_seen: usize,
    /// Pixels lost behind a camera or outside its image.
    pub pixels_outside_image: usize,
}

impl std::fmt::Display for SimSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.attempts == 0 {
            // A free-motion recording: frames of the camera, not drawn poses.
            writeln!(f, "{}: a free-motion recording of {} camera frames", self.name, self.poses)?;
        } else {
            writeln!(
                f,
                "{}: {} poses ({} attempts; rejected: {} unreachable, {} near a singularity, {} colliding)",
                self.name,
                self.poses,
                self.attempts,
                self.rejected_unreachable,
                self.rejected_singular,
                self.rejected_collision
            )?;
        }
        if self.pixels_seen > 0 {
            return writeln!(
                f,
                "pixels: {} seen, {} hidden by the mechanism, {} outside an image, {} outliers; {} points triangulated; {} poses with fewer than 3 points",
                self.pixels_seen,
                self.markers_occluded,
                self.pixels_outside_image,
                self.outliers,
                self.markers_seen,
                self.poses_with_too_few_markers
            );
        }
        writeln!(
            f,
            "markers: {} seen, {} occluded, {} outliers; {} poses with fewer than 3 markers",
            self.markers_seen, self.markers_occluded, self.outliers, self.poses_with_too_few_markers
        )
    }
}

/// Why a simulation could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    #[error("{0}")]
    /// A setting of the config file that no pose can meet, located at its key's line.
    Config(crate::io::FileError),
    #[error("the true geometry drawn is not a valid manipulator (spreads too large?): {0}")]
    /// The drawn true geometry is not a valid manipulator.
    Geometry(#[from] SpmError),
    #[error("{}{reason}", plan_place(.path, .line, .step))]
    /// A planned pose the simulation cannot take as asked: the model cannot reach it, it lies
    /// outside the config's workspace, or its row's joints contradict its orientation.
    Plan {
        /// The plan file, when the plan was read from one.
        path: Option<std::path::PathBuf>,
        /// The pose's line in that file.
        line: Option<usize>,
        /// Its step number (from 1), when the problem is one pose's.
        step: Option<u64>,
        /// What is wrong.
        reason: String,
    },
    #[error("only {found} of {wanted} poses survived {attempts} attempts: {cause}; loosen `{key}` in the config")]
    /// Too few candidate orientations passed the checks.
    TooFewPoses {
        /// Poses accepted.
        found: usize,
        /// Poses asked for.
        wanted: usize,
        /// Candidate orientations tried.
        attempts: usize,
        /// What rejected most candidates.
        cause: String,
        /// The config key that governs that rejection.
        key: &'static str,
    },
}

/// Where a plan error lies: `plan.csv:5: step 4: `, `plan step 4: ` or nothing.
fn plan_place(path: &Option<std::path::PathBuf>, line: &Option<usize>, step: &Option<u64>) -> String {
    let step = step.map(|s| format!("step {s}: "));
    match (path, line) {
        (Some(path), Some(line)) => format!("{}:{line}: {}", path.display(), step.unwrap_or_default()),
        (Some(path), None) => format!("{}: {}", path.display(), step.unwrap_or_default()),
        (None, _) => step.map(|s| format!("plan {s}")).unwrap_or_default(),
    }
}

/// Why a candidate orientation was rejected.
enum Rejection {
    Unreachable(crate::model::IkError),
    /// Near a parallel singularity (the conditioning index) or a serial one (the leg and its branch
    /// margin).
    Singular {
        conditioning: f64,
        leg_margin: Option<(usize, f64)>,
    },
    Collision(Body, Body),
}

impl Rejection {
    /// What is wrong, in the config's terms, on the model `model`.
    fn describe(&self, workspace: &Workspace, model: &Path) -> String {
        match self {
            Rejection::Unreachable(e) => format!("the model {} cannot reach this orientation: {e}", model.display()),
            Rejection::Singular { leg_margin: Some((leg, margin)), .. } => format!(
                "this orientation lies near a serial singularity of the model {}: leg {}'s branch margin {:.3} is within `workspace.min_branch_margin` ({}) of zero",
                model.display(),
                leg + 1,
                margin.abs(),
                workspace.min_branch_margin
            ),
            Rejection::Singular { conditioning, .. } => format!(
                "this orientation lies near a parallel singularity of the model {}: its conditioning index {conditioning:.3} is below `workspace.min_conditioning` ({})",
                model.display(),
                workspace.min_conditioning
            ),
            Rejection::Collision(a, b) => {
                format!("the model's {} and {} collide at this orientation", body_name(*a), body_name(*b))
            }
        }
    }
}

/// A body in words.
fn body_name(body: Body) -> String {
    match body {
        Body::Base => "base".into(),
        Body::Proximal(i) => format!("leg {}'s proximal link", i + 1),
        Body::Distal(i) => format!("leg {}'s distal link", i + 1),
        Body::Platform => "moving platform".into(),
    }
}

/// How far a plan row's joints may put the MP from its orientation under the model (rad): spmcal
/// writes the joints as the model's IK of the orientation at full precision, and the FDA gives
/// the orientation back to ~1e-14 rad; a millionth of a radian (0.2″) is rounding of any kind, and
/// anything beyond it an edited row or a plan made for another model.
pub(crate) const PLAN_AGREEMENT_RAD: f64 = 1e-6;

/// The joint readings at `r` of `spm` if `r` passes the workspace's checks: reachable in the
/// working mode, away from singularities (`workspace`'s bounds), no link collisions.
fn workspace_check(
    spm: &Spm,
    scene: &CollisionScene,
    workspace: &Workspace,
    r: &Rotation3<f64>,
) -> Result<Vector3<f64>, Rejection> {
    let joints = spm.ik(r).map_err(Rejection::Unreachable)?;
    let conditioning = spm.jacobians(&joints, r).conditioning();
    let margins = spm.branch_margins(&joints, r);
    if conditioning < workspace.min_conditioning || margins.max() > -workspace.min_branch_margin {
        let leg = margins.argmax().0;
        let leg_margin = (margins[leg] > -workspace.min_branch_margin).then_some((leg, margins[leg]));
        return Err(Rejection::Singular { conditioning, leg_margin });
    }
    if let Some((a, b)) = scene.collision(&scene.body_rotations(spm, &joints, r)) {
        return Err(Rejection::Collision(a, b));
    }
    Ok(joints)
}

/// Check a plan (`config.plan`) against the model before anything is drawn: every pose reachable
/// by the model and inside the config's workspace (tilt, yaw, singularities, collisions), and —
/// with the plan's rows (`config.plan_source`) — each row's joints giving the row's orientation
/// under the model's FDA (within [`PLAN_AGREEMENT_RAD`]). A free-motion recording takes no plan.
fn check_plan(config: &SimConfig, model: &RobotModel) -> Result<(), SimError> {
    let Some(plan) = &config.plan else { return Ok(()) };
    let source = config.plan_source.as_ref();
    let path = source.map(|s| s.path.clone());
    if let Some(s) = source.filter(|s| s.rows.len() != plan.len()) {
        let reason = format!(
            "the plan holds {} orientations but its file has {} rows: they do not describe one plan",
            plan.len(),
            s.rows.len()
        );
        return Err(SimError::Plan { path, line: None, step: None, reason });
    }
    if config.recording.is_some() {
        let reason = "the config describes a free-motion recording (`recording`), which follows the hand, not a plan: remove `recording` from the config or leave out the plan".into();
        return Err(SimError::Plan { path, line: None, step: None, reason });
    }
    let scene = CollisionScene::new(model);
    let w = &config.workspace;
    let (max_tilt, max_yaw) = (w.max_tilt_deg.to_radians(), w.max_yaw_deg.to_radians());
    // Bounds as drawn, with room for the rounding of a quaternion written and read back.
    const ROUNDING: f64 = 1e-9;
    for (k, r) in plan.iter().enumerate() {
        let row = source.map(|s| s.rows[k]);
        let fail = |reason: String| SimError::Plan {
            path: path.clone(),
            line: row.map(|r| r.line),
            step: Some(row.map_or(k as u64 + 1, |r| r.step)),
            reason,
        };
        model.spm.ik(r).map_err(|e| fail(Rejection::Unreachable(e).describe(w, &model.urdf_path)))?;
        if let Some(row) = row {
            let agree = model.spm.forward(&row.joints).map(|fda| so3::geodesic_angle(&fda, r));
            let j = row.joints;
            match agree {
                Ok(angle) if angle <= PLAN_AGREEMENT_RAD => {}
                Ok(angle) => {
                    return Err(fail(format!(
                        "its joints ({}, {}, {} rad) put the MP {angle:.3e} rad ({:.4}°) from its quaternion under the model {} (a row agrees within {PLAN_AGREEMENT_RAD:e} rad: spmcal writes plans at full precision): the row was edited, or the plan was made for another model or parameters file",
                        j[0],
                        j[1],
                        j[2],
                        angle.to_degrees(),
                        model.urdf_path.display()
                    )));
                }
                Err(e) => {
                    return Err(fail(format!(
                        "its joints ({}, {}, {} rad) do not give its quaternion under the model {}: forward kinematics fails ({e}); the row was edited, or the plan was made for another model or parameters file",
                        j[0],
                        j[1],
                        j[2],
                        model.urdf_path.display()
                    )));
                }
            }
        }
        let (tilt, yaw) = so3::tilt_and_yaw(r);
        if tilt > max_tilt + ROUNDING {
            return Err(fail(format!(
                "its orientation tilts {:.3}° from home, outside the simulation's workspace (`workspace.max_tilt_deg`: {}°)",
                tilt.to_degrees(),
                w.max_tilt_deg
            )));
        }
        if yaw.abs() > max_yaw + ROUNDING {
            return Err(fail(format!(
                "its orientation yaws {:.3}°, outside the simulation's workspace (`workspace.max_yaw_deg`: ±{}°)",
                yaw.to_degrees(),
                w.max_yaw_deg
            )));
        }
        workspace_check(&model.spm, &scene, w, r).map_err(|e| fail(e.describe(w, &model.urdf_path)))?;
    }
    Ok(())
}

struct Simulator<'a> {
    config: &'a SimConfig,
    model: &'a RobotModel,
    spm: Spm,
    camera: CameraRegistration,
    /// True marker positions in P.
    markers: Vec<Vector3<f64>>,
    scene: CollisionScene,
    rng: ChaCha8Rng,
    summary: SimSummary,
    /// The rig's cameras, when the camera is a rig seen through its pixels.
    pixels: Option<PixelCameras>,
}

impl SimConfig {
    /// Up to `count` orientations of this config's workspace for the mechanism `spm` (of `model`,
    /// with its markers and the camera looking down): drawn as [`SimConfig::simulate`] draws its
    /// poses (seeded by `seed`) and kept when they pass its checks — reachable in the working
    /// mode, away from singularities, no link collisions. The workspace a calibration's accuracy
    /// is predicted over (`plan`) and scored over (the studies).
    pub fn workspace_orientations(
        &self,
        model: &RobotModel,
        spm: &Spm,
        count: usize,
        seed: u64,
    ) -> Vec<Rotation3<f64>> {
        let config = SimConfig { seed, ..self.clone() };
        let markers: Vec<Vector3<f64>> = model.markers.iter().map(|m| m.position).collect();
        Candidate::draw(&config, model, spm, &self.camera.looking_down(), &markers, count, 0.0)
            .into_iter()
            .map(|c| c.rotation)
            .collect()
    }

    /// Simulate a session with this config on `model`, with the counts of what was rejected,
    /// occluded and drawn as an outlier; `progress` is told the number of poses made so far.
    /// Deterministic for a seed.
    ///
    /// # Errors
    /// A [`SimError`] when the drawn geometry is invalid or too few candidate poses pass the
    /// checks (naming the config key to loosen); with a plan, when a planned pose is out of the
    /// model's reach or the config's workspace, or its row's joints contradict its orientation
    /// (naming the plan file's line when the plan was read from one).
    ///
    /// # Panics
    /// If the config holds a deviation that is not finite or an outlier probability outside
    /// [0, 1] (configs are checked when read).
    pub fn simulate(
        &self,
        model: &RobotModel,
        progress: &mut dyn FnMut(usize),
    ) -> Result<(Session, SimSummary), SimError> {
        check_plan(self, model)?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let t = &self.truth;
        let spread = GeometrySpread {
            axis_tilt: t.axis_tilt_deg.to_radians(),
            link_angle: t.link_angle_deg.to_radians(),
            joint_offset: t.joint_offset_deg.to_radians(),
        };
        let mut legs = spread.perturb(model.spm.geometry(), &mut rng);
        for (g, s) in legs.iter_mut().zip(self.encoders.scales) {
            g.scale *= s;
        }
        let spm = Spm::new(legs)?;
        let nominal = self.camera.looking_down();
        let position = Normal::new(0.0, t.camera_position_m).expect("validated deviation");
        let camera_centre =
            Vector3::new(0.0, 0.0, self.camera.height_m) + Vector3::from_fn(|_, _| position.sample(&mut rng));
        let rotation =
            so3::exp(&random_rotation_vector(t.camera_rotation_deg.to_radians(), &mut rng)) * nominal.rotation;
        let camera = CameraRegistration::from_centre(rotation, &camera_centre);
        let misplacement = Normal::new(0.0, t.marker_position_m).expect("validated deviation");
        let markers =
            model.markers.iter().map(|m| m.position + Vector3::from_fn(|_, _| misplacement.sample(&mut rng))).collect();
        let summary = SimSummary { name: self.name.clone(), seed: self.seed, ..Default::default() };
        let pixels = self.pixel_cameras();
        let scene = CollisionScene::new(model);
        let mut sim = Simulator { config: self, model, spm, camera, markers, scene, rng, summary, pixels };
        let session = match &self.recording {
            Some(r) => sim.record_streams(r, progress),
            None => sim.run(progress),
        };
        // A setting no pose can meet is the config's: say so at its key's line.
        let session = session.map_err(|e| match e {
            SimError::TooFewPoses { key, .. } => match self.source.locate(key, e.to_string()) {
                Ok(located) => SimError::Config(located),
                Err(_) => e,
            },
            other => other,
        })?;
        Ok((session, sim.summary))
    }

    /// The cameras of the config's rig, if it has one.
    fn pixel_cameras(&self) -> Option<PixelCameras> {
        self.camera.rig.as_ref().map(|rig| PixelCameras::new(rig, self.camera.outlier_probability))
    }
}

/// A pose the capture checks accept: its orientation, the joint readings there and the markers
/// both lenses see.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Candidate {
    /// MP orientation (P → B).
    pub(crate) rotation: Rotation3<f64>,
    /// Joint readings of the working mode there.
    pub(crate) joints: Vector3<f64>,
    /// Markers (indices into the model's) both lenses see.
    pub(crate) visible: Vec<usize>,
}

impl Candidate {
    /// Up to `count` orientations drawn from `config`'s workspace as `simulate` draws its poses
    /// (home first, then random, seeded by `config.seed`), kept when they pass its checks on the
    /// geometry `spm` — reachable in the working mode, away from singularities, no link
    /// collisions — each with the markers (at `markers`, in P) the camera at `camera` sees. With a
    /// `margin` (radians) the checks must also pass, and the markers stay visible, `margin`
    /// further out in tilt and `margin` either way in yaw: a real mechanism, camera and operator
    /// are that far from the model. Gives up after `50 count + 100` draws.
    pub(crate) fn draw(
        config: &SimConfig,
        model: &RobotModel,
        spm: &Spm,
        camera: &CameraRegistration,
        markers: &[Vector3<f64>],
        count: usize,
        margin: f64,
    ) -> Vec<Candidate> {
        let mut sim = Simulator {
            config,
            model,
            spm: spm.clone(),
            camera: *camera,
            markers: markers.to_vec(),
            scene: CollisionScene::new(model),
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            summary: SimSummary::default(),
            pixels: config.pixel_cameras(),
        };
        let max_attempts = 50 * count + 100;
        let mut out = Vec::with_capacity(count);
        let mut attempts = 0;
        // Drawn in order (the random stream decides), checked in batches on two cores, kept in order.
        while out.len() < count && attempts < max_attempts {
            let batch: Vec<Rotation3<f64>> = (attempts..max_attempts.min(attempts + (count - out.len()).max(64)))
                .map(|k| if k == 0 { Rotation3::identity() } else { sim.candidate(k, max_attempts) })
                .collect();
            attempts += batch.len();
            let (first, second) = batch.split_at(batch.len() / 2);
            let check = |rotations: &[Rotation3<f64>]| -> Vec<Option<Candidate>> {
                rotations.iter().map(|r| sim.robust_candidate(r, margin)).collect()
            };
            let (a, b) = crate::in_parallel(|| check(first), || check(second));
            out.extend(a.into_iter().chain(b).flatten().take(count - out.len()));
        }
        out
    }
}

/// The body frame of `b` on the MP: its origin in P and its orientation, body → P.
fn body_frame(b: &RigidBodySettings) -> (Vector3<f64>, Rotation3<f64>) {
    (Vector3::from(b.origin_m), so3::exp(&Vector3::from(b.rotation_deg).map(f64::to_radians)))
}

/// The rigid motion `(R, t)` carrying the markers `model` (in P) onto those `measured` (in the
/// camera's frame; `None`: unseen) best in least squares (Kabsch); `None` for fewer than three.
fn fit_markers(model: &[Vector3<f64>], measured: &[Option<Vector3<f64>>]) -> Option<(Rotation3<f64>, Vector3<f64>)> {
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> =
        model.iter().zip(measured).filter_map(|(p, m)| m.map(|m| (*p, m))).collect();
    if pairs.len() < MIN_MARKERS {
        return None;
    }
    let n = pairs.len() as f64;
    let cp = pairs.iter().map(|(p, _)| p).sum::<Vector3<f64>>() / n;
    let cm = pairs.iter().map(|(_, m)| m).sum::<Vector3<f64>>() / n;
    let h: nalgebra::Matrix3<f64> = pairs.iter().map(|(p, m)| (m - cm) * (p - cp).transpose()).sum();
    let rotation = so3::nearest_rotation(&h)?;
    Some((rotation, cm - rotation * cp))
}

/// `session` as a tracker of the rigid body `b` reports it: the body's poses, no markers.
fn as_body(mut session: Session, b: &RigidBodySettings) -> Session {
    session.markers.clear();
    session.body = Some(b.name.clone());
    for pose in session.poses.iter_mut() {
        pose.markers.clear();
        pose.marker_lines.clear();
    }
    if let Some(streams) = session.streams.as_mut() {
        std::sync::Arc::make_mut(streams).captures.clear();
    }
    session.reference_pose = session.poses.iter().find(|p| p.body.is_some()).map_or(0, |p| p.id);
    session
}

fn random_rotation_vector<R: Rng + ?Sized>(sigma: f64, rng: &mut R) -> Vector3<f64> {
    let normal = Normal::new(0.0, sigma).expect("validated deviation");
    Vector3::from_fn(|_, _| normal.sample(rng))
}

impl Simulator<'_> {
    /// Why the simulation fell short, and the config key that governs it.
    fn dominant_rejection(&self, home: Option<&SessionPose>) -> (String, &'static str) {
        let s = &self.summary;
        if let Some(home) = home.filter(|p| p.seen() < MIN_MARKERS) {
            let cause = format!("the camera sees only {} markers at home (the reference pose)", home.seen());
            return (cause, "camera.height_m");
        }
        let counts = [
            (s.rejected_unreachable, "unreachable", "workspace.max_tilt_deg"),
            (s.rejected_singular, "near a singularity", "workspace.min_conditioning"),
            (s.rejected_collision, "colliding", "workspace.max_tilt_deg"),
        ];
        let (n, what, key) = counts.into_iter().max_by_key(|c| c.0).expect("three counts");
        (format!("{n} candidates were rejected as {what}"), key)
    }

    fn run(&mut self, progress: &mut dyn FnMut(usize)) -> Result<Session, SimError> {
        let wanted = self.config.poses;
        let plan = self.config.plan.as_deref();
        let wanted = plan.map_or(wanted, <[_]>::len);
        let max_attempts = match (plan, self.config.workspace.trajectory) {
            (Some(_), _) | (None, Trajectory::Spiral) => wanted,
            (None, Trajectory::Random) => 50 * wanted + 100,
        };
        let mut poses = Vec::with_capacity(wanted);
        let mut truth = BTreeMap::new();
        let mut stations = 0;
        while stations < wanted && self.summary.attempts < max_attempts {
            // The first candidate is home: a level MP makes the natural reference pose.
            let r = match plan {
                Some(plan) => plan[self.summary.attempts],
                None if self.summary.attempts == 0 => Rotation3::identity(),
                None => self.candidate(self.summary.attempts, max_attempts),
            };
            self.summary.attempts += 1;
            match self.accept(&r) {
                Ok(joints) => {
                    let station = stations as u64;
                    stations += 1;
                    let captures = if self.config.capture.sequential {
                        self.record_sequential(poses.len() as u64, station, &r)
                    } else {
                        vec![(self.record(poses.len() as u64, &r, &joints, &self.all_markers()), r)]
                    };
                    for (pose, r) in captures {
                        truth.insert(pose.id, self.sagged(&r));
                        poses.push(pose);
                    }
                    progress(stations);
                }
                Err(Rejection::Unreachable(_)) => self.summary.rejected_unreachable += 1,
                Err(Rejection::Singular { .. }) => self.summary.rejected_singular += 1,
                Err(Rejection::Collision(..)) => self.summary.rejected_collision += 1,
            }
        }
        // A planned pose the true mechanism cannot take is counted, not replaced.
        let enough = match (plan, self.config.workspace.trajectory) {
            (None, Trajectory::Random) => stations == wanted,
            _ => stations >= wanted.min(MIN_MARKERS),
        };
        // Simultaneous capture makes home the per-pose estimator's reference: it must see enough
        // (a plan's first pose need not be home; the session then picks its reference).
        // (A single camera triangulates nothing: the estimator has no use for its session.)
        let single = self.pixels.as_ref().is_some_and(|p| p.truth.cameras.len() < 2);
        let reference_blind = plan.is_none()
            && !self.config.capture.sequential
            && !single
            && poses.first().is_some_and(|p| p.seen() < MIN_MARKERS);
        if !enough || poses.is_empty() || reference_blind {
            let (cause, key) = self.dominant_rejection(poses.first());
            return Err(SimError::TooFewPoses { found: stations, wanted, attempts: self.summary.attempts, cause, key });
        }
        self.summary.poses = poses.len();
        self.summary.poses_with_too_few_markers = poses.iter().filter(|p| p.seen() < MIN_MARKERS).count();
        let parameters = self.truth_parameters(None, None);
        let description = self.config.description.clone().unwrap_or_else(|| {
            let trajectory = if plan.is_some() { "planned" } else { self.config.workspace.trajectory.name() };
            format!(
                "simulated by spmcal simulate (seed {}, {} poses, {trajectory} trajectory)",
                self.config.seed,
                poses.len()
            )
        });
        let reference_pose = poses.iter().find(|p| p.seen() >= MIN_MARKERS).unwrap_or(&poses[0]).id;
        let session = Session {
            rig: self.file_rig(),
            name: self.config.name.clone(),
            description: Some(description),
            model: self.model.urdf_path.clone(),
            markers: self.model.markers.iter().map(|m| m.name.clone()).collect(),
            body: None,
            reference_pose,
            poses,
            truth: Some(Truth { parameters, orientations: truth, rig: self.true_rig() }),
            streams: None,
            folder: None,
        };
        Ok(match &self.config.camera.rigid_body {
            Some(b) => as_body(session, b),
            None => session,
        })
    }

    /// The rig the session's file states, when the camera is a rig.
    fn file_rig(&self) -> Option<std::sync::Arc<crate::model::Rig>> {
        self.pixels.as_ref().map(|p| std::sync::Arc::new(p.file.clone()))
    }

    /// The true rig, when the camera is a rig.
    fn true_rig(&self) -> Option<crate::model::Rig> {
        self.pixels.as_ref().map(|p| p.truth.clone())
    }

    /// The true parameters (with the camera latency of a recording, and its clock rate when the
    /// camera's clock runs at its own).
    fn truth_parameters(&self, latency_s: Option<f64>, clock_rate_ppm: Option<f64>) -> Parameters {
        let markers = match &self.config.camera.rigid_body {
            Some(b) => {
                let (origin, frame) = body_frame(b);
                vec![MarkerPosition {
                    name: b.name.clone(),
                    position: origin,
                    std_error: None,
                    rotation: Some(frame),
                    rotation_std_error: None,
                }]
            }
            None => self
                .model
                .markers
                .iter()
                .zip(&self.markers)
                .map(|(m, p)| MarkerPosition {
                    name: m.name.clone(),
                    position: *p,
                    std_error: None,
                    rotation: None,
                    rotation_std_error: None,
                })
                .collect(),
        };
        Parameters {
            source: ParameterSource::Truth,
            model: Some(self.model.reference().display().to_string()),
            model_sha256: Some(self.model.sha256.clone()),
            legs: *self.spm.geometry(),
            camera: Some(self.camera),
            camera_model: self.config.camera.model(),
            markers,
            latency_s,
            clock_rate_ppm,
            platform_sag_deg: self.config.truth.sag_deg,
            platform_sag_std_error_deg: None,
            fit: None,
        }
    }

    /// A free-motion recording: the hand moves smoothly through random waypoints of 80% of the
    /// workspace's tilt and yaw (one every `period_s / 10`), shrunk until every encoder sample is
    /// reachable, away from singularities and free of collisions; the encoders stream its IK
    /// with noise and quantisation, the camera measures markers at its own rate, stamped late by
    /// the latency with jitter, on a clock that runs `clock_rate_ppm` fast.
    fn record_streams(&mut self, r: &Recording, progress: &mut dyn FnMut(usize)) -> Result<Session, SimError> {
        let w = &self.config.workspace;
        let (tilt, yaw) = (0.8 * w.max_tilt_deg.to_radians(), 0.8 * w.max_yaw_deg.to_radians());
        // The hand goes through random waypoints — uniform over the tilt disc and the yaw range,
        // as the static poses are drawn — one every `period_s / 10`, along a Catmull–Rom spline
        // (smooth, no stops): a path that covers the workspace as static poses do. (Sums of a few
        // sinusoids per axis, tried first, left the mechanism weakly determined.)
        let step = r.period_s / 10.0;
        let count = (r.duration_s / step).ceil() as usize + 4;
        let waypoints: Vec<[f64; 3]> = (0..count)
            .map(|_| {
                let radius = self.rng.random::<f64>().sqrt();
                let azimuth = self.rng.random_range(0.0..std::f64::consts::TAU);
                [radius * azimuth.cos(), radius * azimuth.sin(), self.rng.random_range(-1.0..1.0)]
            })
            .collect();
        let wave = |axis: usize, t: f64| -> f64 {
            let u = t / step;
            let k = (u.floor() as usize).min(count - 4);
            let f = u - k as f64;
            let [p0, p1, p2, p3] = [0, 1, 2, 3].map(|d| waypoints[k + d][axis]);
            // Catmull–Rom between p1 and p2.
            0.5 * (2.0 * p1
                + (p2 - p0) * f
                + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f * f
                + (3.0 * p1 - p0 - 3.0 * p2 + p3) * f * f * f)
        };
        let n = (r.duration_s * r.encoder_rate_hz).round() as usize + 1;
        let mut scale = 1.0;
        let at = |scale: f64, t: f64| {
            let v = Vector3::new(wave(0, t), wave(1, t), 0.0) * (tilt * scale);
            let v = if v.norm() > tilt * scale { v * (tilt * scale / v.norm()) } else { v };
            so3::exp(&v) * so3::exp(&(Vector3::z() * (yaw * scale * wave(2, t))))
        };
        let truth_joints = loop {
            let mut joints = Vec::with_capacity(n);
            let mut failed = None;
            for i in 0..n {
                let t = i as f64 / r.encoder_rate_hz;
                // Collisions and singularities change slowly: checked every 10 ms; IK everywhere.
                let check = i % ((r.encoder_rate_hz / 100.0).ceil() as usize).max(1) == 0;
                let rot = at(scale, t);
                let result = if check { self.accept(&rot) } else { self.spm.ik(&rot).map_err(Rejection::Unreachable) };
                match result {
                    Ok(j) => joints.push(j),
                    Err(_) => {
                        failed = Some(t);
                        break;
                    }
                }
            }
            match failed {
                None => break joints,
                Some(_) if scale > 0.3 => scale *= 0.8,
                Some(t) => {
                    return Err(SimError::TooFewPoses {
                        found: 0,
                        wanted: 1,
                        attempts: 6,
                        cause: format!("the hand's motion leaves the workspace at {t:.2} s even at 30% of its size"),
                        key: "workspace.max_tilt_deg",
                    });
                }
            }
        };
        let encoders: Vec<EncoderSample> = truth_joints
            .iter()
            .enumerate()
            .map(|(i, j)| EncoderSample { time_s: i as f64 / r.encoder_rate_hz, joints: self.read_encoders(j) })
            .collect();
        let jitter = Normal::new(0.0, r.jitter_s).expect("validated deviation");
        let frames = (r.duration_s * r.camera_rate_hz).floor() as usize;
        let m = self.markers.len();
        let (mut captures, mut pixels, mut bodies) = (Vec::new(), Vec::new(), Vec::new());
        for f in 0..frames {
            let t = (f as f64 + 0.5) / r.camera_rate_hz;
            let rot = at(scale, t);
            let Ok(joints) = self.spm.ik(&rot) else { continue };
            let which: Vec<usize> = if r.all_markers { (0..m).collect() } else { vec![f % m] };
            let pose = self.record(0, &rot, &joints, &which);
            // Taken at `t` on the encoders' clock: the camera's reads `t·(1 + ρ·10⁻⁶)` then.
            let stamp = t * (1.0 + r.clock_rate_ppm * 1e-6) + r.latency_s + jitter.sample(&mut self.rng);
            for (marker, seen) in pose.markers.iter().enumerate() {
                if let Some(position) = seen {
                    captures.push(Capture { time_s: stamp, marker, position: *position, line: 0 });
                }
            }
            pixels.extend(pose.pixels.into_iter().map(|seen| PixelRow { at: stamp, seen }));
            bodies.extend(pose.body.map(|pose| BodyCapture { time_s: stamp, pose }));
            progress(f + 1);
        }
        // The jitter (under a quarter frame) never reorders frames; sorted all the same.
        bodies.sort_by(|a: &BodyCapture, b: &BodyCapture| a.time_s.total_cmp(&b.time_s));
        captures.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        pixels.sort_by(|a, b| a.at.total_cmp(&b.at));
        self.summary.poses = frames;
        self.summary.poses_with_too_few_markers = 0;
        let streams = match &self.pixels {
            // The captures are the points the file's rig triangulates from each frame's pixels, as
            // the recording's reader makes them.
            Some(cameras) => {
                Streams::of_pixels(std::path::PathBuf::from("pixels.csv"), encoders, pixels, &cameras.file).0
            }
            None => Streams {
                captures_path: std::path::PathBuf::from(if bodies.is_empty() { "captures.csv" } else { "poses.csv" }),
                encoders,
                captures,
                pixels,
                bag_topics: None,
                bodies,
            },
        };
        let session = Session {
            rig: self.file_rig(),
            name: self.config.name.clone(),
            description: Some(self.config.description.clone().unwrap_or_else(|| {
                format!(
                    "free-motion recording simulated by spmcal simulate (seed {}, {} s)",
                    self.config.seed, r.duration_s
                )
            })),
            model: self.model.urdf_path.clone(),
            markers: self.model.markers.iter().map(|mk| mk.name.clone()).collect(),
            body: None,
            reference_pose: 0,
            poses: Vec::new(),
            truth: Some(Truth {
                parameters: self
                    .truth_parameters(Some(r.latency_s), (r.clock_rate_ppm != 0.0).then_some(r.clock_rate_ppm)),
                orientations: BTreeMap::new(),
                rig: self.true_rig(),
            }),
            streams: Some(std::sync::Arc::new(streams)),
            folder: None,
        };
        let session = match &self.config.camera.rigid_body {
            Some(b) => as_body(session, b),
            None => session,
        };
        Ok(session.at_clock(r.latency_s, r.clock_rate_ppm).0)
    }

    /// The `k`-th candidate orientation of `n`.
    fn candidate(&mut self, k: usize, n: usize) -> Rotation3<f64> {
        let w = &self.config.workspace;
        let (max_tilt, max_yaw) = (w.max_tilt_deg.to_radians(), w.max_yaw_deg.to_radians());
        match w.trajectory {
            Trajectory::Random => {
                // sqrt makes the tilt vectors uniform over the disc of radius max_tilt.
                let tilt = max_tilt * self.rng.random::<f64>().sqrt();
                let azimuth = self.rng.random_range(0.0..std::f64::consts::TAU);
                let yaw = if max_yaw > 0.0 { self.rng.random_range(-max_yaw..=max_yaw) } else { 0.0 };
                so3::from_tilt_and_yaw(azimuth, tilt, yaw)
            }
            Trajectory::Spiral => {
                let s = k as f64 / (n.max(2) - 1) as f64;
                so3::from_tilt_and_yaw(
                    3.0 * std::f64::consts::TAU * s,
                    max_tilt * s.sqrt(),
                    max_yaw * (5.0 * std::f64::consts::TAU * s).sin(),
                )
            }
        }
    }

    /// The true joint readings of a pose the workspace settings accept.
    fn accept(&self, r: &Rotation3<f64>) -> Result<Vector3<f64>, Rejection> {
        workspace_check(&self.spm, &self.scene, &self.config.workspace, r)
    }

    fn all_markers(&self) -> Vec<usize> {
        (0..self.markers.len()).collect()
    }

    /// Encoder readings of the true `joints`: noise, then quantisation.
    fn read_encoders(&mut self, joints: &Vector3<f64>) -> Vector3<f64> {
        let step = std::f64::consts::TAU / self.config.encoders.counts_per_revolution as f64;
        let noise = Normal::new(0.0, self.config.encoders.noise_deg.to_radians()).expect("validated deviation");
        joints.map(|theta| ((theta + noise.sample(&mut self.rng)) / step).round() * step)
    }

    /// A station captured one marker at a time: the hand-held MP drifts (a random walk) between
    /// captures, and each capture is its own pose with the reading of its instant. A capture whose
    /// marker is hidden, or that drifted out of the workspace, is not recorded.
    fn record_sequential(
        &mut self,
        first_id: u64,
        station: u64,
        r: &Rotation3<f64>,
    ) -> Vec<(SessionPose, Rotation3<f64>)> {
        let mut at = *r;
        let mut captures = Vec::new();
        for k in 0..self.markers.len() {
            if k > 0 {
                at = so3::exp(&random_rotation_vector(self.config.capture.motion_deg.to_radians(), &mut self.rng)) * at;
            }
            let Ok(joints) = self.spm.ik(&at) else { continue };
            let mut pose = self.record(first_id + captures.len() as u64, &at, &joints, &[k]);
            if pose.seen() == 0 && pose.pixels.is_empty() {
                continue;
            }
            pose.station = Some(station);
            captures.push((pose, at));
        }
        captures
    }

    /// `r` as a planning candidate: passing the checks there and `margin` beyond (see
    /// [`Candidate::draw`]), with the markers seen at all of them.
    fn robust_candidate(&self, r: &Rotation3<f64>, margin: f64) -> Option<Candidate> {
        let joints = self.accept(r).ok()?;
        let mut visible = self.visible(r, &joints);
        if margin > 0.0 {
            let tilt = so3::log(r).xy().norm();
            let outwards = if tilt > 1e-9 { so3::exp(&(so3::log(r) * ((tilt + margin) / tilt))) } else { *r };
            for near in [outwards, r * so3::exp(&(Vector3::z() * margin)), r * so3::exp(&(Vector3::z() * -margin))] {
                let j = self.accept(&near).ok()?;
                // A mask, not a search per marker: linear in the markers.
                let mut seen = vec![false; self.markers.len()];
                self.visible(&near, &j).into_iter().for_each(|k| seen[k] = true);
                visible.retain(|&k| seen[k]);
            }
        }
        Some(Candidate { rotation: *r, joints, visible })
    }

    /// Where the lines of sight start, in B: the two lenses of a camera of points, or each
    /// camera of a rig.
    fn viewpoints(&self) -> Vec<Vector3<f64>> {
        match &self.pixels {
            Some(p) => p.centres().iter().map(|c| self.camera.to_base(c)).collect(),
            None => lenses(&self.camera, self.config.camera.baseline_m).to_vec(),
        }
    }

    /// The markers every lens (every camera of a rig) sees at a pose.
    fn visible(&self, r: &Rotation3<f64>, joints: &Vector3<f64>) -> Vec<usize> {
        let rotations = self.scene.body_rotations(&self.spm, joints, r);
        let radius = self.config.camera.marker_radius_m;
        let lens = self.viewpoints();
        (0..self.markers.len())
            .filter(|&k| {
                let point = r * self.markers[k];
                lens.iter().all(|l| self.scene.occluder(&rotations, &point, l, radius).is_none())
            })
            .collect()
    }

    /// Where the platform is when the joints put it at `r`: sagged under its weight by
    /// `truth.sag_deg` per unit of the gravity torque's arm `n × (−z)` (`n` its axis, `z` up).
    fn sagged(&self, r: &Rotation3<f64>) -> Rotation3<f64> {
        let compliance = self.config.truth.sag_deg.to_radians();
        if compliance == 0.0 {
            return *r;
        }
        so3::exp(&(crate::model::sag_arm(r) * compliance)) * r
    }

    /// Encoder readings and camera measurements of the markers `which` at a pose (the joints put
    /// the platform at `r`; the camera sees it [`Simulator::sagged`]).
    fn record(&mut self, id: u64, r: &Rotation3<f64>, joints: &Vector3<f64>, which: &[usize]) -> SessionPose {
        let r = &self.sagged(r);
        let readings = self.read_encoders(joints);
        let (markers, pixels) = if self.pixels.is_some() {
            self.see_pixels(r, joints, which)
        } else {
            (self.measure_points(r, joints, which), Vec::new())
        };
        let n = markers.len();
        let body = self.config.camera.rigid_body.as_ref().and_then(|b| self.see_body(b, r, &markers));
        SessionPose {
            pixels,
            id,
            joints: readings,
            time_s: Some(id as f64 * self.config.capture.interval_s),
            markers,
            line: 0,
            marker_lines: vec![0; n],
            station: None,
            body,
        }
    }

    /// What a tracker reports of the rigid body `b` at the MP orientation `r`, in the camera's
    /// frame: the true pose with its own noise, or fitted to the `measured` markers (three seen at
    /// least, else nothing) as a tracker fits a body to its markers.
    fn see_body(
        &mut self,
        b: &RigidBodySettings,
        r: &Rotation3<f64>,
        measured: &[Option<Vector3<f64>>],
    ) -> Option<BodyPose> {
        let (origin, frame) = body_frame(b);
        // The MP's pose in the camera's frame: the truth, or the markers' best fit.
        let (rotation, translation) = match b.fitted_to_markers {
            true => fit_markers(&self.markers, measured)?,
            false => (self.camera.rotation * r, self.camera.translation),
        };
        let mut position = rotation * origin + translation;
        let mut orientation = rotation * frame;
        if !b.fitted_to_markers {
            let noise = Normal::new(0.0, b.position_sigma_m).expect("validated deviation");
            position += Vector3::from_fn(|_, _| noise.sample(&mut self.rng));
            orientation =
                so3::exp(&random_rotation_vector(b.orientation_sigma_deg.to_radians(), &mut self.rng)) * orientation;
        }
        Some(BodyPose { position, rotation: orientation, line: 0 })
    }

    /// What each camera of the rig sees of the markers `which` at a pose — the pixels of every
    /// camera whose line of sight the mechanism leaves free — and the points the rig's file
    /// triangulates from them (a marker two cameras or more saw).
    fn see_pixels(
        &mut self,
        r: &Rotation3<f64>,
        joints: &Vector3<f64>,
        which: &[usize],
    ) -> (Vec<Option<Vector3<f64>>>, Vec<SeenPixel>) {
        let rotations = self.scene.body_rotations(&self.spm, joints, r);
        let radius = self.config.camera.marker_radius_m;
        let lens = self.viewpoints();
        let Simulator { pixels: Some(cameras), rng, summary, scene, camera, .. } = self else {
            unreachable!("called with a rig")
        };
        let mut markers = vec![None; self.markers.len()];
        let mut seen = Vec::new();
        for &k in which {
            let point = r * self.markers[k];
            let in_c = camera.to_camera(&point);
            for (c, l) in lens.iter().enumerate() {
                if scene.occluder(&rotations, &point, l, radius).is_some() {
                    summary.markers_occluded += 1;
                    continue;
                }
                match cameras.see(c, &in_c, rng) {
                    Sighting::Pixel(pixel, outlier) => {
                        summary.pixels_seen += 1;
                        summary.outliers += usize::from(outlier);
                        seen.push(SeenPixel { marker: k, camera: c, pixel, line: 0 });
                    }
                    Sighting::Lost => summary.pixels_outside_image += 1,
                }
            }
        }
        // As the session's reader will: the same function, the same pixels, the same rig.
        for (k, point, _) in triangulate(&cameras.file, &seen).points {
            markers[k] = Some(point);
            summary.markers_seen += 1;
        }
        (markers, seen)
    }

    /// The camera's measurements of the markers `which` at a pose (`None`: hidden).
    fn measure_points(
        &mut self,
        r: &Rotation3<f64>,
        joints: &Vector3<f64>,
        which: &[usize],
    ) -> Vec<Option<Vector3<f64>>> {
        let rotations = self.scene.body_rotations(&self.spm, joints, r);
        let cam = &self.config.camera;
        let lens = lenses(&self.camera, cam.baseline_m);
        let mut markers = vec![None; self.markers.len()];
        for &k in which {
            let point = r * self.markers[k];
            if lens.iter().any(|l| self.scene.occluder(&rotations, &point, l, cam.marker_radius_m).is_some()) {
                self.summary.markers_occluded += 1;
                continue;
            }
            let m = cam.measure(&point, &self.camera, &mut self.rng);
            self.summary.markers_seen += 1;
            self.summary.outliers += usize::from(m.outlier);
            markers[k] = Some(m.position);
        }
        markers
    }
}
