//! The workspace a calibration's predicted error is for: by default the session's own poses; with
//! `workspace` in the config, the orientations a user names (tilt and yaw ranges), so that the
//! prediction covers where the model will be used — including where the session did not go and
//! the model extrapolates — and the session's own coverage, to say when it does.

use std::borrow::Cow;

use nalgebra::{DMatrix, DVector, Rotation3, Unit, Vector3};

use super::config::PredictionWorkspace;
use super::parameterisation::Kind;
use super::parameterisation::Parameterisation;
use super::sensitivity::{Frames, through_sag};
use super::uncertainty::{PredictedError, predicted_orientation_error};
use crate::math::so3;

/// How many orientations the predicted error is averaged over: its RMS is then within about 3 % of
/// the workspace's (measured: 400 against 4,000 on the Agile Wrist).
const SAMPLES: usize = 400;

impl PredictionWorkspace {
    /// The tilt and yaw (deg) of `r`: `r = exp(tilt) · exp(yaw ẑ)`, the tilt the smallest rotation
    /// taking ẑ to `r ẑ`.
    pub(crate) fn tilt_yaw_deg(r: &Rotation3<f64>) -> (f64, f64) {
        let z = r * Vector3::z();
        let tilt = Rotation3::rotation_between(&Vector3::z(), &z).unwrap_or_else(Rotation3::identity);
        let yaw = tilt.inverse() * r;
        (z.z.clamp(-1.0, 1.0).acos().to_degrees(), yaw.scaled_axis().z.to_degrees())
    }

    /// The smallest workspace holding every orientation of `rotations`.
    pub(crate) fn covering(rotations: &[Rotation3<f64>]) -> PredictionWorkspace {
        rotations.iter().map(Self::tilt_yaw_deg).fold(
            PredictionWorkspace { max_tilt_deg: 0.0, max_yaw_deg: 0.0 },
            |w, (t, y)| PredictionWorkspace {
                max_tilt_deg: w.max_tilt_deg.max(t),
                max_yaw_deg: w.max_yaw_deg.max(y.abs()),
            },
        )
    }

    /// `count` orientations spread evenly over the workspace (area-uniform in the tilt disc,
    /// uniform in yaw), from a Halton sequence: the same every run, no random numbers.
    pub(crate) fn orientations(&self, count: usize) -> Vec<Rotation3<f64>> {
        (1..=count)
            .map(|k| {
                let (u1, u2, u3) = (halton(k, 2), halton(k, 3), halton(k, 5));
                let tilt = self.max_tilt_deg.to_radians() * u1.sqrt();
                let azimuth = std::f64::consts::TAU * u2;
                let yaw = self.max_yaw_deg.to_radians() * (2.0 * u3 - 1.0);
                let axis = Unit::new_unchecked(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0));
                Rotation3::from_axis_angle(&axis, tilt) * so3::exp(&(Vector3::z() * yaw))
            })
            .collect()
    }

    /// The orientations of this workspace the calibrated mechanism (`p` at `x`) reaches, with
    /// the sensitivity `∂ω/∂x` at the joints its IK gives; `None` when too few are reachable to
    /// fit the common rotations.
    fn poses(&self, p: &Parameterisation, x: &DVector<f64>) -> Option<PredictionPoses<'static>> {
        let legs = p.legs(x);
        let spm = p.spm(x).ok()?;
        let frames = Frames::new(p, x);
        let sag = p.entries.iter().position(|e| e.kind == Kind::PlatformSag);
        let (mut sens, mut rotations) = (Vec::new(), Vec::new());
        // Each orientation is the platform's (the sag included); the sensitivity is the platform's
        // too, the sag's own column with it.
        for r in self.orientations(SAMPLES) {
            if let Ok(joints) = spm.ik(&r) {
                let rigid = spm.rigid(&r);
                let mut s = frames.orientation_sensitivity(&spm, &legs, &joints, &rigid);
                through_sag(&spm, &rigid, &mut s, sag);
                sens.push(s);
                rotations.push(r);
            }
        }
        (rotations.len() >= 10).then(|| PredictionPoses {
            ids: Cow::Owned((0..rotations.len() as u64).collect()),
            sensitivities: Cow::Owned(sens),
            rotations: Cow::Owned(rotations),
            workspace: Some(*self),
        })
    }
}

/// The poses a calibration's orientation error is predicted at: the workspace the user named, or
/// else the session's own poses — their sensitivities worked out once, for every covariance the
/// report predicts with (the plain and the widened).
pub(crate) struct PredictionPoses<'a> {
    sensitivities: Cow<'a, [DMatrix<f64>]>,
    rotations: Cow<'a, [Rotation3<f64>]>,
    ids: Cow<'a, [u64]>,
    workspace: Option<PredictionWorkspace>,
}

impl<'a> PredictionPoses<'a> {
    /// Over `workspace` when the user named one (at the calibrated mechanism, `p` at `x`), else
    /// over the session's poses (their sensitivities `sens`, `orientations` and `ids`); `None`
    /// when there is nothing to predict at. With a finding when the workspace reaches beyond the
    /// session's poses (by more than a degree), where the prediction is an extrapolation.
    pub(crate) fn of(
        workspace: Option<&PredictionWorkspace>,
        p: &Parameterisation,
        x: &DVector<f64>,
        sens: Option<&'a [DMatrix<f64>]>,
        orientations: &'a [Rotation3<f64>],
        ids: &'a [u64],
    ) -> (Option<Self>, Option<String>) {
        let Some(w) = workspace else {
            let poses = sens.map(|s| PredictionPoses {
                sensitivities: Cow::Borrowed(s),
                rotations: Cow::Borrowed(orientations),
                ids: Cow::Borrowed(ids),
                workspace: None,
            });
            return (poses, None);
        };
        let poses = w.poses(p, x);
        let covered = PredictionWorkspace::covering(orientations);
        let beyond = w.max_tilt_deg > covered.max_tilt_deg + 1.0 || w.max_yaw_deg > covered.max_yaw_deg + 1.0;
        let finding = beyond.then(|| {
            format!(
                "the predicted error is for the workspace tilt ≤ {:.0}°, yaw ±{:.0}° (`workspace`), but the session's \
                 poses reach tilt {:.1}°, yaw ±{:.1}°: beyond them the calibrated model extrapolates, and the \
                 prediction includes it; poses out to the workspace's edge (`spmcal plan`) make it smaller",
                w.max_tilt_deg, w.max_yaw_deg, covered.max_tilt_deg, covered.max_yaw_deg
            )
        });
        (poses, finding)
    }

    /// The predicted orientation error at these poses under `cov` (the FDA's own columns `fda`).
    pub(crate) fn predicted(&self, cov: &DMatrix<f64>, fda: &[bool]) -> Option<PredictedError> {
        let mut e = predicted_orientation_error(&self.sensitivities, &self.rotations, &self.ids, fda, cov)?;
        e.workspace = self.workspace;
        Some(e)
    }

    /// The report's predicted error under `widened` (the covariance the model check may have
    /// widened by the misfit) and, when that differs from the fit's own `plain`, the RMS without
    /// the widening.
    pub(crate) fn plain_and_widened(
        poses: Option<&Self>,
        widened: &DMatrix<f64>,
        plain: &DMatrix<f64>,
        fda: &[bool],
    ) -> (Option<PredictedError>, Option<f64>) {
        let predicted = |c: &DMatrix<f64>| poses.and_then(|poses| poses.predicted(c, fda));
        let unwidened = (widened != plain).then(|| predicted(plain)).flatten().map(|e| e.rms);
        (predicted(widened), unwidened)
    }
}

/// The `k`-th element of the van der Corput sequence in `base` (in [0, 1)).
fn halton(mut k: usize, base: usize) -> f64 {
    let (mut value, mut fraction) = (0.0, 1.0);
    while k > 0 {
        fraction /= base as f64;
        value += fraction * (k % base) as f64;
        k /= base;
    }
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilt_and_yaw_are_read_back_from_the_orientations_drawn() {
        let w = PredictionWorkspace { max_tilt_deg: 30.0, max_yaw_deg: 25.0 };
        let drawn = w.orientations(500);
        for r in &drawn {
            let (tilt, yaw) = PredictionWorkspace::tilt_yaw_deg(r);
            assert!(tilt <= 30.0 + 1e-9 && yaw.abs() <= 25.0 + 1e-9, "{tilt} {yaw}");
        }
        // Evenly spread: the drawn set reaches its bounds (within a degree) and fills its middle.
        let cover = PredictionWorkspace::covering(&drawn);
        assert!(cover.max_tilt_deg > 29.0 && cover.max_yaw_deg > 24.0, "{cover:?}");
        let inner = drawn.iter().filter(|r| PredictionWorkspace::tilt_yaw_deg(r).0 < 15.0).count();
        // Area-uniform in the disc: a quarter within half the tilt (±3 %).
        assert!((inner as f64 / 500.0 - 0.25).abs() < 0.03, "{inner}");
    }

    #[test]
    fn a_known_rotation_splits_into_its_tilt_and_yaw() {
        let axis = Unit::new_normalize(Vector3::new(1.0, 2.0, 0.0));
        let r =
            Rotation3::from_axis_angle(&axis, 20f64.to_radians()) * so3::exp(&(Vector3::z() * (-12f64).to_radians()));
        let (tilt, yaw) = PredictionWorkspace::tilt_yaw_deg(&r);
        assert!((tilt - 20.0).abs() < 1e-9 && (yaw + 12.0).abs() < 1e-9, "{tilt} {yaw}");
    }
}
