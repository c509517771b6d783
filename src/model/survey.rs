//! What `spmcal check` says about a model before it is used: its geometry leg by leg, the home
//! each leg sits on, and how well conditioned the mechanism is over a workspace of tilts and
//! yaws — with every problem a user should hear about in words.

use nalgebra::{Rotation3, Vector3};
use serde::Serialize;

use super::geometry::LegGeometry;
use super::spm::{Branch, Spm};
use crate::math::so3;

/// Below this conditioning index the FDA is still trusted but sensitive: the orientation errs by
/// joint errors times about `1/conditioning` (at 0.1, tenfold), worth a word before calibrating.
const POOR_CONDITIONING: f64 = 0.1;

/// Grid of the workspace survey: tilt steps, azimuths per tilt ring, yaw steps.
const TILT_STEPS: usize = 12;
const AZIMUTHS: usize = 24;
const YAW_STEPS: usize = 13;

/// A model surveyed: geometry, home and workspace, and the problems found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelSurvey {
    /// The legs' geometry (axes in B and P, angles in radians, home branches).
    pub legs: [LegGeometry; 3],
    /// Whether the actuated axes share one line (a coaxial SPM such as Orbita3d).
    pub coaxial: bool,
    /// Joint readings at home (`R = I`): zero for a model whose zero configuration is home, the
    /// negated encoder offsets for calibrated parameters.
    pub home_joints: [f64; 3],
    /// How far (deg) the working-mode FDA of all-zero joint readings is from the identity: 0 for
    /// a model whose zero configuration is home (the convention); `None` when it fails.
    pub fda_at_zero_deg: Option<f64>,
    /// Each leg's `|(u×w)·v| / sin α1` at home (0 at a serial singularity, 1 at best).
    pub home_margins: [f64; 3],
    /// Conditioning index of the closure Jacobian at home (0 singular, 1 isotropic).
    pub home_conditioning: f64,
    /// The workspace surveyed: tilts up to this (deg) …
    pub max_tilt_deg: f64,
    /// … and yaws within ± this (deg), `R = exp(tilt·a) exp(yaw·z)`.
    pub max_yaw_deg: f64,
    /// Orientations of the grid.
    pub orientations: usize,
    /// Of them, reached by IK with the FDA's checks passing (regular, every leg on its home branch).
    pub regular: usize,
    /// Smallest conditioning index over the regular ones.
    pub min_conditioning: f64,
    /// Where it occurs: tilt, tilt azimuth, yaw (deg).
    pub min_conditioning_at_deg: [f64; 3],
    /// Smallest branch margin over the regular ones.
    pub min_margin: f64,
    /// What a user should know, one sentence each; empty when nothing is amiss.
    pub problems: Vec<String>,
}

impl ModelSurvey {
    /// Survey `spm` over tilts up to `max_tilt_deg` and yaws within `±max_yaw_deg`.
    pub fn of(spm: &Spm, max_tilt_deg: f64, max_yaw_deg: f64) -> Self {
        let legs = *spm.geometry();
        let home = spm.home_joints();
        let identity = Rotation3::identity();
        let margins = spm.branch_margins(&home, &identity);
        let mut survey = ModelSurvey {
            legs,
            coaxial: legs[0].u.cross(&legs[1].u).norm() < 1e-6 && legs[0].u.cross(&legs[2].u).norm() < 1e-6,
            home_joints: home.into(),
            fda_at_zero_deg: spm
                .forward(&Vector3::zeros())
                .ok()
                .map(|r| so3::geodesic_angle(&r, &identity).to_degrees()),
            home_margins: margins.map(f64::abs).into(),
            home_conditioning: spm.jacobians(&home, &identity).conditioning(),
            max_tilt_deg,
            max_yaw_deg,
            orientations: 0,
            regular: 0,
            min_conditioning: f64::INFINITY,
            min_conditioning_at_deg: [0.0; 3],
            min_margin: f64::INFINITY,
            problems: Vec::new(),
        };
        survey.walk_workspace(spm);
        if survey.regular == 0 {
            (survey.min_conditioning, survey.min_margin) = (0.0, 0.0);
        }
        survey.problems = survey.findings(spm);
        survey
    }

    /// Every orientation of the grid through IK and the FDA's own checks.
    fn walk_workspace(&mut self, spm: &Spm) {
        let settings = spm.settings;
        for t in 0..=TILT_STEPS {
            let tilt = self.max_tilt_deg.to_radians() * t as f64 / TILT_STEPS as f64;
            let azimuths = if t == 0 { 1 } else { AZIMUTHS };
            for a in 0..azimuths {
                let azimuth = 2.0 * std::f64::consts::PI * a as f64 / AZIMUTHS as f64;
                for y in 0..YAW_STEPS {
                    let yaw = self.max_yaw_deg.to_radians() * (2.0 * y as f64 / (YAW_STEPS - 1) as f64 - 1.0);
                    let r = so3::from_tilt_and_yaw(azimuth, tilt, yaw);
                    self.orientations += 1;
                    let Ok(joints) = spm.ik(&r) else { continue };
                    let conditioning = spm.jacobians(&joints, &r).conditioning();
                    let margin = -spm.branch_margins(&joints, &r).max();
                    if conditioning < settings.min_conditioning || margin < settings.min_branch_margin {
                        continue;
                    }
                    self.regular += 1;
                    self.min_margin = self.min_margin.min(margin);
                    if conditioning < self.min_conditioning {
                        self.min_conditioning = conditioning;
                        self.min_conditioning_at_deg = [tilt, azimuth, yaw].map(f64::to_degrees);
                    }
                }
            }
        }
    }

    /// The problems, in words.
    fn findings(&self, spm: &Spm) -> Vec<String> {
        let mut problems = Vec::new();
        if self.home_conditioning < POOR_CONDITIONING {
            problems.push(format!(
                "home is poorly conditioned (index {:.3}): orientation errors near home are about {:.0}× the joint errors",
                self.home_conditioning,
                1.0 / self.home_conditioning
            ));
        }
        for (i, m) in self.home_margins.iter().enumerate() {
            if *m < 5.0 * spm.settings.min_branch_margin {
                problems.push(format!(
                    "leg {} is near a serial singularity at home (margin {m:.3}): small motions may leave its branch",
                    i + 1
                ));
            }
        }
        let missing = self.orientations - self.regular;
        if missing > 0 {
            problems.push(format!(
                "{missing} of the {} orientations within {}° of tilt and ±{}° of yaw are out of reach or beyond the \
                 FDA's singularity thresholds (conditioning {}, branch margin {}): the workspace is smaller",
                self.orientations,
                self.max_tilt_deg,
                self.max_yaw_deg,
                spm.settings.min_conditioning,
                spm.settings.min_branch_margin
            ));
        }
        if self.regular > 0 && self.min_conditioning < POOR_CONDITIONING {
            let [t, a, y] = self.min_conditioning_at_deg;
            problems.push(format!(
                "the conditioning index falls to {:.3} (tilt {t:.1}° towards azimuth {a:.0}°, yaw {y:.1}°): poses there \
                 amplify joint errors {:.0}-fold",
                self.min_conditioning,
                1.0 / self.min_conditioning
            ));
        }
        problems
    }

    /// The home branches as `-`/`+` per leg.
    pub fn home_signs(&self) -> String {
        self.legs.iter().map(|g| Branch::Working.sign_char(g.home_branch)).collect()
    }
}
