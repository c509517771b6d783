//! The orientation-level fit (`fit: orientations`): the per-pose orientations of the vision
//! estimator (poses that see at least three markers) against the FDA, every `holdout_every`-th
//! pose held out of the fit to check it; `t_CB` comes from the centre of rotation.

use nalgebra::{DVector, Rotation3, Vector3};

use crate::calib::agreement::degrees;
use crate::calib::config::{CalibConfig, Group};
use crate::calib::model::Model;
use crate::calib::orientation_model::{Observation, OrientationModel, observations};
use crate::calib::params::Parameterisation;
use crate::calib::pipeline::{
    CalibError, Calibration, Fitted, Level, MIN_MOTION_DEG, Origin, Results, Solution, check_enough,
};
use crate::calib::registration;
use crate::calib::report::Errors;
use crate::calib::uncertainty::{parameter_reports, predicted_orientation_error};
use crate::dataset::Session;
use crate::math::stats::Stats;
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
        check_enough(&free_of(&layout, &config.freeze), fitted.len(), "poses")?;
        // Nothing moving is its own problem, not "one axis": say which.
        let max_deg = fitted.iter().map(|o| o.measured.angle().to_degrees()).fold(0.0, f64::max);
        if max_deg < MIN_MOTION_DEG {
            return Err(CalibError::NoMotion { max_deg, unidentifiable: Vec::new() });
        }
        let predicted: Vec<Rotation3<f64>> = fit_set.iter().map(|(_, (_, r))| *r).collect();
        let (camera0, reference0) =
            registration::from_rotations(&fitted, &predicted, vision.reference_pose).ok_or(CalibError::Registration)?;
        let p = Parameterisation::new(*nominal_spm.geometry(), camera0, reference0, &config.bounds);
        // The correction applied, written with the result (a perfect camera's is no model at all).
        let camera_model = match config.camera_terms.model(config.camera_model) {
            m if m.is_perfect() => CameraModel::rigid(),
            m => m,
        };
        Ok(OrientationLevel {
            p,
            fitted,
            held_out,
            vision,
            freeze: config.freeze.clone(),
            max_deg,
            excluded,
            camera_model,
        })
    }
}

fn free_of(p: &Parameterisation, freeze: &[Group]) -> Vec<bool> {
    p.entries.iter().map(|e| !freeze.contains(&e.kind.group())).collect()
}

impl Level for OrientationLevel {
    type Model<'a>
        = OrientationModel<'a>
    where
        Self: 'a;

    fn parameterisation(&self) -> &Parameterisation {
        &self.p
    }

    fn model(&self) -> OrientationModel<'_> {
        OrientationModel::new(&self.p, &self.fitted)
    }

    fn free(&self) -> Vec<bool> {
        free_of(&self.p, &self.freeze)
    }

    fn motion_deg(&self) -> f64 {
        self.max_deg
    }

    fn origin(&self, model: &OrientationModel<'_>, j: usize) -> Origin {
        (model.observations()[j].pose, None, 0)
    }

    fn finish(&self, r: Results<'_, OrientationModel<'_>>) -> Result<Calibration, CalibError> {
        let (p, x, cov) = (&self.p, &r.calibrated.x, &r.covariance);
        let held = |x: &DVector<f64>| -> Result<Option<Stats>, CalibError> {
            if self.held_out.is_empty() {
                return Ok(None);
            }
            let eval =
                OrientationModel::new(p, &self.held_out).evaluate(x, None, false).map_err(CalibError::HeldOut)?;
            Ok(Some(degrees(&eval.residuals)))
        };
        let mut report = r.report;
        report.before = Errors { fit: degrees(&r.nominal.evaluation.residuals), held_out: held(&r.nominal.x)? };
        report.after = Errors { fit: degrees(&r.calibrated.evaluation.residuals), held_out: held(x)? };
        report.held_out_poses = self.held_out.len();
        // Orientations fix R_CB; t_CB comes from the centre of rotation. When the poses leave the
        // centre undetermined (all about one axis) no registration is written rather than a
        // made-up t_CB.
        let centre = self.vision.centre;
        let parameters = Parameters {
            markers: Vec::new(),
            latency_s: None,
            source: ParameterSource::Calibrated,
            model: Some(crate::io::files::tidy_path(&r.robot.urdf_path).display().to_string()),
            legs: p.legs(x),
            camera: centre
                .map(|c| CameraRegistration { rotation: p.camera(x), translation: Vector3::from(c.position_m) }),
            camera_model: self.camera_model,
            fit: None,
        };
        report.parameters = parameter_reports(p, x, cov, &r.free);
        let eval = &r.calibrated.evaluation;
        let pose_ids: Vec<u64> = r.model.observations().iter().map(|o| o.pose).collect();
        let fda = vec![true; p.len()];
        report.predicted_error_deg = eval
            .orientation_jacobians
            .as_ref()
            .and_then(|s| predicted_orientation_error(s, &eval.orientations, &pose_ids, &fda, cov));
        report.residual_sigma_deg = r.calibrated.weighting.noise.as_ref().map_or_else(Vec::new, |classes| {
            classes
                .iter()
                .map(|(m, n, c)| (*m, *n, [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt().to_degrees())))
                .collect()
        });
        report.camera_translation_m = centre.map(|c| c.position_m);
        report.camera_translation_std_error_m = centre.map(|c| c.std_error_m);
        let gross = report
            .flagged
            .iter()
            .filter(|f| f.excluded)
            .map(|f| format!("pose {}: gross error ({:.3} deg, {:.1} sigma)", f.pose, f.residual, f.sigmas));
        let mut excluded: Vec<String> = self.excluded.iter().cloned().chain(gross).collect();
        excluded.append(&mut report.excluded);
        report.excluded = excluded;
        Ok(Calibration {
            parameters,
            report,
            parameterisation: p.clone(),
            fitted: Fitted::Orientations {
                fitted: r.model.observations().to_vec(),
                held_out: self.held_out.clone(),
                vision: Box::new(self.vision.clone()),
            },
            nominal: Solution::of(&r.nominal),
            calibrated: Solution::of(&r.calibrated),
            covariance: r.covariance,
        })
    }
}
