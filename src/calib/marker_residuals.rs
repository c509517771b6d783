//! The marker-level model: every marker observation with the encoder reading of its own capture.
//!
//! A marker `k` seen at a capture with joint readings `θ` is predicted at
//! `x̂ = K (R_CB R(θ) p_k + t_CB)` (camera frame), `R(θ)` the working-mode FDA and `K` the camera
//! model (`model/camera.rs`; identity for a perfect camera); the residual is `r = x_C − x̂`
//! (metres). Nothing is estimated per pose, so a capture may see one marker or all,
//! and the markers' positions `p_k` on the MP are parameters like the mechanism's.
//!
//! Derivatives (perturbations on the left, `R ← exp(ε) R` in B), all but the camera model's
//! carried through `K`: `dr = K R_CB [R p_k]× dω` for the mechanism (`dω = −Ã⁻¹ F_x dx`, as in the
//! orientation-level model), `dr = K [R_CB R p_k]× J_l(c) dc` for `R_CB = exp(c) R_CB⁰`,
//! `dr = −K dt` for `t_CB`, `dr = −K R_CB R dp_k` for the marker and `dr = −(∂K/∂κ) y dκ` for a
//! camera-model term `κ`, `y = R_CB R p_k + t_CB`.
//!
//! A rigid body (motion capture) gives per capture its origin `o` and orientation `Q` (body →
//! tracker, the tracker's frame standing for C). Its origin is a point of the MP like a marker
//! (`p_0`, fitted, the body's name for the marker's); its orientation a rotation residual
//! `r = log(Q A R(θ)ᵀ R_CBᵀ)` (radians, as the orientation level's), with `A` (P → body frame,
//! the transpose of the body frame's rotation on the MP) fitted: the reference rotation's entries
//! stand for it. Derivatives as at the orientation level (`J_l` the left Jacobian):
//! `dr = −J_l⁻¹(r) M R_CB dω` for the mechanism and the clock, `dr = −J_l⁻¹(r) M J_l(c) dc` for
//! `R_CB`, `dr = J_l⁻¹(r) Q J_l(a) da` for `A` (`M = Q A Rᵀ R_CBᵀ`). A tracker's noise has no
//! line of sight: a body's positions share one σ (m), its orientations another (rad).
//!
//! Noise: a stereo camera triangulates depth worse than it measures across the line of sight. A
//! pixel subtends `d / f`, so the lateral error grows with the distance `d`; the depth error
//! grows with its square (`∝ d² / (f · baseline)`). The covariance of an observation along the
//! unit line of sight `ℓ` is `σ_l² (d/d₀)² (I − ℓℓᵀ) + σ_d² (d/d₀)⁴ ℓℓᵀ`; `σ_l`, `σ_d` (at the
//! reference distance `d₀`) are estimated from the residuals.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};
use serde::Serialize;

use super::config::FitLevel;
use super::parameterisation::{Kind, Parameterisation};
use super::residuals::{EvalError, Evaluation, Residuals};
use super::rig_terms;
use super::sensitivity::{Frames, through_sag};
use crate::dataset::{Session, Streams};
use crate::math::so3;
use crate::model::{CameraModel, FdaError, Rig, RigProjection, Spm};

/// One marker seen at one capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerObservation {
    /// Pose (capture) id.
    pub pose: u64,
    /// Marker index (as in the session's `markers`).
    pub marker: usize,
    /// The capture's joint readings.
    pub joints: Vector3<f64>,
    /// Measured position in the camera frame (m); for a pixel, `(u, v, 0)` (px).
    pub measured: Vector3<f64>,
    /// The camera of the session's rig that saw it at the pixel `measured` (`None`: a point).
    pub camera: Option<usize>,
    /// Line of `markers.csv` (0 when not read from a file).
    pub line: usize,
    /// The capture's station, when recorded.
    pub station: Option<u64>,
    /// The capture's time on the camera's clock (s), when recorded: with a free-motion
    /// recording's streams, the joints are interpolated at this time less the latency.
    pub time_s: Option<f64>,
    /// A rigid body's orientation: `measured` is then the rotation vector of the body frame's
    /// measured orientation (body → tracker, rad), not a position (`marker` is the body's 0).
    pub rotation: bool,
}

impl MarkerObservation {
    /// Every marker observation of `session`, pose by pose — its pixels when it is seen
    /// through a rig, else its points — and the poses whose FDA fails on `spm` (left out, with
    /// the error).
    pub fn of_session(session: &Session, spm: &Spm) -> (Vec<MarkerObservation>, Vec<(u64, FdaError)>) {
        Self::collect(session, spm, session.rig.is_some())
    }

    fn collect(session: &Session, spm: &Spm, pixels: bool) -> (Vec<MarkerObservation>, Vec<(u64, FdaError)>) {
        let (mut kept, mut failed) = (Vec::new(), Vec::new());
        let seen = |p: &crate::dataset::SessionPose| match (pixels, p.body) {
            (true, _) => p.pixels.len(),
            (false, Some(_)) => 2,
            (false, None) => p.seen(),
        };
        for pose in session.poses.iter().filter(|p| seen(p) > 0) {
            if let Err(e) = spm.forward(&pose.joints) {
                failed.push((pose.id, e));
                continue;
            }
            let observation = |marker, measured, camera, line| MarkerObservation {
                pose: pose.id,
                marker,
                joints: pose.joints,
                measured,
                camera,
                line,
                station: pose.station,
                time_s: pose.time_s,
                rotation: false,
            };
            if let Some(body) = &pose.body {
                // The body's origin as the point of marker 0, then its orientation.
                kept.push(observation(0, body.position, None, body.line));
                let rotation = so3::log(&body.rotation);
                kept.push(MarkerObservation { rotation: true, ..observation(0, rotation, None, body.line) });
            } else if pixels {
                kept.extend(pose.pixels.iter().map(|seen| {
                    let measured = Vector3::new(seen.pixel.x, seen.pixel.y, 0.0);
                    observation(seen.marker, measured, Some(seen.camera), seen.line)
                }));
            } else {
                for (marker, seen) in pose.markers.iter().enumerate() {
                    if let Some(measured) = seen {
                        kept.push(observation(marker, *measured, None, pose.marker_lines[marker]));
                    }
                }
            }
        }
        (kept, failed)
    }
}

/// Per pose, the RMS of the residuals of its marker observations times `scale` (1e3: metres to
/// millimetres; 1 for pixels), in the observations' order (they come pose by pose, as
/// [`MarkerObservation::of_session`] makes them).
pub(crate) fn per_pose_rms(
    observations: &[MarkerObservation],
    residuals: &[Vector3<f64>],
    scale: f64,
) -> Vec<(u64, f64)> {
    let mut poses: Vec<(u64, f64, usize)> = Vec::new();
    // A body's orientations are in radians: the positions say the size in `scale`'s unit.
    for (o, r) in observations.iter().zip(residuals).filter(|(o, _)| !o.rotation) {
        let squared = (r.norm() * scale).powi(2);
        match poses.last_mut() {
            Some((pose, sum, n)) if *pose == o.pose => {
                *sum += squared;
                *n += 1;
            }
            _ => poses.push((o.pose, squared, 1)),
        }
    }
    poses.into_iter().map(|(pose, sum, n)| (pose, (sum / n as f64).sqrt())).collect()
}

/// The stereo noise model: standard deviations across and along the line of sight at the
/// reference distance, with their standard errors.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StereoNoise {
    /// Distance at which the σ's hold (the median distance of the observations), m.
    pub reference_distance_m: f64,
    /// σ across the line of sight (per axis), m.
    pub lateral_m: f64,
    /// Its standard error, m.
    pub lateral_std_error_m: f64,
    /// σ along the line of sight, m.
    pub depth_m: f64,
    /// Its standard error, m.
    pub depth_std_error_m: f64,
    /// A pixel session's σ per pixel coordinate of each camera of its rig (px; empty for points).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub pixel_px: Vec<f64>,
    /// Their standard errors (px).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub pixel_std_error_px: Vec<f64>,
    /// A rigid body's position noise, σ per axis (m; `None` for markers): a tracker's has no
    /// line of sight.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_position_m: Option<f64>,
    /// Its standard error (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_position_std_error_m: Option<f64>,
    /// A rigid body's orientation noise, σ per axis of the rotation vector (rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_orientation_rad: Option<f64>,
    /// Its standard error (rad).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_orientation_std_error_rad: Option<f64>,
    /// A rigid body's position and orientation covariances in the tracker's frame (m², rad²),
    /// which whiten its residuals: a tracker's noise differs by direction as a camera's does
    /// (its σ's above are their per-axis RMS).
    #[serde(skip)]
    pub body_covariances: Option<[Matrix3<f64>; 2]>,
}

impl StereoNoise {
    /// A camera's noise for points: `lateral_m` across and `depth_m` along the line of sight at
    /// `reference_distance_m` (m), known exactly (no standard errors), no pixels, no rigid body.
    pub fn points(reference_distance_m: f64, lateral_m: f64, depth_m: f64) -> StereoNoise {
        StereoNoise {
            reference_distance_m,
            lateral_m,
            lateral_std_error_m: 0.0,
            depth_m,
            depth_std_error_m: 0.0,
            pixel_px: Vec::new(),
            pixel_std_error_px: Vec::new(),
            body_position_m: None,
            body_position_std_error_m: None,
            body_orientation_rad: None,
            body_orientation_std_error_rad: None,
            body_covariances: None,
        }
    }
}

/// A pose's joints and their rates of change with the camera latency and with the clock's rate
/// entry (the drift over the recording, `ρ·10⁻⁶·T`).
type JointsAndRate = (Vector3<f64>, Vector3<f64>, Vector3<f64>);

/// Smallest σ the whitening uses (0.1 µm): noise-free data must not divide by zero.
const SIGMA_FLOOR_M: f64 = 1e-7;

/// The same for a pixel (a thousandth of a pixel).
const PIXEL_SIGMA_FLOOR_PX: f64 = 1e-3;

/// The same for a body's orientation (0.1 µrad).
const ROTATION_SIGMA_FLOOR_RAD: f64 = 1e-7;

/// The Huber threshold of a body's noise estimate, in robust σ's of a residual's norm: the
/// fit's default. A Gaussian 3-vector's norm passes 3σ with probability 2.9 %: the estimate is
/// then 0.5 % low (Monte Carlo, 2·10⁶ draws), far inside its standard error (the fit's own
/// weights, see `body_noise`, are not).
const BODY_HUBER: f64 = 3.0;

/// The marker-level model over a set of observations.
#[derive(Debug)]
pub struct MarkerResiduals<'a> {
    /// The parameters (a `Parameterisation::for_markers`).
    pub p: &'a Parameterisation,
    /// The observations, grouped by pose (consecutive).
    observations: std::borrow::Cow<'a, [MarkerObservation]>,
    /// Index of each observation's pose in `poses`.
    pose_of: Vec<usize>,
    /// Id, joint readings and camera time of each distinct pose.
    poses: Vec<(u64, Vector3<f64>, Option<f64>)>,
    /// Median distance of the observations from the camera.
    reference_distance: f64,
    /// The Jacobian columns computed (the others stay zero): a fit of the registration alone
    /// needs none of the mechanism's derivatives, which are most of the cost.
    columns: Option<Vec<bool>>,
    /// A Jacobian the fit gave back, reused by the next evaluation.
    spare: std::cell::RefCell<Option<DMatrix<f64>>>,
    /// A free-motion recording's streams: with a latency parameter, each pose's joints are
    /// interpolated at the encoders' time of its stamp (the parameters' camera clock).
    streams: Option<&'a Streams>,
    /// Per observation, the factor its noise is inflated by (captures taken while the joystick
    /// moved too fast); empty: none.
    inflation: Vec<f64>,
    /// Whether the observations are a rigid body's (positions and orientations).
    body: bool,
}

impl Clone for MarkerResiduals<'_> {
    /// A copy without the spare Jacobian (it is only storage to reuse).
    fn clone(&self) -> Self {
        MarkerResiduals {
            observations: self.observations.clone(),
            pose_of: self.pose_of.clone(),
            poses: self.poses.clone(),
            columns: self.columns.clone(),
            spare: Default::default(),
            inflation: self.inflation.clone(),
            ..*self
        }
    }
}

impl<'a> MarkerResiduals<'a> {
    /// The model of `observations` (consecutive observations of a pose share its FDA).
    pub fn new(p: &'a Parameterisation, observations: &'a [MarkerObservation]) -> Self {
        Self::of(p, std::borrow::Cow::Borrowed(observations))
    }

    fn of(p: &'a Parameterisation, observations: std::borrow::Cow<'a, [MarkerObservation]>) -> Self {
        let mut poses: Vec<(u64, Vector3<f64>, Option<f64>)> = Vec::new();
        let mut pose_of = Vec::with_capacity(observations.len());
        for o in observations.iter() {
            if poses.last().is_none_or(|(id, joints, _)| *id != o.pose || *joints != o.joints) {
                poses.push((o.pose, o.joints, o.time_s));
            }
            pose_of.push(poses.len() - 1);
        }
        let mut distances: Vec<f64> =
            observations.iter().filter(|o| o.camera.is_none() && !o.rotation).map(|o| o.measured.norm()).collect();
        distances.sort_by(f64::total_cmp);
        let reference_distance = distances.get(distances.len() / 2).copied().unwrap_or(1.0).max(1e-3);
        let body = observations.iter().any(|o| o.rotation);
        MarkerResiduals {
            p,
            observations,
            pose_of,
            poses,
            reference_distance,
            columns: None,
            spare: Default::default(),
            streams: None,
            inflation: Vec::new(),
            body,
        }
    }

    /// The same model reading each pose's joints from `streams` at its time less the latency
    /// (when the parameterisation has one).
    pub fn with_streams(mut self, streams: &'a Streams) -> Self {
        self.streams = Some(streams);
        self
    }

    /// The same model with each observation's noise inflated by `factors` (≥ 1, one per observation).
    pub fn with_inflation(mut self, factors: Vec<f64>) -> Self {
        self.inflation = factors;
        self
    }

    fn inflation(&self, j: usize) -> f64 {
        self.inflation.get(j).copied().unwrap_or(1.0)
    }

    /// The recording's streams the model reads, if any.
    pub fn streams(&self) -> Option<&'a Streams> {
        self.streams
    }

    /// Each pose's joints at `x` (the camera clock moves them along the encoder stream), with
    /// their rates of change with the latency and with the clock's rate entry (the drift `r·T`).
    /// A capture stamped `t` is read at `e = (t − τ) / (1 + r)`, `r = ρ·10⁻⁶`: `∂e/∂τ = −1 / (1 + r)`
    /// and `∂e/∂(rT) = −e / ((1 + r) T)`, each times the joint velocity `θ̇(e)`.
    fn joints(&self, x: &DVector<f64>) -> Result<Vec<JointsAndRate>, EvalError> {
        let latency = self.p.entries.iter().any(|e| e.kind == Kind::Latency).then(|| self.p.clock(x));
        self.poses
            .iter()
            .map(|&(pose, joints, time)| match (latency, self.streams, time) {
                (Some(clock), Some(s), Some(t)) => {
                    let e = clock.encoder_time(t);
                    match (s.joints_at(e), s.velocity_at(e)) {
                        (Some(j), Some(v)) => {
                            let stretch = 1.0 + clock.rate_ppm * 1e-6;
                            Ok((j, -v / stretch, -v * (e / (stretch * self.p.clock_rate_span_s))))
                        }
                        _ => Err(EvalError::OutsideStream {
                            pose,
                            latency_s: clock.latency_s,
                            clock_rate_ppm: clock.rate_ppm,
                        }),
                    }
                }
                _ => Ok((joints, Vector3::zeros(), Vector3::zeros())),
            })
            .collect()
    }

    fn column_needed(&self, i: usize) -> bool {
        self.columns.as_ref().is_none_or(|c| c[i])
    }

    fn mechanism_needed(&self) -> bool {
        self.p.entries.iter().enumerate().any(|(i, e)| e.kind.moves_platform() && self.column_needed(i))
    }

    /// The observations, grouped by pose.
    pub fn observations(&self) -> &[MarkerObservation] {
        &self.observations
    }

    /// Unit line of sight and distance of observation `j`.
    fn sight(&self, j: usize) -> (Vector3<f64>, f64) {
        let m = self.observations[j].measured;
        let d = m.norm().max(1e-6);
        (m / d, d)
    }

    /// The stereo σ's that the (weighted) residuals imply: across and along the line of sight for
    /// points, per camera for pixels.
    pub fn stereo_noise(&self, residuals: &[Vector3<f64>], weights: &[f64]) -> StereoNoise {
        let (mut depth, mut lateral, mut total, mut points) = (0.0, 0.0, 0.0, 0usize);
        let cameras = self.p.rig0.as_ref().map_or(0, |r| r.cameras.len());
        let (mut pixel, mut pixel_total, mut pixel_count) =
            (vec![0.0; cameras], vec![0.0; cameras], vec![0usize; cameras]);
        for (j, r) in residuals.iter().enumerate() {
            let r = r / self.inflation(j);
            if self.body {
                continue;
            }
            if let Some(c) = self.observations[j].camera {
                pixel[c] += weights[j] * r.norm_squared();
                pixel_total[c] += weights[j];
                pixel_count[c] += 1;
                continue;
            }
            let (l, d) = self.sight(j);
            let ratio = self.reference_distance / d;
            let along = l.dot(&r);
            depth += weights[j] * (along * ratio * ratio).powi(2);
            lateral += weights[j] * ((r - l * along) * ratio).norm_squared();
            total += weights[j];
            points += 1;
        }
        // Degrees of freedom: 3 per point and 2 per pixel, less one per parameter (shared pro rata).
        let rows = (3 * points + 2 * pixel_count.iter().sum::<usize>()) as f64;
        let rows = if self.body { 3.0 * residuals.len() as f64 } else { rows };
        let dof = (1.0 - self.p.len() as f64 / rows.max(1.0)).max(0.1);
        let n = points as f64;
        let total = total.max(f64::MIN_POSITIVE) * dof;
        let (depth_m, lateral_m) =
            if points > 0 { ((depth / total).sqrt(), (lateral / (2.0 * total)).sqrt()) } else { (0.0, 0.0) };
        let pixel_px: Vec<f64> =
            (0..cameras).map(|c| (pixel[c] / (2.0 * pixel_total[c].max(f64::MIN_POSITIVE) * dof)).sqrt()).collect();
        let pixel_std_error_px =
            (0..cameras).map(|c| pixel_px[c] / (4.0 * pixel_count[c] as f64).max(1.0).sqrt()).collect();
        StereoNoise {
            reference_distance_m: self.reference_distance,
            lateral_m,
            lateral_std_error_m: lateral_m / (4.0 * n).max(1.0).sqrt(),
            depth_m,
            depth_std_error_m: depth_m / (2.0 * n).max(1.0).sqrt(),
            pixel_px,
            pixel_std_error_px,
            ..self.body_noise(residuals, dof)
        }
    }

    /// A rigid body's noise (position, orientation), each from its own group's residuals, with
    /// `dof` the share of the rows left by the parameters: the covariance `Σ w r rᵀ / (Σ w · dof)`,
    /// `w` the Huber weight (at [`BODY_HUBER`] robust σ's) of the group's own robust scale, and
    /// its per-axis RMS `σ² = tr Σ / 3`;
    /// standard errors `σ / √(2 · 3n · dof)` (n rows of 3), as a variance estimated from `3n·dof`
    /// squares has. Nothing for markers. Not the fit's weights: the fit's first phase weighs
    /// metres and radians alike, its robust scale lies between the two groups', and its Huber
    /// weights would cut the orientations' larger residuals (their σ 11 % low in a test).
    fn body_noise(&self, residuals: &[Vector3<f64>], dof: f64) -> StereoNoise {
        let none = StereoNoise::points(self.reference_distance, 0.0, 0.0);
        if !self.body {
            return none;
        }
        let group = |rotation: bool| -> Vec<Vector3<f64>> {
            let of = residuals.iter().zip(self.observations.iter()).enumerate();
            of.filter(|(_, (_, o))| o.rotation == rotation).map(|(j, (r, _))| r / self.inflation(j)).collect()
        };
        let count = |rotation: bool| group(rotation).len() as f64;
        let covariance = |rotation: bool| {
            let residuals = group(rotation);
            let mut sorted: Vec<f64> = residuals.iter().map(|r| r.norm()).collect();
            sorted.sort_by(f64::total_cmp);
            // The median norm of a 3-vector of per-axis σ is 1.5382 σ.
            let scale = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0) / 1.5382;
            let limit = BODY_HUBER * scale;
            let (mut sum, mut total) = (Matrix3::zeros(), 0.0);
            for r in residuals {
                let d = r.norm();
                let w = if d > limit { limit / d } else { 1.0 };
                sum += r * r.transpose() * w;
                total += w;
            }
            sum / (f64::max(total, f64::MIN_POSITIVE) * dof)
        };
        let covariances = [covariance(false), covariance(true)];
        let [position, orientation] = covariances.map(|c| (c.trace() / 3.0).max(0.0).sqrt());
        let error = |s: f64, n: f64| s / (6.0 * n * dof).max(1.0).sqrt();
        StereoNoise {
            body_position_m: Some(position),
            body_position_std_error_m: Some(error(position, count(false))),
            body_orientation_rad: Some(orientation),
            body_orientation_std_error_rad: Some(error(orientation, count(true))),
            body_covariances: Some(covariances),
            ..none
        }
    }

    /// Whether the observations are pixels (a session seen through its rig).
    pub(crate) fn pixels(&self) -> bool {
        self.observations.first().is_some_and(|o| o.camera.is_some())
    }

    /// `Σ_j^{-1/2}` of observation `j` under `noise`.
    pub fn whitening_of(&self, j: usize, noise: &StereoNoise) -> Matrix3<f64> {
        if self.body {
            let rotation = self.observations[j].rotation;
            let floor = if rotation { ROTATION_SIGMA_FLOOR_RAD } else { SIGMA_FLOOR_M };
            let covariance = noise.body_covariances.map_or_else(Matrix3::identity, |c| c[usize::from(rotation)]);
            // Floored so that noise-free data stays defined.
            let covariance = covariance + Matrix3::identity() * floor * floor;
            return super::orientation_residuals::inverse_root(&covariance) / self.inflation(j);
        }
        if let Some(c) = self.observations[j].camera {
            let sigma = noise.pixel_px.get(c).copied().unwrap_or(1.0).max(PIXEL_SIGMA_FLOOR_PX);
            return Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) / (sigma * self.inflation(j));
        }
        let (l, d) = self.sight(j);
        let ratio = noise.reference_distance_m / d;
        let along = l * l.transpose();
        let across = Matrix3::identity() - along;
        (across * (ratio / noise.lateral_m.max(SIGMA_FLOOR_M))
            + along * (ratio * ratio / noise.depth_m.max(SIGMA_FLOOR_M)))
            / self.inflation(j)
    }
    /// The Fisher information `Σ_j (W_j J_j)ᵀ (W_j J_j)` of the observations at `x` under `noise`
    /// (`W_j` the whitening, `J_j` the Jacobian of observation `j`), summed per pose:
    /// `(pose id, information)` in the model's pose order.
    ///
    /// # Errors
    /// An [`EvalError`] when the model cannot be evaluated at `x`.
    ///
    /// # Panics
    /// Never: the evaluation is asked for its Jacobian.
    pub fn information_per_pose(
        &self,
        x: &DVector<f64>,
        noise: &StereoNoise,
    ) -> Result<Vec<(u64, DMatrix<f64>)>, EvalError> {
        let evaluation = self.evaluate(x, None, true)?;
        let jacobian = evaluation.jacobian.as_ref().expect("asked for the Jacobian");
        let n = self.p.len();
        let mut out: Vec<(u64, DMatrix<f64>)> =
            self.poses.iter().map(|(id, _, _)| (*id, DMatrix::zeros(n, n))).collect();
        for j in 0..self.observations.len() {
            let block = self.whitening_of(j, noise) * jacobian.rows(3 * j, 3);
            out[self.pose_of[j]].1 += block.transpose() * &block;
        }
        Ok(out)
    }
}

impl Residuals for MarkerResiduals<'_> {
    type Noise = StereoNoise;

    fn parameterisation(&self) -> &Parameterisation {
        self.p
    }

    fn len(&self) -> usize {
        self.observations.len()
    }

    fn rows(&self, j: usize) -> usize {
        if self.observations[j].camera.is_some() { 2 } else { 3 }
    }

    fn with_columns(mut self, columns: Vec<bool>) -> Self {
        self.columns = Some(columns);
        self
    }

    fn subset(&self, rows: &[usize]) -> Self {
        let observations: Vec<MarkerObservation> = rows.iter().map(|&j| self.observations[j]).collect();
        let mut model = MarkerResiduals::of(self.p, std::borrow::Cow::Owned(observations));
        model.streams = self.streams;
        model.columns.clone_from(&self.columns);
        // A subset of a body's positions alone is still a body's.
        model.body = self.body;
        if !self.inflation.is_empty() {
            model.inflation = rows.iter().map(|&j| self.inflation[j]).collect();
        }
        model
    }

    fn group(&self, j: usize) -> (bool, u64) {
        let o = &self.observations[j];
        o.station.map_or((false, o.pose), |s| (true, s))
    }

    fn is_orientation(&self, j: usize) -> bool {
        self.observations[j].rotation
    }

    fn pose_of(&self, j: usize) -> usize {
        self.pose_of[j]
    }

    fn observed(&self, x: &DVector<f64>) -> Vec<super::residuals::Observed> {
        // A frame the clock at `x` puts outside the stream keeps its recorded joints (the fit would
        // not have ended there).
        let at_clock = self.joints(x).ok();
        self.observations
            .iter()
            .enumerate()
            .map(|(j, o)| super::residuals::Observed {
                point: (o.camera.is_none() && !o.rotation).then_some(o.measured),
                pixel: o.camera.map(|c| (c, [o.measured.x, o.measured.y])),
                joints: at_clock.as_ref().map_or(o.joints, |poses| poses[self.pose_of[j]].0),
                time_s: o.time_s,
                marker: Some(o.marker),
            })
            .collect()
    }

    fn poses(&self) -> usize {
        self.poses.len()
    }

    fn estimate_noise(&self, residuals: &[Vector3<f64>], weights: &[f64]) -> StereoNoise {
        self.stereo_noise(residuals, weights)
    }

    fn whitening(&self, noise: &StereoNoise) -> Vec<Matrix3<f64>> {
        (0..self.observations.len()).map(|j| self.whitening_of(j, noise)).collect()
    }

    fn evaluate(
        &self,
        x: &DVector<f64>,
        warm: Option<&[Rotation3<f64>]>,
        with_jacobian: bool,
    ) -> Result<Evaluation, EvalError> {
        let p = self.p;
        let legs = p.legs(x);
        let spm = p.spm(x).map_err(EvalError::Geometry)?;
        let (camera, translation) = (p.camera(x), p.translation(x));
        let camera_model = p.camera_model(x);
        let markers: Vec<Vector3<f64>> = (0..p.markers0.len()).map(|k| p.marker(x, k)).collect();
        let joints = self.joints(x)?;
        let mut orientations = Vec::with_capacity(self.poses.len());
        for (k, ((pose, _, _), (theta, _, _))) in self.poses.iter().zip(&joints).enumerate() {
            let r = match warm {
                Some(w) => spm.track(theta, &w[k]),
                None => spm.forward(theta),
            }
            .map_err(|error| EvalError::Fda { pose: *pose, error })?;
            orientations.push(r);
        }
        let rig = p.rig(x);
        let body_frame = p.reference(x);
        let residuals = self
            .observations
            .iter()
            .zip(&self.pose_of)
            .map(|(o, &pose)| {
                if o.rotation {
                    let m = so3::exp(&o.measured) * body_frame * orientations[pose].inverse() * camera.inverse();
                    return Ok(so3::log(&m));
                }
                let y = camera * (orientations[pose] * markers[o.marker]) + translation;
                Ok(o.measured - observe(o, &y, &camera_model, rig.as_ref())?.0)
            })
            .collect::<Result<Vec<Vector3<f64>>, EvalError>>()?;
        let mut eval = Evaluation { residuals, orientations, jacobian: None, orientation_jacobians: None };
        if with_jacobian {
            let frames = Frames::new(p, x);
            let mechanism = self.mechanism_needed();
            let latency = p.entries.iter().position(|e| e.kind == Kind::Latency);
            let clock_rate = p.entries.iter().position(|e| e.kind == Kind::ClockRate);
            let sag = p.entries.iter().position(|e| e.kind == Kind::PlatformSag).filter(|_| mechanism);
            let sensitivities: Vec<DMatrix<f64>> = joints
                .iter()
                .zip(&eval.orientations)
                .map(|((theta, per_latency, per_rate), r)| {
                    let rigid = spm.rigid(r);
                    let mut s = match mechanism {
                        true => frames.orientation_sensitivity(&spm, &legs, theta, &rigid),
                        false => DMatrix::zeros(3, p.len()),
                    };
                    // ∂ω/∂τ = J(θ) ∂θ/∂τ, J = A⁻¹B mapping joint rates to the MP's angular
                    // velocity; the same for the clock's rate.
                    if latency.is_some() || clock_rate.is_some() {
                        let forward = spm.jacobians(theta, &rigid).forward();
                        for (i, rate) in [(latency, per_latency), (clock_rate, per_rate)] {
                            if let (Some(i), Some(j)) = (i, forward) {
                                s.set_column(i, &(j * rate));
                            }
                        }
                    }
                    through_sag(&spm, &rigid, &mut s, sag);
                    s
                })
                .collect();
            eval.jacobian = Some(self.jacobian(x, &camera, &markers, &eval.orientations, &sensitivities));
            eval.orientation_jacobians = Some(sensitivities);
        }
        Ok(eval)
    }

    fn recycle(&self, old: Evaluation) {
        if let Some(jacobian) = old.jacobian {
            *self.spare.borrow_mut() = Some(jacobian);
        }
    }

    fn unit_scale(&self) -> f64 {
        if self.pixels() { 1.0 } else { 1e3 }
    }

    /// A body's positions alone (its orientations are in radians, reported on their own).
    fn report_rms(&self, residuals: &[Vector3<f64>]) -> f64 {
        if !self.body || residuals.len() != self.observations.len() {
            return super::residuals::rms(residuals) * self.unit_scale();
        }
        let positions = residuals.iter().zip(self.observations.iter()).filter(|(_, o)| !o.rotation);
        crate::math::stats::rms(positions.map(|(r, _)| r.norm())) * self.unit_scale()
    }

    fn unit(&self) -> &'static str {
        if self.pixels() { "px" } else { "mm" }
    }

    fn level(&self) -> FitLevel {
        FitLevel::Markers
    }
}

impl MarkerResiduals<'_> {
    /// `∂r/∂x`, `3n × N`.
    fn jacobian(
        &self,
        x: &DVector<f64>,
        camera: &Rotation3<f64>,
        markers: &[Vector3<f64>],
        orientations: &[Rotation3<f64>],
        sensitivities: &[DMatrix<f64>],
    ) -> DMatrix<f64> {
        let p = self.p;
        let jc = so3::left_jacobian(&p.registration_vectors(x).0);
        let (camera_model, translation) = (p.camera_model(x), p.translation(x));
        let rig = p.rig(x);
        let rig_derivatives = rig_terms::PixelDerivatives::new(p, x);
        let mechanism = self.mechanism_needed();
        let shape = (3 * self.observations.len(), p.len());
        let mut jac = match self.spare.take() {
            Some(mut spare) if spare.shape() == shape => {
                spare.fill(0.0);
                spare
            }
            _ => DMatrix::zeros(shape.0, shape.1),
        };
        let ja = so3::left_jacobian(&p.registration_vectors(x).1);
        let body_frame = p.reference(x);
        for (j, o) in self.observations.iter().enumerate() {
            let pose = self.pose_of[j];
            if o.rotation {
                let measured = so3::exp(&o.measured);
                let m = measured * body_frame * orientations[pose].inverse() * camera.inverse();
                let jl_inv = so3::left_jacobian_inverse(&so3::log(&m));
                let (mech, m_c) = (-(jl_inv * m.matrix() * camera.matrix()), -(jl_inv * m.matrix() * jc));
                let reference = jl_inv * measured.matrix() * ja;
                let mut block = jac.fixed_rows_mut::<3>(3 * j);
                if mechanism {
                    block.gemm(1.0, &mech, &sensitivities[pose], 0.0);
                }
                for (i, e) in p.entries.iter().enumerate().filter(|(i, _)| self.column_needed(*i)) {
                    let column: Vector3<f64> = match e.kind {
                        Kind::Camera { k: axis } => m_c.column(axis).into(),
                        Kind::Reference { k: axis } => reference.column(axis).into(),
                        Kind::Latency | Kind::ClockRate if !mechanism => mech * sensitivities[pose].column(i),
                        _ => continue,
                    };
                    block.set_column(i, &column);
                }
                continue;
            }
            let rp = orientations[pose] * markers[o.marker];
            let y = camera * rp + translation;
            // Evaluated before: the observation projects.
            let Ok((_, k, projection)) = observe(o, &y, &camera_model, rig.as_ref()) else { continue };
            let mech = k * camera.matrix() * rp.cross_matrix();
            let in_camera = k * (camera * rp).cross_matrix() * jc;
            let rotation = k * camera.matrix() * orientations[pose].matrix();
            let mut block = jac.fixed_rows_mut::<3>(3 * j);
            // The mechanism's (and the camera clock's) columns in one product (∂ω/∂x is zero in the
            // others), then the rest.
            if mechanism {
                block.gemm(1.0, &mech, &sensitivities[pose], 0.0);
            }
            for (i, e) in p.entries.iter().enumerate().filter(|(i, _)| self.column_needed(*i)) {
                let column: Vector3<f64> = match e.kind {
                    Kind::Camera { k: axis } => in_camera.column(axis).into(),
                    Kind::Translation { k: axis } => -k.column(axis),
                    Kind::Marker { marker, k: axis } if marker == o.marker => -rotation.column(axis),
                    Kind::CameraTerm { term } if o.camera.is_none() => -camera_model.term_derivative(term, &y),
                    Kind::Latency | Kind::ClockRate if !mechanism => mech * sensitivities[pose].column(i),
                    _ => continue,
                };
                block.set_column(i, &column);
            }
            if let (Some(c), Some(projection), Some(derivatives)) = (o.camera, projection, &rig_derivatives) {
                for (i, d) in derivatives.of(c, &y, &projection) {
                    if self.column_needed(i) {
                        block.set_column(i, &-Vector3::new(d.x, d.y, 0.0));
                    }
                }
            }
        }
        jac
    }
}

/// A prediction, its derivative with respect to the point, and a pixel's projection.
type Observed = (Vector3<f64>, Matrix3<f64>, Option<RigProjection>);

/// What observation `o` predicts for the point `y` (cam0's frame): the position the camera model
/// reports, or the pixel (`(u, v, 0)`) where its camera of `rig` sees it; with `∂/∂y` and the
/// pixel's projection.
fn observe(
    o: &MarkerObservation,
    y: &Vector3<f64>,
    camera_model: &CameraModel,
    rig: Option<&Rig>,
) -> Result<Observed, EvalError> {
    match (o.camera, rig) {
        (Some(c), Some(rig)) => {
            let q = rig.project(c, y).ok_or(EvalError::BehindCamera { pose: o.pose, camera: c })?;
            let mut d = Matrix3::zeros();
            d.fixed_rows_mut::<2>(0).copy_from(&q.d_cam0);
            Ok((Vector3::new(q.lens.pixel.x, q.lens.pixel.y, 0.0), d, Some(q)))
        }
        _ => Ok((camera_model.distort(y), camera_model.jacobian(y), None)),
    }
}
