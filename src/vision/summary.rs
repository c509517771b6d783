//! The summary of a session's estimate (`spmcal estimate`), as data and as text.

use std::fmt;

use serde::Serialize;

use super::centre::CentreOfRotation;
use super::pose::Method;
use super::session::SessionEstimate;
use crate::math::stats::Stats;

/// How many skipped poses the text lists before "… and N more".
const LISTED: usize = 10;

/// The summary of `estimate`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateSummary {
    /// The estimator.
    pub method: Method,
    /// The pose every other is estimated against.
    pub reference_pose: u64,
    /// Poses estimated (the reference included).
    pub poses_estimated: usize,
    /// Poses estimated from a planar marker set (three markers, or more in a plane: no redundancy
    /// to filter the noise).
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
