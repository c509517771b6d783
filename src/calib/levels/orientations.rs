//! The orientation-level fit (`fit: orientations`): the per-pose orientations of the vision
//! estimator (poses that see at least three markers) against the FDA, every `holdout_every`-th
//! pose held out of the fit to check it; `t_CB` comes from the centre of rotation.

use nalgebra::{DVector, Rotation3, Vector3};

use crate::calib::agreement::degrees;
use crate::calib::calibration::{CalibError, Fitted};
use crate::calib::config::{CalibConfig, Group, PredictionWorkspace};
use crate::calib::level::{Level, LevelReport, LevelResults, MIN_MOTION_DEG, Origin, check_enough};
use crate::calib::orientation_residuals::{Observation, OrientationResiduals, observations};
use crate::calib::parameterisation::{Kind, Parameterisation};
use crate::calib::registration;
use crate::calib::report::ErrorStats;
use crate::calib::residuals::Residuals;
use crate::calib::uncertainty::parameter_reports;
use crate::calib::workspace::PredictionPoses;
use crate::dataset::Session;
use crate::model::{CameraModel, CameraRegistration, ParameterSource, Parameters, RobotModel};
use crate::vision::SessionEstimate;

/// A session's per-pose orientations, ready to fit.
pub(crate) struct OrientationLevel {
    p: Parameterisation,
    fitted: Vec<Observation>,
    held_out: Vec<Observation>,
    vision: SessionEstimate,
    freeze: Vec<Group>,
    max_deg: f64,
    excluded: Vec<String>,
    /// The camera model the markers were corrected by (`camera_terms`), written with the result.
    camera_model: CameraModel,
    /// The config's `workspace`: what the predicted error is for.
    workspace: Option<PredictionWorkspace>,
}

impl OrientationLevel {
    /// The vision estimate of `session` (its markers already corrected by the camera model of
    /// `camera_terms`), its poses on `robot`'s nominal model, registered.
    pub(crate) fn prepare(session: &Session, robot: &RobotModel, config: &CalibConfig) -> Result<Self, CalibError> {
        let vision = SessionEstimate::of(session, config.vision_method)?;
        let nominal_spm = &robot.spm;
        // Observations whose nominal FDA exists.
        let (all, failed) = observations(session, &vision, nominal_spm);
        let mut excluded: Vec<String> = vision.skipped.iter().map(|s| s.to_string()).collect();
        excluded.extend(failed.iter().map(|(pose, e)| format!("pose {pose}: nominal forward kinematics: {e}")));
        let (fit_set, held_set): (Vec<_>, Vec<_>) = all.iter().enumerate().partition(|(k, (o, _))| {
            config.holdout_every == 0 || o.pose == vision.reference_pose || (k + 1) % config.holdout_every != 0
        });
        let fitted: Vec<Observation> = fit_set.iter().map(|(_, (o, _))| *o).collect();
        let held_out: Vec<Observation> = held_set.iter().map(|(_, (o, _))| *o).collect();
        // Enough poses for the free parameters, checked before the registration indexes them (the
        // entries do not depend on the rotations: the free mask is known before the registration).
        let layout = Parameterisation::new(
            *nominal_spm.geometry(),
            Rotation3::identity(),
            Rotation3::identity(),
            &config.bounds,
        );
        let free = crate::calib::joint_scales::counted(&layout, &free_of(&layout, &config.frozen_groups()), config);
        check_enough(&free, fitted.len(), "poses")?;
        // Nothing moving is its own problem, not "one axis": say which.
        let max_deg = fitted.iter().map(|o| o.measured.angle().to_degrees()).fold(0.0, f64::max);
        if max_deg < MIN_MOTION_DEG {
            return Err(CalibError::NoMotion { max_deg, unidentifiable: Vec::new() });
        }
        let predicted: Vec<Rotation3<f64>> = fit_set.iter().map(|(_, (_, r))| *r).collect();
        let (camera0, reference0) =
            registration::from_rotations(&fitted, &predicted, vision.reference_pose).ok_or(CalibError::Registration)?;
        let p = Parameterisation::new(*nominal_spm.geometry(), camera0, reference0, &config.bounds)
            .with_platform_sag(nominal_spm.platform_sag());
        // The correction applied, written with the result (a perfect camera's is no model at all).
        let camera_model = match config.camera_terms.model(config.camera_model_or_rigid()) {
            m if m.is_perfect() => CameraModel::rigid(),
            m => m,
        };
        Ok(OrientationLevel {
            p,
            fitted,
            held_out,
            vision,
            freeze: config.frozen_groups(),
            max_deg,
            excluded,
            camera_model,
            workspace: config.workspace,
        })
    }
}

fn free_of(p: &Parameterisation, freeze: &[Group]) -> Vec<bool> {
    p.entries.iter().map(|e| !freeze.contains(&e.kind.group())).collect()
}

impl Level for OrientationLevel {
    type Problem<'a>
        = OrientationResiduals<'a>
    where
        Self: 'a;

    fn parameterisation(&self) -> &Parameterisation {
        &self.p
    }

    fn problem(&self) -> OrientationResiduals<'_> {
        OrientationResiduals::new(&self.p, &self.fitted)
    }

    fn free(&self) -> Vec<bool> {
        free_of(&self.p, &self.freeze)
    }

    fn motion_deg(&self) -> f64 {
        self.max_deg
    }

    fn origin(&self, model: &OrientationResiduals<'_>, j: usize) -> Origin {
        (model.observations()[j].pose, None, 0)
    }

    fn finish(&self, r: LevelResults<'_, OrientationResiduals<'_>>) -> Result<LevelReport, CalibError> {
        let (p, x, cov) = (&self.p, &r.calibrated.x, r.covariance);
        let held = |x: &DVector<f64>| -> Result<Vec<Vector3<f64>>, CalibError> {
            if self.held_out.is_empty() {
                return Ok(Vec::new());
            }
            let eval =
                OrientationResiduals::new(p, &self.held_out).evaluate(x, None, false).map_err(CalibError::HeldOut)?;
            Ok(eval.residuals)
        };
        let held_out_residuals = [held(&r.nominal.x)?, held(x)?];
        let stats = |residuals: &[Vector3<f64>]| (!self.held_out.is_empty()).then(|| degrees(residuals));
        let before =
            ErrorStats { fit: degrees(&r.nominal.evaluation.residuals), held_out: stats(&held_out_residuals[0]) };
        let after =
            ErrorStats { fit: degrees(&r.calibrated.evaluation.residuals), held_out: stats(&held_out_residuals[1]) };
        // Orientations fix R_CB; t_CB comes from the centre of rotation. When the poses leave the
        // centre undetermined (all about one axis) no registration is written rather than a
        // made-up t_CB.
        let centre = self.vision.centre;
        let parameters = Parameters {
            markers: Vec::new(),
            latency_s: None,
            clock_rate_ppm: None,
            source: ParameterSource::Calibrated,
            model: Some(r.robot.reference().display().to_string()),
            model_sha256: Some(r.robot.sha256.clone()),
            legs: p.legs(x),
            camera: centre
                .map(|c| CameraRegistration { rotation: p.camera(x), translation: Vector3::from(c.position_m) }),
            camera_model: self.camera_model,
            platform_sag_deg: p.platform_sag(x).to_degrees(),
            platform_sag_std_error_deg: crate::calib::uncertainty::platform_sag_std_error_deg(p, cov, &r.free),
            fit: None,
        };
        let eval = &r.calibrated.evaluation;
        let pose_ids: Vec<u64> = r.problem.observations().iter().map(|o| o.pose).collect();
        let fda = vec![true; p.len()];
        let (poses, beyond_the_session) = PredictionPoses::of(
            self.workspace.as_ref(),
            p,
            x,
            eval.orientation_jacobians.as_deref(),
            &eval.orientations,
            &pose_ids,
        );
        let (predicted_error_deg, predicted_error_unwidened_deg) =
            PredictionPoses::plain_and_widened(poses.as_ref(), r.predicted_covariance, cov, &fda);
        let residual_sigma_deg = r.calibrated.weighting.noise.as_ref().map_or_else(Vec::new, |classes| {
            classes
                .iter()
                .map(|(m, n, c)| (*m, *n, [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt().to_degrees())))
                .collect()
        });
        let gross = r
            .flagged
            .iter()
            .filter(|f| f.excluded)
            .map(|f| format!("pose {}: gross error ({:.3} deg, {:.1} sigma)", f.pose, f.residual, f.sigmas));
        Ok(LevelReport {
            parameters,
            fitted: Fitted::Orientations {
                fitted: r.problem.observations().to_vec(),
                held_out: self.held_out.clone(),
                held_out_residuals: Box::new(held_out_residuals),
                vision: Box::new(self.vision.clone()),
            },
            vision_method: None,
            before,
            after,
            held_out_poses: self.held_out.len(),
            // The joint scales are reported on their own (`CalibrationReport::joint_scales`), not in degrees.
            parameters_report: parameter_reports(p, x, cov, &r.free)
                .into_iter()
                .zip(&p.entries)
                .filter(|(_, e)| !matches!(e.kind, Kind::Scale { .. }))
                .map(|(r, _)| r)
                .collect(),
            predicted_error_deg,
            predicted_error_unwidened_deg,
            predicted_error_mm: None,
            residual_sigma_deg,
            camera_translation_m: centre.map(|c| c.position_m),
            camera_translation_std_error_m: centre.map(|c| c.std_error_m),
            markers: None,
            excluded: self.excluded.iter().cloned().chain(gross).collect(),
            notes: Vec::new(),
            findings: beyond_the_session.into_iter().collect(),
        })
    }
}
