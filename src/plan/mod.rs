//! Capture planning (`spmcal plan`): which N poses to capture, in what order, and the accuracy
//! they will buy.
//!
//! Candidates are drawn from the workspace as the simulator draws poses and kept when they pass
//! its checks (working mode, away from singularities, no link collisions), each with the markers
//! the camera sees (`Candidate::draw`). Each candidate's Fisher information for the
//! marker-level fit and the workspace weighting are in `information`; the I-optimal design —
//! the poses that minimise the mean predicted orientation variance over the workspace after
//! calibration, on the report's definition (the rotations common to every pose left out) —
//! continuous by the cone program for small fresh candidate sets, else by the
//! multiplicative algorithm (`design`), rounded and improved by exchanges (`design::exact`); the
//! capture order by `route::tour`.

mod design;
mod file;
mod information;
mod route;

use nalgebra::{DMatrix, Rotation3, Vector3};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use serde::Serialize;

pub(crate) use design::information_of;
pub(crate) use design::{cone_program, criterion, exact, log_det, multiplicative};
pub use file::PlannedPose;
pub(crate) use information::{Information, orientation_errors};
pub(crate) use route::tour;

use crate::calib::{
    CalibConfig, JOINT_SCALE_AUTO_MOST_STD_ERROR, Kind, MarkerObservation, MarkerResiduals, Parameterisation,
    marker_pose_errors,
};
use crate::dataset::Session;
use crate::model::{CameraModelKind, Parameters, RobotModel};
use crate::sim::{Candidate, SimConfig};

/// What to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanSettings {
    /// Poses to choose.
    pub poses: usize,
    /// Candidates to draw from the workspace.
    pub candidates: usize,
    /// The multiplicative algorithm stops when no candidate's directional derivative exceeds the
    /// design's by more than this fraction (the equivalence theorem's bound).
    pub tolerance: f64,
    /// ... or after this many iterations.
    pub max_iterations: usize,
    /// Random N-pose designs drawn to compare the plan with.
    pub random_draws: usize,
    /// Candidates must pass the workspace checks and keep their markers visible this far beyond
    /// them (tilt outwards, yaw either way), degrees: the real mechanism, camera and hand are
    /// about that far from the model (a plan of the model's extreme poses loses some to
    /// collisions and occlusion otherwise).
    pub margin_deg: f64,
    /// The camera model the calibration will fit (as `calibrate`'s `camera_model`): its terms
    /// take their share of the information.
    pub camera_model: CameraModelKind,
}

impl Default for PlanSettings {
    fn default() -> Self {
        PlanSettings {
            poses: 40,
            candidates: 2000,
            tolerance: 0.01,
            max_iterations: 2000,
            random_draws: 50,
            margin_deg: 2.0,
            camera_model: CameraModelKind::DepthScale,
        }
    }
}

/// The most candidates a plan draws: each holds its information (about 27 kB of memory in all at
/// N = 33 parameters), and every iteration of the continuous design visits each.
const MAX_CANDIDATES: usize = 20_000;

/// The most poses a plan chooses: each sweep of the exchanges tries every chosen pose, so the
/// time grows as the square of the poses (400 poses: a minute and a half on 2,000 candidates).
const MAX_POSES: usize = 1_000;

impl PlanSettings {
    /// Every setting within its range, in the command line's terms.
    fn check(&self) -> Result<(), PlanError> {
        let setting = |option, reason| Err(PlanError::Setting { option, reason });
        if self.poses == 0 {
            return setting("--poses", "a plan needs at least one pose".into());
        }
        if self.poses > MAX_POSES {
            return setting(
                "--poses",
                format!(
                    "must be at most {MAX_POSES} (got {}): plan a session of at most {MAX_POSES} poses, and `--augment` it with another plan if more are wanted",
                    self.poses
                ),
            );
        }
        if !(1..=MAX_CANDIDATES).contains(&self.candidates) {
            return setting("--candidates", format!("must be from 1 to {MAX_CANDIDATES} (got {})", self.candidates));
        }
        if self.poses > self.candidates {
            let reason = format!(
                "{} poses cannot be chosen from {} candidates: ask for at most {} poses or more `--candidates`",
                self.poses, self.candidates, self.candidates
            );
            return setting("--poses", reason);
        }
        if !(self.margin_deg.is_finite() && (0.0..=20.0).contains(&self.margin_deg)) {
            return setting("--margin-deg", format!("must be from 0 to 20 degrees (got {})", self.margin_deg));
        }
        Ok(())
    }
}

/// Why no plan could be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    #[error(
        "only {found} candidate poses pass the workspace checks (asked for {wanted} poses): loosen `workspace` in the config"
    )]
    /// Too few candidates pass the simulator's checks.
    TooFewCandidates {
        /// Candidates found.
        found: usize,
        /// Poses asked for.
        wanted: usize,
    },
    #[error("{option}: {reason}")]
    /// A setting is out of its range (checked before any work).
    Setting {
        /// The command-line option, e.g. `--poses`.
        option: &'static str,
        /// What is wrong with its value.
        reason: String,
    },
    #[error("no candidate lets the camera see marker `{0}`: its position cannot be calibrated")]
    /// A marker no candidate shows.
    UnseenMarker(String),
    #[error("the parameters cannot be evaluated: {0}")]
    /// The model, the parameters or the session cannot be used.
    Model(#[from] crate::calib::SetError),
    #[error("even all {0} candidates together leave some parameter undetermined")]
    /// The information of every candidate together is singular.
    Singular(usize),
    #[error("the {0} poses chosen leave some parameter undetermined: ask for more poses")]
    /// The information of the chosen design is singular.
    SingularPlan(usize),
}

/// Predicted orientation error after calibration over the workspace (degrees): RMS and worst, on
/// the calibration report's definition (`predicted_error_deg`: up to the rotations common to every
/// pose, which no measurement sees and `compare` fits).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Predicted {
    /// RMS over the workspace of the orientation error's norm, `√(tr(L M⁻¹))`.
    pub rms_deg: f64,
    /// The worst workspace pose.
    pub worst_deg: f64,
    /// The D-criterion `log det M`.
    pub log_det: f64,
}

/// What the plan buys, beside N random poses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanSummary {
    /// Poses planned.
    pub poses: usize,
    /// Candidates it chose from.
    pub candidates: usize,
    /// Parameters of the marker-level fit (the joint scales not counted: see
    /// `joint_scale_std_errors`).
    pub parameters: usize,
    /// The continuous optimum scaled to N poses (a bound no N-pose plan can beat).
    pub continuous_optimum: Predicted,
    /// What found the continuous design: the cone program (small candidate sets) or the
    /// multiplicative algorithm.
    pub solver: &'static str,
    /// Equivalence-theorem ratio of the continuous design (1 at the optimum).
    pub equivalence_ratio: f64,
    /// Iterations of the solver.
    pub iterations: usize,
    /// Candidates carrying weight in the continuous design (above 1/(100 N)).
    pub support: usize,
    /// The plan.
    pub plan: Predicted,
    /// The plan's I-efficiency: continuous optimum over the plan's criterion (≤ 1).
    pub efficiency: f64,
    /// Exchanges made after rounding.
    pub exchanges: usize,
    /// N random reachable poses (mean criterion over the draws).
    pub random: Predicted,
    /// Random poses needed for the plan's mean accuracy (`None`: more than the candidates).
    pub random_poses_needed: Option<usize>,
    /// Joystick travel of the tour from home through the plan and back, degrees.
    pub travel_deg: f64,
    /// The session the plan adds to, with its poses.
    pub augments: Option<(String, usize)>,
    /// The camera model planned for: the one asked for, or rigid when the candidates cannot
    /// determine its terms.
    pub camera_model: CameraModelKind,
    /// The predicted standard error of each camera-model term after the plan.
    pub camera_std_errors: Vec<(String, f64)>,
    /// What the calibration's report will predict for these poses (its `predicted_error_deg`, whose
    /// workspace is the session's own poses), degrees, at the parameters planned around: the
    /// same definition as `plan.rms_deg`, over the planned poses instead of the whole workspace
    /// (a plan puts its poses where they teach most, often where the error is largest).
    pub report_prediction_deg: Option<f64>,
    /// Why the plan is for another camera model than the one asked for, or which of its terms
    /// the plan barely sees.
    pub camera_note: Option<String>,
    /// The predicted standard error of each joint scale after the plan (`φ = sθ + δ`; a scale
    /// determined no better than `calibrate`'s `joint_scales: auto` needs is held there).
    pub joint_scale_std_errors: Vec<(String, f64)>,
}

/// A capture plan.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The poses in capture order.
    pub poses: Vec<PlannedPose>,
    /// What it buys.
    pub summary: PlanSummary,
    /// The candidates it chose from.
    pub(crate) candidates: Vec<Candidate>,
    /// Predicted orientation error after calibration at each candidate (degrees): the map of the
    /// plan's accuracy over the workspace.
    pub(crate) uncertainty_deg: Vec<f64>,
}

/// A camera-model term is seen when the plan determines it to this (a scale to 0.5%): a depth
/// error of 2% is then read to a quarter of itself, and what is left costs the fit little
/// (`examples/camera_model`).
const CAMERA_TERM_SEEN: f64 = 0.005;

impl Plan {
    /// Plan `settings.poses` poses for `model` (or `params`: geometry, registration and markers
    /// where it has them) with the workspace, camera and noise of `config`; `augment`: a session the
    /// plan adds to (its information counts, its registration is fitted when `params` has none).
    ///
    /// # Errors
    /// A [`PlanError`] when too few candidates pass the checks, a marker is never seen, the model or
    /// the session cannot be evaluated, or the parameters stay undetermined.
    pub fn design(
        model: &RobotModel,
        params: Option<&Parameters>,
        config: &SimConfig,
        settings: &PlanSettings,
        augment: Option<&Session>,
    ) -> Result<Plan, PlanError> {
        settings.check()?;
        let nominal = Parameters::nominal(&model.spm, None);
        let params = params.unwrap_or(&nominal);
        let spm = params.spm().map_err(crate::calib::SetError::Geometry)?;
        let names: Vec<String> = model.markers.iter().map(|m| m.name.clone()).collect();
        let markers: Vec<Vector3<f64>> =
            model.markers.iter().map(|m| params.marker(&m.name).unwrap_or(m.position)).collect();
        let camera = match (params.camera, augment) {
            (Some(c), _) => c,
            (None, Some(session)) => marker_pose_errors(session, model, params)?.1,
            (None, None) => config.camera.looking_down(),
        };
        let pool = Candidate::draw(
            config,
            model,
            &spm,
            &camera,
            &markers,
            settings.candidates,
            settings.margin_deg.to_radians(),
        );
        if pool.len() < settings.poses.max(2) {
            return Err(PlanError::TooFewCandidates { found: pool.len(), wanted: settings.poses });
        }
        // Where the accuracy counts: the workspace's poses as the simulator accepts them, without
        // the candidates' safety margin (the edges a plan keeps away from are still worked in).
        let unmargined = (settings.margin_deg > 0.0).then(|| {
            Candidate::draw(config, model, &spm, &camera, &markers, settings.candidates.min(WORKSPACE_POSES), 0.0)
        });
        let workspace = unmargined.as_deref().unwrap_or(&pool);
        if let Some(&k) = information::unseen_markers(&pool, markers.len()).first() {
            return Err(PlanError::UnseenMarker(names[k].clone()));
        }
        let bounds = CalibConfig::default().bounds;
        let noise = config.camera.stereo_noise();
        let n = settings.poses;
        // The camera model's terms take their share of the information; candidates that cannot
        // determine them (with every candidate taken) plan for a rigid camera, and say so.
        let mut camera_note = None;
        // The joint scales are counted apart: a calibration fits them only where the data show a
        // scale error (`joint_scales: auto`), so the plan is made, and its accuracy predicted, for
        // the mechanism without them, and says how well it would determine them.
        let (p, info, prior, with_scales) = loop {
            let kind = if camera_note.is_some() { CameraModelKind::Rigid } else { settings.camera_model };
            let camera_model = params.camera_model.with_kind(kind);
            let mut p_all =
                Parameterisation::for_markers(*spm.geometry(), &camera, &markers, &names, camera_model, &bounds);
            // A sag is fitted only where a session shows it (`platform_sag: auto`): planned for
            // without it, as the scales below.
            p_all.entries.retain(|e| e.kind != Kind::PlatformSag);
            let info_all =
                Information::of(&p_all, &camera, &pool, workspace, &noise).map_err(crate::calib::SetError::Eval)?;
            let prior_all = match augment {
                Some(session) => session_information(session, &p_all, &spm, &noise)? / n as f64,
                None => DMatrix::zeros(p_all.len(), p_all.len()),
            };
            let keep: Vec<usize> =
                (0..p_all.len()).filter(|&i| !matches!(p_all.entries[i].kind, Kind::Scale { .. })).collect();
            let info = info_all.select(&keep);
            let prior = DMatrix::from_fn(keep.len(), keep.len(), |a, b| prior_all[(keep[a], keep[b])]);
            let mut p = p_all.clone();
            p.entries.retain(|e| !matches!(e.kind, Kind::Scale { .. }));
            let every = design::weighted_sum(&info.per_candidate, &vec![1.0; pool.len()], &prior);
            if criterion(&every, &info.workspace).is_finite() {
                break (p, info, prior, (p_all, info_all.per_candidate, prior_all));
            }
            if kind == CameraModelKind::Rigid {
                return Err(PlanError::Singular(pool.len()));
            }
            camera_note = Some(format!(
                "the candidates cannot determine the `{}` camera model's terms (the poses do not move the markers in \
                 the ways that tell them from the mechanism): planned for a rigid camera",
                kind.name()
            ));
        };
        let l = &info.workspace;
        // Small fresh candidate sets: the cone program (exact to clarabel's tolerance); otherwise, or
        // should clarabel fail, the multiplicative algorithm.
        let by_cone = (augment.is_none() && pool.len() <= CONE_PROGRAM_MAX_CANDIDATES)
            .then(|| cone_program(&info.per_candidate, l).ok())
            .flatten();
        let (solver, continuous) = match by_cone {
            Some(c) if c.equivalence_ratio <= 1.0 + settings.tolerance => ("cone program (clarabel)", c),
            // Clarabel's interior point can stop short of the equivalence bound (the workspace
            // weighting leaves out the common rotations and is singular): polish its weights.
            Some(c) => {
                let polished = design::multiplicative_from(
                    &info.per_candidate,
                    l,
                    &prior,
                    c.weights,
                    settings.tolerance,
                    settings.max_iterations,
                );
                ("cone program (clarabel), polished by the multiplicative algorithm", polished)
            }
            None => (
                "multiplicative algorithm",
                multiplicative(&info.per_candidate, l, &prior, settings.tolerance, settings.max_iterations),
            ),
        };
        let chosen = exact(&info.per_candidate, l, &prior, n, &continuous.weights);
        let m_plan = information_of(&info.per_candidate, &prior, &chosen.chosen);
        let m_continuous = design::weighted_sum(&info.per_candidate, &continuous.weights, &prior) * n as f64;
        let predicted = |m: &DMatrix<f64>| {
            let covariance = m.clone().cholesky().map(|c| c.inverse());
            let errors = covariance.map(|c| orientation_errors(&info, &c)).unwrap_or_default();
            Predicted {
                rms_deg: criterion(m, l).sqrt().to_degrees(),
                worst_deg: errors.iter().copied().fold(0.0, f64::max).to_degrees(),
                log_det: log_det(m),
            }
        };
        let (random, random_poses_needed) = random_designs(&info, &prior, n, chosen.criterion, settings.random_draws);
        let rotations: Vec<Rotation3<f64>> = chosen.chosen.iter().map(|&c| pool[c].rotation).collect();
        let (order, travel) = tour(&rotations);
        let poses = order
            .iter()
            .enumerate()
            .map(|(step, &k)| {
                let c = &pool[chosen.chosen[k]];
                PlannedPose { step: step as u64 + 1, rotation: c.rotation, joints: c.joints }
            })
            .collect();
        let covariance = m_plan.clone().cholesky().map(|c| c.inverse()).ok_or(PlanError::SingularPlan(n))?;
        let uncertainty_deg = orientation_errors(&info, &covariance).iter().map(|e| e.to_degrees()).collect();
        let report_prediction_deg = {
            let sensitivities: Vec<DMatrix<f64>> =
                chosen.chosen.iter().map(|&c| info.sensitivities[c].clone()).collect();
            let ids: Vec<u64> = (0..chosen.chosen.len() as u64).collect();
            let fda = vec![true; p.len()];
            crate::calib::predicted_orientation_error(&sensitivities, &rotations, &ids, &fda, &covariance)
                .map(|e| e.rms)
        };
        let camera_std_errors = p
            .entries
            .iter()
            .enumerate()
            .filter(|(_, e)| matches!(e.kind, Kind::CameraTerm { .. }))
            .map(|(i, e)| (e.name.clone(), covariance[(i, i)].max(0.0).sqrt()))
            .collect::<Vec<_>>();
        // Each joint scale's standard error, were it fitted with the rest on the plan's poses.
        let (p_all, per_candidate_all, prior_all) = &with_scales;
        let m_all = information_of(per_candidate_all, prior_all, &chosen.chosen);
        let covariance_all = crate::math::linalg::symmetric_pseudo_inverse(&m_all, 1e-14).unwrap_or(m_all * f64::NAN);
        let joint_scale_std_errors: Vec<(String, f64)> = p_all
            .entries
            .iter()
            .enumerate()
            .filter(|(_, e)| matches!(e.kind, Kind::Scale { .. }))
            .map(|(i, e)| (e.name.clone(), covariance_all[(i, i)].max(0.0).sqrt()))
            .collect();
        let blind: Vec<String> = camera_std_errors
            .iter()
            .filter(|(_, sigma)| *sigma > CAMERA_TERM_SEEN)
            .map(|(name, sigma)| format!("{name} (±{sigma:.4})"))
            .collect();
        if !blind.is_empty() {
            camera_note = Some(format!(
                "this plan barely sees {}: beyond ±{CAMERA_TERM_SEEN} the camera model cannot correct the camera; \
                 tilt the poses further, or plan more",
                blind.join(", ")
            ));
        }
        let summary = PlanSummary {
            poses: n,
            candidates: pool.len(),
            parameters: p.len(),
            continuous_optimum: predicted(&m_continuous),
            solver,
            equivalence_ratio: continuous.equivalence_ratio,
            iterations: continuous.iterations,
            support: continuous.weights.iter().filter(|&&w| w > 0.01 / n as f64).count(),
            plan: predicted(&m_plan),
            efficiency: (continuous.criterion / n as f64) / chosen.criterion,
            exchanges: chosen.exchanges,
            random,
            random_poses_needed,
            travel_deg: travel.to_degrees(),
            augments: augment.map(|s| (s.name.clone(), s.poses.len())),
            camera_model: p.camera_model0.kind,
            camera_std_errors,
            report_prediction_deg,
            camera_note,
            joint_scale_std_errors,
        };
        Ok(Plan { poses, summary, candidates: pool, uncertainty_deg })
    }

    /// The plan as a session (its poses, numbered by step, with the joint readings the model
    /// expects and no markers), for recordings.
    pub fn session(&self, model: &RobotModel) -> Session {
        let markers = model.markers.len();
        let poses = self
            .poses
            .iter()
            .map(|p| crate::dataset::SessionPose {
                pixels: Vec::new(),
                id: p.step,
                joints: p.joints,
                time_s: None,
                markers: vec![None; markers],
                line: 0,
                marker_lines: vec![0; markers],
                station: None,
                body: None,
            })
            .collect();
        Session {
            rig: None,
            name: "plan".into(),
            description: Some(format!("a capture plan of {} poses", self.poses.len())),
            model: model.urdf_path.clone(),
            markers: model.markers.iter().map(|m| m.name.clone()).collect(),
            body: None,
            reference_pose: self.poses.first().map_or(0, |p| p.step),
            poses,
            truth: None,
            streams: None,
            folder: None,
        }
    }

    /// The predicted orientation error after calibration over the workspace, as a markdown table:
    /// the mean (and worst) over the candidates in each band of tilt and yaw.
    pub fn uncertainty_map(&self) -> String {
        let bands = crate::math::so3::WORKSPACE_BANDS_DEG;
        let label = |k: usize| match bands[k + 1] {
            b if b.is_finite() => format!("{}–{}°", bands[k], b),
            _ => format!("> {}°", bands[k]),
        };
        let mut cells = vec![vec![(0.0, 0.0_f64, 0usize); 4]; 4];
        for (c, e) in self.candidates.iter().zip(&self.uncertainty_deg) {
            let (tilt, yaw) = crate::math::so3::workspace_band(&c.rotation);
            let cell = &mut cells[tilt][yaw];
            *cell = (cell.0 + e, cell.1.max(*e), cell.2 + 1);
        }
        // Only the bands the workspace reaches.
        let rows: Vec<usize> = (0..4).filter(|&k| cells[k].iter().any(|c| c.2 > 0)).collect();
        let columns: Vec<usize> = (0..4).filter(|&k| cells.iter().any(|row| row[k].2 > 0)).collect();
        let mut text =
            String::from("Predicted orientation error after calibration (mean / worst, degrees)\n\n| tilt \\ yaw |");
        for &k in &columns {
            text += &format!(" {} |", label(k));
        }
        text += &format!("\n|---|{}\n", "---|".repeat(columns.len()));
        for &r in &rows {
            text += &format!("| {} |", label(r));
            for &k in &columns {
                let (sum, worst, n) = cells[r][k];
                text += &if n == 0 { " – |".to_string() } else { format!(" {:.3} / {:.3} |", sum / n as f64, worst) };
            }
            text += "\n";
        }
        text
    }
}

/// The Fisher information of an existing session's marker observations at `p`'s parameters.
fn session_information(
    session: &Session,
    p: &Parameterisation,
    spm: &crate::model::Spm,
    noise: &crate::calib::StereoNoise,
) -> Result<DMatrix<f64>, PlanError> {
    let (observations, _) = MarkerObservation::of_session(session, spm);
    let per_pose = MarkerResiduals::new(p, &observations)
        .information_per_pose(&nalgebra::DVector::zeros(p.len()), noise)
        .map_err(crate::calib::SetError::Eval)?;
    Ok(per_pose.into_iter().fold(DMatrix::zeros(p.len(), p.len()), |sum, (_, m)| sum + m))
}

/// Up to this many candidates (and no session to augment) the continuous design comes from the
/// cone program (a few seconds at 150); beyond, from the multiplicative algorithm.
const CONE_PROGRAM_MAX_CANDIDATES: usize = 150;

/// Poses that sample the workspace for the plan's weighting (when the candidates keep a margin).
const WORKSPACE_POSES: usize = 2000;

/// Random designs whose worst workspace error is averaged.
const WORST_DRAWS: usize = 10;

/// N random candidates, `draws` times: the mean criterion's prediction, and the fewest random
/// poses whose mean criterion reaches `target` (searched by doubling then bisection, to 2%).
fn random_designs(
    info: &Information,
    prior: &DMatrix<f64>,
    n: usize,
    target: f64,
    draws: usize,
) -> (Predicted, Option<usize>) {
    let all = info.per_candidate.len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x9a11);
    let mut indices: Vec<usize> = (0..all).collect();
    let total_prior = prior * n as f64;
    // Mean criterion (and, when asked, worst error and log det) of random designs of `size`.
    let mut mean_over = |size: usize, full: bool| -> (f64, f64, f64) {
        let (mut phi, mut worst, mut logdet) = (0.0, 0.0, 0.0);
        // The search below only compares means: fewer draws do.
        let draws = if full { draws } else { (draws / 5).max(5) };
        for draw in 0..draws {
            indices.shuffle(&mut rng);
            let mut m = total_prior.clone();
            indices[..size].iter().for_each(|&c| m += &info.per_candidate[c]);
            phi += criterion(&m, &info.workspace);
            if full {
                logdet += log_det(&m);
            }
            // The worst pose needs the error at every candidate: from the first draws only.
            if full
                && draw < WORST_DRAWS
                && let Some(c) = m.clone().cholesky()
            {
                worst += orientation_errors(info, &c.inverse()).iter().copied().fold(0.0, f64::max);
            }
        }
        let d = draws as f64;
        (phi / d, worst / draws.min(WORST_DRAWS) as f64, logdet / d)
    };
    let (phi, worst, logdet) = mean_over(n, true);
    let random = Predicted { rms_deg: phi.sqrt().to_degrees(), worst_deg: worst.to_degrees(), log_det: logdet };
    // The mean criterion falls as poses are added: find the first size that reaches the target.
    let reaches =
        |size: usize, mean_over: &mut dyn FnMut(usize, bool) -> (f64, f64, f64)| mean_over(size, false).0 <= target;
    let (mut low, mut high) = (n, n);
    while !reaches(high, &mut mean_over) {
        if high == all {
            return (random, None);
        }
        low = high;
        high = (high * 2).min(all);
    }
    while high - low > (low / 50).max(1) {
        let mid = (low + high) / 2;
        if reaches(mid, &mut mean_over) { high = mid } else { low = mid }
    }
    (random, Some(high))
}

impl std::fmt::Display for PlanSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self;
        if let Some((session, poses)) = &s.augments {
            writeln!(f, "adding to session {session} ({poses} poses)")?;
        }
        writeln!(
            f,
            "plan: {} poses chosen from {} candidates for {} parameters (marker-level fit)",
            s.poses, s.candidates, s.parameters
        )?;
        writeln!(
            f,
            "predicted orientation error after calibration, over the workspace (as the report's \
             `predicted_error_deg` and `compare` measure it: up to the rotations common to every pose):"
        )?;
        writeln!(f, "  {:<34} {:>9} {:>9} {:>10}", "", "RMS (°)", "worst (°)", "log det M")?;
        let row = |f: &mut std::fmt::Formatter<'_>, label: &str, p: &Predicted| {
            writeln!(f, "  {label:<34} {:>9.4} {:>9.4} {:>10.2}", p.rms_deg, p.worst_deg, p.log_det)
        };
        row(f, "continuous optimum (bound)", &s.continuous_optimum)?;
        row(f, "this plan", &s.plan)?;
        row(f, &format!("{} random reachable poses", s.poses), &s.random)?;
        if let Some(e) = s.report_prediction_deg {
            writeln!(
                f,
                "the calibration's report will predict about {e:.4}° RMS at these poses (its `predicted_error_deg` \
                 takes the session's own poses as the workspace)"
            )?;
        }
        writeln!(
            f,
            "plan efficiency {:.1}% of the continuous optimum ({} support points; {}, equivalence ratio {:.4} after {} iterations; {} exchanges)",
            100.0 * s.efficiency,
            s.support,
            s.solver,
            s.equivalence_ratio,
            s.iterations,
            s.exchanges
        )?;
        match s.random_poses_needed {
            Some(n) => writeln!(f, "random poses needed for the plan's accuracy: {n}")?,
            None => {
                writeln!(f, "random poses needed for the plan's accuracy: more than all {} candidates", s.candidates)?
            }
        }
        if let Some(note) = &s.camera_note {
            writeln!(f, "camera: {note}")?;
        }
        for (name, sigma) in &s.camera_std_errors {
            writeln!(f, "camera model: {name} determined to ±{sigma:.5} (predicted standard error)")?;
        }
        for (name, sigma) in &s.joint_scale_std_errors {
            let held = match *sigma > JOINT_SCALE_AUTO_MOST_STD_ERROR {
                true => " — too poorly for `joint_scales: auto`, which will hold it: move the joint further",
                false => "",
            };
            writeln!(f, "joint scale: {name} determined to ±{:.0} ppm (predicted standard error){held}", 1e6 * sigma)?;
        }
        writeln!(f, "tour from home and back: {:.0}° of joystick travel", s.travel_deg)
    }
}
