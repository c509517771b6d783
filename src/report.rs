//! What the commands report, as data: serialisable summaries with a human-readable `Display`,
//! and the one shape every command's `--json` takes ([`Envelope`]). The command line only prints.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

use crate::calib::{CalibrationReport, Convergence, ErrorSummary, FitLevel, MarkerFitReport};
use crate::compare::SetComparison;
use crate::dataset::{JointReading, OrientationRecord};
use crate::files::push_numbers;
use crate::model::{FdaError, Spm, conditioning_index};
use crate::sim::SimSummary;
use crate::so3;
use crate::vision::{CentreOfRotation, Method, SessionEstimate, Stats};

/// The machine-readable summary of one command: the same top-level keys for every command.
#[derive(Debug, Clone, Serialize)]
pub struct Envelope<T: Serialize> {
    /// The command's name (`calibrate`, `compare`, …).
    pub command: &'static str,
    /// The inputs it read, by option name (paths and settings as given).
    pub inputs: BTreeMap<String, String>,
    /// What it computed.
    pub results: T,
    /// What the user should know but did not stop the command.
    pub warnings: Vec<String>,
}

impl<T: Serialize> Envelope<T> {
    /// An envelope for `command` with no inputs and no warnings yet.
    pub fn new(command: &'static str, results: T) -> Self {
        Envelope { command, inputs: BTreeMap::new(), results, warnings: Vec::new() }
    }

    /// Record an input.
    pub fn input(mut self, name: &str, value: impl fmt::Display) -> Self {
        self.inputs.insert(name.to_string(), value.to_string());
        self
    }

    /// The JSON text.
    ///
    /// # Panics
    /// Never in practice: reports serialise to JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("reports serialise to JSON")
    }
}

/// One assembly mode of `fda --all-modes`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeReport {
    /// 0 is the working mode when it exists.
    pub mode: usize,
    /// MP orientation, scalar first.
    pub q_wxyz: [f64; 4],
    /// Leg branch signs, e.g. `---`.
    pub branches: String,
    /// Conditioning index of the closure Jacobian.
    pub conditioning: f64,
    /// Whether this is the working mode (continuation from home).
    pub working: bool,
}

/// The FDA of one pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FdaPose {
    /// Pose number.
    pub pose: u64,
    /// Working-mode orientation (without `--all-modes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q_wxyz: Option<[f64; 4]>,
    /// Its conditioning index.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conditioning: Option<f64>,
    /// Every real assembly mode (with `--all-modes`), the working mode first.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub modes: Vec<ModeReport>,
}

/// Every real assembly mode of `joints`, the working mode (continuation from home), when it
/// exists, first and flagged: the ordering `fda --all-modes` prints.
pub fn modes_working_first(spm: &Spm, joints: &nalgebra::Vector3<f64>) -> Vec<ModeReport> {
    let working = spm.forward(joints).ok();
    let is_working = |r: &nalgebra::Rotation3<f64>| working.is_some_and(|w| so3::geodesic_angle(r, &w) < 1e-8);
    let mut modes = spm.all_modes(joints);
    modes.sort_by_key(|m| !is_working(&m.rotation));
    modes
        .iter()
        .enumerate()
        .map(|(k, m)| ModeReport {
            mode: k,
            q_wxyz: so3::to_wxyz(&m.rotation),
            branches: m.branch_label(),
            conditioning: m.conditioning,
            working: is_working(&m.rotation),
        })
        .collect()
}

/// A pose whose working-mode FDA failed: its reading's line, its number, and why.
pub type PoseFailure = (usize, u64, FdaError);

/// `fda`: orientations (for the CSV) and the per-pose report; the first pose whose working-mode
/// FDA fails stops it, with its pose and reading line.
///
/// # Errors
/// `(line, pose, error)` of that pose.
///
/// # Panics
/// If a stored mode quaternion is not a rotation (never for files read by spmcal).
pub fn fda(
    spm: &Spm,
    readings: &[JointReading],
    all_modes: bool,
) -> Result<(Vec<OrientationRecord>, Vec<FdaPose>), PoseFailure> {
    let mut records = Vec::new();
    let mut poses = Vec::new();
    for r in readings {
        if all_modes {
            let modes = modes_working_first(spm, &r.joints);
            for m in &modes {
                records.push(OrientationRecord {
                    pose: r.pose,
                    mode: Some(m.mode),
                    rotation: so3::from_wxyz(m.q_wxyz).expect("a rotation's quaternion"),
                    extra: vec![
                        ("branches".into(), m.branches.clone()),
                        ("conditioning".into(), format!("{:.6}", m.conditioning)),
                        ("working".into(), m.working.to_string()),
                    ],
                    line: r.line,
                });
            }
            poses.push(FdaPose { pose: r.pose, q_wxyz: None, conditioning: None, modes });
        } else {
            let rotation = spm.forward(&r.joints).map_err(|e| (r.line, r.pose, e))?;
            let conditioning = conditioning_index(&spm.jacobians(&r.joints, &rotation).a);
            records.push(OrientationRecord { pose: r.pose, mode: None, rotation, extra: vec![], line: r.line });
            let q = Some(so3::to_wxyz(&rotation));
            poses.push(FdaPose { pose: r.pose, q_wxyz: q, conditioning: Some(conditioning), modes: Vec::new() });
        }
    }
    Ok((records, poses))
}

/// The summary of `estimate`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateSummary {
    /// The estimator.
    pub method: Method,
    /// The pose every other is estimated against.
    pub reference_pose: u64,
    /// Poses estimated (the reference included).
    pub poses_estimated: usize,
    /// Poses estimated from three markers (no redundancy to filter the noise).
    pub poses_without_redundancy: usize,
    /// Poses skipped, with the reason.
    pub skipped: Vec<String>,
    /// `e_j` over the estimated poses but the reference.
    pub e: Option<Stats>,
    /// Iterations of the polar decomposition.
    pub polar_iterations: Option<Stats>,
    /// Angle between the paper's and Kabsch's rotation, degrees.
    pub paper_vs_kabsch_deg: Option<Stats>,
    /// The centre of rotation in the camera frame; `None` when the poses leave it undetermined.
    pub centre_of_rotation: Option<CentreOfRotation>,
}

impl EstimateSummary {
    /// Summarise a session's estimate.
    pub fn of(result: &SessionEstimate) -> Self {
        let errors: Vec<f64> =
            result.poses.iter().filter(|(p, _)| *p != result.reference_pose).map(|(_, e)| e.error).collect();
        let iterations: Vec<f64> = result.poses.iter().map(|(_, e)| e.polar_iterations as f64).collect();
        let difference: Vec<f64> = result.method_difference.iter().map(|a| a.to_degrees()).collect();
        let redundant = result.poses.iter().filter(|(_, e)| e.redundant).count();
        EstimateSummary {
            method: result.method,
            reference_pose: result.reference_pose,
            poses_estimated: result.poses.len(),
            poses_without_redundancy: result.poses.len() - redundant,
            skipped: result.skipped.iter().map(|s| s.to_string()).collect(),
            e: Stats::of(&errors),
            polar_iterations: Stats::of(&iterations),
            paper_vs_kabsch_deg: Stats::of(&difference),
            centre_of_rotation: result.centre,
        }
    }
}

/// How many skipped poses or excluded items a text report lists before "… and N more".
const LISTED: usize = 10;

impl fmt::Display for EstimateSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} poses estimated against pose {} ({} without redundancy), {} skipped",
            self.poses_estimated,
            self.reference_pose,
            self.poses_without_redundancy,
            self.skipped.len()
        )?;
        for s in self.skipped.iter().take(LISTED) {
            writeln!(f, "  skipped {s}")?;
        }
        if self.skipped.len() > LISTED {
            writeln!(f, "  … and {} more (all are listed by --json)", self.skipped.len() - LISTED)?;
        }
        if let Some(e) = &self.e {
            writeln!(f, "e_j: mean {:.4}, median {:.4}, max {:.4}", e.mean, e.median, e.max)?;
        }
        if let Some(d) = &self.paper_vs_kabsch_deg {
            writeln!(f, "paper vs kabsch: mean {:.4}°, max {:.4}°", d.mean, d.max)?;
        }
        match &self.centre_of_rotation {
            Some(c) => writeln!(
                f,
                "centre of rotation (camera frame): [{:.4}, {:.4}, {:.4}] m, residual RMS {:.2} mm, max {:.2} mm",
                c.position_m[0],
                c.position_m[1],
                c.position_m[2],
                c.rms_residual_m * 1e3,
                c.max_residual_m * 1e3
            ),
            None => writeln!(f, "centre of rotation: undetermined (too few poses, or all rotate about one axis)"),
        }
    }
}

/// `estimate`'s table: `pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m`.
pub fn estimate_csv(result: &SessionEstimate) -> String {
    let mut table = String::from("pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m\n");
    for (pose, e) in &result.poses {
        let q = so3::to_wxyz(&e.rotation);
        let t = e.translation;
        let angle = so3::log(&e.rotation).norm().to_degrees();
        table.push_str(&pose.to_string());
        push_numbers(&mut table, &[q[0], q[1], q[2], q[3], angle, e.error, t.x, t.y, t.z]);
        table.push('\n');
    }
    table
}

/// `compare`'s table: one row per pose any set predicts, one column per set (empty where that
/// set's FDA failed).
pub fn comparison_csv(results: &[SetComparison]) -> String {
    let mut table = String::from("pose");
    for c in results {
        table.push_str(&format!(",{}_{}", c.label, c.unit));
    }
    table.push('\n');
    let poses: std::collections::BTreeSet<u64> =
        results.iter().flat_map(|c| c.per_pose.iter().map(|(p, _)| *p)).collect();
    for pose in poses {
        table.push_str(&pose.to_string());
        for c in results {
            let value = c.per_pose.iter().find(|(p, _)| *p == pose).map_or(String::new(), |(_, a)| format!("{a:.5}"));
            table.push_str(&format!(",{value}"));
        }
        table.push('\n');
    }
    table
}

impl fmt::Display for SetComparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = if self.unit == "deg" { "°" } else { " mm" };
        writeln!(
            f,
            "{:<11} RMS {:.4}{unit}, median {:.4}{unit}, max {:.4}{unit} over {} poses (registration: {})",
            self.label,
            self.rms,
            self.median,
            self.max,
            self.per_pose.len(),
            self.registration
        )
    }
}

impl fmt::Display for SimSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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
        writeln!(
            f,
            "markers: {} seen, {} occluded, {} outliers; {} poses with fewer than 3 markers",
            self.markers_seen, self.markers_occluded, self.outliers, self.poses_with_too_few_markers
        )
    }
}

fn error_line(f: &mut fmt::Formatter<'_>, label: &str, e: &ErrorSummary) -> fmt::Result {
    writeln!(f, "  {label:<26} {:8.4} {:8.4} {:8.4}", e.rms_deg, e.median_deg, e.max_deg)
}

impl fmt::Display for CalibrationReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self;
        match r.fit {
            FitLevel::Markers => writeln!(
                f,
                "{}: {} poses, {} excluded; marker-level fit, loss {:?}",
                r.session,
                r.poses,
                r.excluded.len(),
                r.loss
            )?,
            FitLevel::Orientations => writeln!(
                f,
                "{}: {} poses, {} fitted, {} held out, {} excluded; orientation-level fit, vision {:?}, loss {:?}",
                r.session,
                r.poses,
                r.fit_poses,
                r.held_out_poses,
                r.excluded.len(),
                r.vision_method,
                r.loss
            )?,
        }
        for e in r.excluded.iter().take(LISTED) {
            writeln!(f, "  excluded {e}")?;
        }
        if r.excluded.len() > LISTED {
            writeln!(f, "  … and {} more (all are listed by --json)", r.excluded.len() - LISTED)?;
        }
        match &r.markers {
            Some(m) => {
                marker_summary(f, m)?;
                per_pose_lines(f, r)?;
            }
            None => {
                writeln!(f, "FDA vs vision (deg)          RMS      median   max")?;
                error_line(f, "nominal, fitted poses", &r.before.fit)?;
                error_line(f, "calibrated, fitted poses", &r.after.fit)?;
                if let (Some(b), Some(a)) = (&r.before.held_out, &r.after.held_out) {
                    error_line(f, "nominal, held out", b)?;
                    error_line(f, "calibrated, held out", a)?;
                }
            }
        }
        let iterations = r.iterations.len();
        match r.convergence {
            Convergence::Converged => writeln!(f, "converged in {iterations} iterations")?,
            Convergence::StalledAtMinimum => writeln!(
                f,
                "stalled at a minimum after {iterations} iterations (the cost stopped changing before the steps fell below the tolerance)"
            )?,
        }
        writeln!(
            f,
            "identifiability: {} of {} directions, condition number {:.3e}",
            r.identifiability.rank, r.identifiability.parameters, r.identifiability.condition
        )?;
        for d in &r.identifiability.weakest {
            writeln!(f, "  weak: {}", d.describe())?;
        }
        for d in &r.regularised {
            writeln!(f, "  REGULARISED (not identifiable, held at its start): {d}")?;
        }
        writeln!(f, "parameter                    change (deg)   std error (deg)")?;
        for p in &r.parameters {
            match p.std_error_deg {
                Some(se) => writeln!(f, "  {:<26} {:+12.5} {:14.5}", p.name, p.change_deg, se)?,
                None => writeln!(f, "  {:<26} {:+12.5}         frozen", p.name, p.change_deg)?,
            }
        }
        if !r.not_significant.is_empty() {
            writeln!(
                f,
                "not distinguishable from nominal (|change| < 2 std errors): {} of {}: {}",
                r.not_significant.len(),
                r.parameters.iter().filter(|p| !p.frozen).count(),
                r.not_significant.join(", ")
            )?;
        }
        for c in r.high_correlations.iter().take(5) {
            writeln!(f, "  correlated: {} ~ {} (rho {:+.3})", c.a, c.b, c.rho)?;
        }
        for (markers, poses, sigma) in &r.residual_sigma_deg {
            writeln!(
                f,
                "residual sigma, {poses} poses with {markers} markers: [{:.4}, {:.4}, {:.4}] deg (camera x, y, z)",
                sigma[0], sigma[1], sigma[2]
            )?;
        }
        if let Some(u) = &r.orientation_uncertainty_deg {
            writeln!(
                f,
                "predicted orientation uncertainty (1 sigma, {}): mean {:.4} deg, max {:.4} deg",
                if r.fit == FitLevel::Markers { "of each pose's FDA" } else { "as the camera sees it" },
                u.mean,
                u.max
            )?;
        }
        match (r.camera_translation_m, r.camera_translation_std_error_m) {
            (Some(t), Some(se)) => writeln!(
                f,
                "camera translation t_CB: [{:.4}, {:.4}, {:.4}] m (± [{:.4}, {:.4}, {:.4}] mm)",
                t[0],
                t[1],
                t[2],
                se[0] * 1e3,
                se[1] * 1e3,
                se[2] * 1e3
            )?,
            _ => writeln!(
                f,
                "camera translation t_CB: undetermined (the poses do not fix the centre of rotation); no camera registration written"
            )?,
        }
        if let Some(m) = &r.markers {
            return marker_details(f, m);
        }
        let outliers: Vec<String> =
            r.outliers.iter().map(|o| format!("{} ({:.3} deg)", o.pose, o.residual_deg)).collect();
        writeln!(f, "outlier poses: {}", if outliers.is_empty() { "none".to_string() } else { outliers.join(", ") })
    }
}

/// The verdict and the marker errors of a marker-level calibration (first, so it is read first).
fn marker_summary(f: &mut fmt::Formatter<'_>, m: &MarkerFitReport) -> fmt::Result {
    writeln!(f, "marker-level fit: {} observations at {} poses", m.observations, m.poses)?;
    if let Some(cv) = &m.cross_validation {
        let verdict = if cv.clearly_better { "BETTER" } else { "NOT CLEARLY BETTER" };
        writeln!(
            f,
            "verdict: {verdict}: on unseen poses ({}-fold cross-validation, {} observations) the calibrated model \
             predicts the markers to {:.3} mm RMS against the nominal model's {:.3} mm",
            cv.folds, cv.observations, cv.calibrated_rms_mm, cv.nominal_rms_mm
        )?;
    }
    for w in &m.warnings {
        writeln!(f, "WARNING: {w}")?;
    }
    writeln!(f, "FDA vs camera, markers (mm)  RMS      median   max")?;
    for (label, e) in [("nominal", &m.before), ("calibrated", &m.after)] {
        writeln!(f, "  {:<26} {:8.4} {:8.4} {:8.4}", label, e.rms_mm, e.median_mm, e.max_mm)?;
    }
    let per_marker: Vec<String> = m
        .before
        .per_marker
        .iter()
        .zip(&m.after.per_marker)
        .map(|((name, n, b), (_, _, a))| format!("{name} {b:.3} → {a:.3} ({n})"))
        .collect();
    writeln!(f, "  per marker, mm RMS (observations): {}", per_marker.join(", "))
}

/// The per-pose orientation errors beside a marker-level fit, when the estimator had poses.
fn per_pose_lines(f: &mut fmt::Formatter<'_>, r: &CalibrationReport) -> fmt::Result {
    if r.before.fit.poses == 0 {
        return writeln!(f, "FDA vs vision per pose: no pose (station) sees three markers");
    }
    writeln!(f, "FDA vs vision per pose (deg)  RMS      median   max")?;
    error_line(f, "nominal", &r.before.fit)?;
    error_line(f, "calibrated", &r.after.fit)
}

/// Fitted markers, stereo noise and flagged observations of a marker-level calibration.
fn marker_details(f: &mut fmt::Formatter<'_>, m: &MarkerFitReport) -> fmt::Result {
    if let Some(l) = &m.latency {
        match l.std_error_s {
            Some(se) => writeln!(f, "camera latency: {:.3} ± {:.3} ms (estimated)", l.value_s * 1e3, se * 1e3)?,
            None => writeln!(f, "camera latency: {:.3} ms (as given; frozen)", l.value_s * 1e3)?,
        }
    }
    if let Some(n) = &m.stereo_noise {
        writeln!(
            f,
            "stereo noise at {:.3} m: across the line of sight {:.4} ± {:.4} mm, along it {:.4} ± {:.4} mm",
            n.reference_distance_m,
            n.lateral_m * 1e3,
            n.lateral_std_error_m * 1e3,
            n.depth_m * 1e3,
            n.depth_std_error_m * 1e3
        )?;
    }
    writeln!(f, "marker   fitted position in P (m)          change from the model (mm)         std error (mm)")?;
    for k in &m.markers {
        let se = k
            .std_error_mm
            .map_or("held at the model".to_string(), |s| format!("[{:.3}, {:.3}, {:.3}]", s[0], s[1], s[2]));
        writeln!(
            f,
            "  {:<6} [{:+.5}, {:+.5}, {:+.5}]   [{:+7.3}, {:+7.3}, {:+7.3}]   {se}",
            k.name, k.fitted_m[0], k.fitted_m[1], k.fitted_m[2], k.change_mm[0], k.change_mm[1], k.change_mm[2]
        )?;
    }
    if !m.fast_captures.is_empty() {
        writeln!(
            f,
            "fast captures: {} taken while a joint turned faster than `max_joint_speed_deg_s`, down-weighted (e.g. captures.csv line {}, {:.0} deg/s)",
            m.fast_captures.len(),
            m.fast_captures[0].2,
            m.fast_captures[0].3
        )?;
    }
    let excluded = m.flagged.iter().filter(|o| o.excluded).count();
    writeln!(f, "flagged observations: {} ({excluded} excluded as gross errors)", m.flagged.len())?;
    for o in m.flagged.iter().take(LISTED) {
        writeln!(
            f,
            "  pose {} marker {} (markers.csv line {}): {:.3} mm, {:.1} sigma{}",
            o.pose,
            o.marker,
            o.line,
            o.residual_mm,
            o.sigmas,
            if o.excluded { ", excluded" } else { "" }
        )?;
    }
    if m.flagged.len() > LISTED {
        writeln!(f, "  … and {} more (all are listed by --json)", m.flagged.len() - LISTED)?;
    }
    Ok(())
}

impl fmt::Display for crate::plan::PlanSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = self;
        if let Some((session, poses)) = &s.augments {
            writeln!(f, "adding to session {session} ({poses} poses)")?;
        }
        writeln!(
            f,
            "plan: {} poses chosen from {} candidates for {} parameters (marker-level fit)",
            s.poses, s.candidates, s.parameters
        )?;
        writeln!(f, "predicted orientation error after calibration, over the workspace:")?;
        writeln!(f, "  {:<34} {:>9} {:>9} {:>10}", "", "RMS (°)", "worst (°)", "log det M")?;
        let row = |f: &mut fmt::Formatter<'_>, label: &str, p: &crate::plan::Predicted| {
            writeln!(f, "  {label:<34} {:>9.4} {:>9.4} {:>10.2}", p.rms_deg, p.worst_deg, p.log_det)
        };
        row(f, "continuous optimum (bound)", &s.continuous_optimum)?;
        row(f, "this plan", &s.plan)?;
        row(f, &format!("{} random reachable poses", s.poses), &s.random)?;
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
        writeln!(f, "tour from home and back: {:.0}° of joystick travel", s.travel_deg)
    }
}
