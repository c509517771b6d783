//! The scene of each command: what `replay`, `simulate`, `estimate`, `calibrate`, `compare` and
//! `plan` put in their recordings.

use std::collections::BTreeMap;

use nalgebra::{Rotation3, Vector2, Vector3};

use super::scene::{ImagePlanes, PixelLayer, PoseFrames, Scene, Series};
use crate::calib::FitLevel as Level;
use crate::calib::{Calibration, Fitted, marker_pose_errors, observations, per_pose_rms, registration};
use crate::compare::SetComparison;
use crate::dataset::Session;
use crate::model::{CameraModel, CameraRegistration, Parameters, Rig, RobotModel, Spm};
use crate::report::tables;
use crate::vision::{MarkerError, Method, SessionEstimate, VisionError};

/// Why a scene could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    #[error("vision: {0}")]
    /// The vision estimate failed.
    Vision(#[from] VisionError),
    #[error("parameters: {0}")]
    /// A parameter set makes no valid manipulator.
    Parameters(#[from] crate::model::SpmError),
    #[error("marker-level comparison: {0}")]
    /// The markers cannot be compared with the model.
    Markers(#[from] crate::calib::SetError),
    #[error("the camera registration cannot be estimated: too few poses, or every pose rotates about one axis")]
    /// No camera registration can be estimated.
    Registration,
    #[error("reference pose {pose}: forward kinematics failed: {error}")]
    /// The reference pose has no forward kinematics.
    ReferencePose {
        /// Pose id.
        pose: u64,
        /// Why.
        error: crate::model::FdaError,
    },
}

/// MP orientations by forward kinematics, pose by pose (poses whose FDA fails are left out).
fn fda_frames(name: &str, spm: &Spm, session: &Session) -> PoseFrames {
    let rotations = session.poses.iter().filter_map(|p| spm.forward(&p.joints).ok().map(|r| (p.id, r))).collect();
    PoseFrames { name: name.to_string(), rotations }
}

/// The vision orientations in the base frame, `R_CBᵀ Q_j A`.
fn vision_frames(estimate: &SessionEstimate, camera: &Rotation3<f64>, reference: &Rotation3<f64>) -> PoseFrames {
    let rotations = estimate.poses.iter().map(|(pose, e)| (*pose, camera.inverse() * e.rotation * reference)).collect();
    PoseFrames { name: "vision".to_string(), rotations }
}

fn e_series(estimate: &SessionEstimate) -> Series {
    Series { name: "e_j".into(), values: estimate.poses.iter().map(|(p, e)| (*p, e.error)).collect() }
}

/// How vision is put in the base frame: the camera rotation `R_CB` and the reference rotation
/// `A`, plus the full registration (with `t_CB`) when it is known.
struct VisionPlacement {
    camera: Rotation3<f64>,
    reference: Rotation3<f64>,
    /// `None` when the poses leave the centre of rotation, and so `t_CB`, undetermined.
    registration: Option<CameraRegistration>,
}

/// Camera rotation and reference rotation `A` for showing vision in the base frame: from the
/// parameters when they carry a registration, else fitted as `calibrate` starts it. Nothing is
/// made up: a reference pose without FDA is an error, an unknown `t_CB` stays unknown.
fn registration(
    session: &Session,
    spm: &Spm,
    estimate: &SessionEstimate,
    params: Option<&Parameters>,
) -> Result<VisionPlacement, SceneError> {
    let reference = session.reference();
    let r_ref =
        spm.forward(&reference.joints).map_err(|error| SceneError::ReferencePose { pose: reference.id, error })?;
    if let Some(camera) = params.and_then(|p| p.camera) {
        let reference = camera.rotation * r_ref;
        return Ok(VisionPlacement { camera: camera.rotation, reference, registration: Some(camera) });
    }
    let (kept, _) = observations(session, estimate, spm);
    if kept.len() < 2 {
        return Err(SceneError::Registration);
    }
    let (observed, predicted): (Vec<_>, Vec<_>) = kept.into_iter().unzip();
    let (rotation, a) =
        registration::from_rotations(&observed, &predicted, estimate.reference_pose).ok_or(SceneError::Registration)?;
    let registration =
        estimate.centre.map(|c| CameraRegistration { rotation, translation: Vector3::from(c.position_m) });
    Ok(VisionPlacement { camera: rotation, reference: a, registration })
}

impl Scene<'_> {
    /// `spmcal replay`: the mechanism from the joints (with `params`, else nominal), the markers from
    /// the camera, the MP frames from FDA and vision, and `e_j`.
    ///
    /// # Errors
    /// A [`SceneError`] when the vision estimate fails, a parameter set is invalid, no registration can be estimated or the reference pose has no FDA; with no pose that sees three markers, when the markers cannot be compared with the model.
    pub fn replay<'a>(
        session: &'a Session,
        model: &'a RobotModel,
        params: Option<&Parameters>,
    ) -> Result<Scene<'a>, SceneError> {
        match SessionEstimate::of(session, Method::Kabsch) {
            Ok(estimate) => vision_scene(session, model, params, &estimate),
            // Nothing for the per-pose estimator (one marker at a time): the mechanism, and the
            // measured markers through the parameters' registration (or the best-fit one), with each
            // pose's marker error.
            Err(VisionError { reason: MarkerError::NoPoseWithThree { .. }, .. }) => {
                let nominal = Parameters::nominal(&model.spm, None);
                let (label, p) = match params {
                    Some(p) => ("fda_calibrated", p),
                    None => ("fda_nominal", &nominal),
                };
                let (errors, camera) = marker_pose_errors(session, model, p)?;
                let spm = p.spm()?;
                Ok(Scene {
                    session,
                    model,
                    frames: vec![fda_frames(label, &spm, session)],
                    mechanism: spm,
                    registration: Some(camera),
                    camera_model: CameraModel::rigid(),
                    series: vec![Series {
                        name: "markers_mm/replayed".into(),
                        values: errors.per_pose.into_iter().collect(),
                    }],
                    iterations: Vec::new(),
                    documents: vec![("used".to_string(), tables::parameters("Parameters used", p))],
                    fitted_markers: fitted_markers(session, p),
                    image_planes: None,
                }
                .with_image_planes(None, None))
            }
            Err(e) => Err(e.into()),
        }
    }
}

/// The marker positions a parameters file carries, in the session's marker order (all or none).
fn fitted_markers(session: &Session, params: &Parameters) -> Option<Vec<nalgebra::Vector3<f64>>> {
    session.markers.iter().map(|name| params.marker(name)).collect()
}

/// A pixel session's measured pixels, pose by pose.
fn measured_pixels(session: &Session) -> PixelLayer {
    let pixels = session
        .poses
        .iter()
        .map(|p| (p.id, p.pixels.iter().map(|s| (s.camera, s.marker, s.pixel)).collect()))
        .collect();
    PixelLayer { name: "measured".into(), pixels }
}

impl Scene<'_> {
    /// A pixel session's image planes drawn through `rig` (the session's when `None`): the
    /// measured pixels and, with a registration, where the scene's mechanism (forward kinematics
    /// at each pose), markers (`markers`, else the scene's fitted ones, else the model's) and
    /// registration put each of them (`predicted`). A session of points is left as it is.
    fn with_image_planes(mut self, rig: Option<&Rig>, markers: Option<Vec<Vector3<f64>>>) -> Self {
        let Some(rig) = rig.or(self.session.rig.as_deref()) else { return self };
        let mut layers = vec![measured_pixels(self.session)];
        let by_name = |name: &String| self.model.markers.iter().find(|m| &m.name == name).map(|m| m.position);
        let markers: Option<Vec<Vector3<f64>>> = markers
            .or_else(|| self.fitted_markers.clone())
            .or_else(|| self.session.markers.iter().map(by_name).collect());
        if let (Some(reg), Some(markers)) = (&self.registration, markers) {
            let mut pixels = BTreeMap::new();
            for pose in &self.session.poses {
                let Ok(r) = self.mechanism.forward(&pose.joints) else { continue };
                let seen = pose.pixels.iter().filter_map(|s| {
                    let y = reg.to_camera(&(r * markers.get(s.marker)?));
                    Some((s.camera, s.marker, rig.project(s.camera, &y)?.lens.pixel))
                });
                pixels.insert(pose.id, seen.collect());
            }
            layers.push(PixelLayer { name: "predicted".into(), pixels });
        }
        self.image_planes = Some(ImagePlanes { rig: rig.clone(), layers });
        self
    }
}

/// The pixels a marker-level calibration's observations predict with `residuals` (measured less
/// residual), pose by pose; `measured` gives the observations' own pixels instead.
fn fitted_pixels(name: &str, calibration: &Calibration, residuals: Option<&[Vector3<f64>]>) -> PixelLayer {
    let mut pixels: BTreeMap<u64, Vec<(usize, usize, Vector2<f64>)>> = BTreeMap::new();
    for (k, o) in marker_observations_of(calibration).iter().enumerate() {
        let Some(camera) = o.camera else { continue };
        let r = residuals.and_then(|r| r.get(k)).copied().unwrap_or_else(Vector3::zeros);
        let pixel = Vector2::new(o.measured.x - r.x, o.measured.y - r.y);
        pixels.entry(o.pose).or_default().push((camera, o.marker, pixel));
    }
    PixelLayer { name: name.into(), pixels }
}

impl Scene<'_> {
    /// `spmcal estimate --rrd`: a nominal replay whose vision frames and `e_j` are `estimate`'s, the
    /// ones the command computed (with the method it was asked for).
    ///
    /// # Errors
    /// A [`SceneError`] when no registration can be estimated or the reference pose has no FDA.
    pub fn estimate<'a>(
        session: &'a Session,
        model: &'a RobotModel,
        estimate: &SessionEstimate,
    ) -> Result<Scene<'a>, SceneError> {
        vision_scene(session, model, None, estimate)
    }
}

/// The mechanism (with `params`, else nominal) and the vision estimate of a session.
fn vision_scene<'a>(
    session: &'a Session,
    model: &'a RobotModel,
    params: Option<&Parameters>,
    estimate: &SessionEstimate,
) -> Result<Scene<'a>, SceneError> {
    let spm = match params {
        Some(p) => p.spm()?,
        None => model.spm.clone(),
    };
    let placement = registration(session, &spm, estimate, params)?;
    let name = if params.is_some() { "fda_calibrated" } else { "fda_nominal" };
    let mut documents =
        vec![("nominal".to_string(), tables::parameters("Nominal parameters", &Parameters::nominal(&model.spm, None)))];
    if let Some(p) = params {
        documents.push(("used".to_string(), tables::parameters("Parameters used", p)));
    }
    Ok(Scene {
        session,
        model,
        frames: vec![fda_frames(name, &spm, session), vision_frames(estimate, &placement.camera, &placement.reference)],
        mechanism: spm,
        registration: placement.registration,
        camera_model: CameraModel::rigid(),
        series: vec![e_series(estimate)],
        iterations: Vec::new(),
        documents,
        fitted_markers: params.and_then(|p| fitted_markers(session, p)),
        image_planes: None,
    }
    .with_image_planes(None, None))
}

impl Scene<'_> {
    /// `spmcal simulate --rrd`: the true mechanism and camera, the true MP frames, the measured markers.
    ///
    /// # Errors
    /// A [`SceneError`] when the true parameters make no valid manipulator.
    pub fn simulation<'a>(session: &'a Session, model: &'a RobotModel) -> Result<Scene<'a>, SceneError> {
        let truth = session.truth.as_ref();
        let spm = match truth {
            Some(t) => t.parameters.spm()?,
            None => model.spm.clone(),
        };
        let frames =
            truth.map(|t| PoseFrames { name: "truth".into(), rotations: t.orientations.clone() }).into_iter().collect();
        let documents = truth
            .map(|t| ("truth".to_string(), tables::parameters("True parameters", &t.parameters)))
            .into_iter()
            .collect();
        Ok(Scene {
            session,
            model,
            mechanism: spm,
            registration: truth.and_then(|t| t.parameters.camera),
            camera_model: truth.map(|t| t.parameters.camera_model).unwrap_or_default(),
            frames,
            series: Vec::new(),
            iterations: Vec::new(),
            documents,
            fitted_markers: None,
            image_planes: None,
        }
        .with_image_planes(
            truth.and_then(|t| t.rig.as_ref()),
            truth.and_then(|t| fitted_markers(session, &t.parameters)),
        ))
    }
}

impl Scene<'_> {
    /// `spmcal plan --rrd`: the planned poses in capture order (the mechanism drawn at each, the MP
    /// frame where it should be), the predicted orientation error after calibration at each, and
    /// the map of that error over the workspace. `session` is [`crate::plan::Plan::session`].
    ///
    /// # Errors
    /// A [`SceneError`] when `params` make no valid manipulator.
    pub fn plan<'a>(
        session: &'a Session,
        model: &'a RobotModel,
        plan: &crate::plan::Plan,
        params: Option<&Parameters>,
    ) -> Result<Scene<'a>, SceneError> {
        let spm = params.map(Parameters::spm).transpose()?.unwrap_or_else(|| model.spm.clone());
        let rotations = plan.poses.iter().map(|p| (p.step, p.rotation)).collect();
        let at_pose = |p: &crate::plan::PlannedPose| {
            let candidate = plan.candidates.iter().position(|c| c.rotation == p.rotation);
            (p.step, candidate.map_or(f64::NAN, |c| plan.uncertainty_deg[c]))
        };
        Ok(Scene {
            session,
            model,
            mechanism: spm,
            registration: params.and_then(|p| p.camera),
            camera_model: params.map(|p| p.camera_model).unwrap_or_default(),
            frames: vec![PoseFrames { name: "planned".into(), rotations }],
            series: vec![Series {
                name: "predicted_error_deg".into(),
                values: plan.poses.iter().map(at_pose).collect(),
            }],
            iterations: Vec::new(),
            documents: vec![("uncertainty_map".into(), plan.uncertainty_map())],
            fitted_markers: None,
            image_planes: None,
        })
    }
}

/// Per-pose FDA-vs-vision angles (degrees) of a fitted parameter vector, fitted and held-out poses.
fn residual_series(name: &str, calibration: &Calibration, which: usize) -> Series {
    let mut values = BTreeMap::new();
    if let Fitted::Orientations { fitted, held_out, held_out_residuals, .. } = &calibration.fitted {
        let fit = [&calibration.nominal, &calibration.calibrated][which];
        for (set, residuals) in [(fitted, &fit.residuals), (held_out, &held_out_residuals[which])] {
            values.extend(set.iter().zip(residuals).map(|(o, r)| (o.pose, r.norm().to_degrees())));
        }
    }
    Series { name: format!("fda_vs_vision/{name}"), values }
}

/// The marker observations a calibration fitted (none for an orientation-level one).
fn marker_observations_of(calibration: &Calibration) -> &[crate::calib::MarkerObservation] {
    match &calibration.fitted {
        Fitted::Markers(observations) => observations,
        _ => &[],
    }
}

/// Whether a calibration fitted pixels (its residuals in px) rather than points (in m).
fn fits_pixels(calibration: &Calibration) -> bool {
    marker_observations_of(calibration).iter().any(|o| o.camera.is_some())
}

/// Per-pose RMS over its markers of the distance between measured and predicted markers: in mm
/// (`markers_mm/NAME`), or for pixels in px (`pixels_px/NAME`).
fn marker_series(name: &str, calibration: &Calibration, residuals: &[nalgebra::Vector3<f64>]) -> Series {
    let observations = marker_observations_of(calibration);
    match fits_pixels(calibration) {
        true => Series {
            name: format!("pixels_px/{name}"),
            values: per_pose_rms(observations, residuals, 1.0).into_iter().collect(),
        },
        false => Series {
            name: format!("markers_mm/{name}"),
            values: per_pose_rms(observations, residuals, 1e3).into_iter().collect(),
        },
    }
}

/// Each marker's residual at each pose that saw it: mm (`marker_residuals_mm/MARKER`), or for
/// pixels the RMS over the cameras that saw it in px (`pixel_residuals_px/MARKER`).
fn marker_residuals(session: &Session, calibration: &Calibration, residuals: &[nalgebra::Vector3<f64>]) -> Vec<Series> {
    let pixels = fits_pixels(calibration);
    session
        .markers
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let (observations, residuals): (Vec<_>, Vec<_>) = marker_observations_of(calibration)
                .iter()
                .zip(residuals)
                .filter(|(o, _)| o.marker == k)
                .map(|(o, r)| (*o, *r))
                .unzip();
            let (prefix, scale) = if pixels { ("pixel_residuals_px", 1.0) } else { ("marker_residuals_mm", 1e3) };
            Series {
                name: format!("{prefix}/{name}"),
                values: per_pose_rms(&observations, &residuals, scale).into_iter().collect(),
            }
        })
        .collect()
}

impl Scene<'_> {
    /// `spmcal calibrate --rrd`: nominal, calibrated and vision MP frames, the errors before and after,
    /// the fit's iterations, and the parameters before and after.
    ///
    /// # Errors
    /// A [`SceneError`] when the calibrated parameters make no valid manipulator.
    pub fn calibration<'a>(
        session: &'a Session,
        model: &'a RobotModel,
        calibration: &Calibration,
    ) -> Result<Scene<'a>, SceneError> {
        let p = &calibration.parameterisation;
        let x = &calibration.calibrated.x;
        let spm = calibration.parameters.spm()?;
        let mut frames =
            vec![fda_frames("fda_nominal", &model.spm, session), fda_frames("fda_calibrated", &spm, session)];
        let mut series = Vec::new();
        if let Fitted::Orientations { vision, .. } = &calibration.fitted {
            frames.push(vision_frames(vision, &p.camera(x), &p.reference(x)));
            series.push(e_series(vision));
            series.push(residual_series("nominal", calibration, 0));
            series.push(residual_series("calibrated", calibration, 1));
        } else {
            // The residuals the fit kept, nominal and calibrated (each at its own latency).
            let after = &calibration.calibrated.residuals;
            series.push(marker_series("nominal", calibration, &calibration.nominal.residuals));
            series.push(marker_series("calibrated", calibration, after));
            series.extend(marker_residuals(session, calibration, after));
        }
        // The report's predicted error of the calibrated model at each pose (the same figures as
        // `--json`'s `predicted_error_deg` / `predicted_error_mm`, the latter in px for a fit of
        // pixels, and so recorded as `predicted_error_px`).
        let report = &calibration.report;
        let markers = if fits_pixels(calibration) { "predicted_error_px" } else { "predicted_error_mm" };
        for (name, predicted) in
            [("predicted_error_deg", &report.predicted_error_deg), (markers, &report.predicted_error_mm)]
        {
            if let Some(e) = predicted {
                series.push(Series { name: name.into(), values: e.per_pose.iter().copied().collect() });
            }
        }
        let fitted_markers = (!marker_observations_of(calibration).is_empty())
            .then(|| (0..p.markers0.len()).map(|k| p.marker(x, k)).collect());
        let after = tables::calibrated_parameters(calibration);
        // A pixel session's image planes through the refined rig: the pixels the fit measured, and
        // what the calibrated and the nominal model predict for them (measured less residual).
        let refined = report.markers.as_ref().and_then(|m| m.rig.as_ref()).map(|r| &r.refined);
        let image_planes =
            refined.or(session.rig.as_deref()).filter(|_| fits_pixels(calibration)).map(|rig| ImagePlanes {
                rig: rig.clone(),
                layers: vec![
                    fitted_pixels("measured", calibration, None),
                    fitted_pixels("predicted", calibration, Some(&calibration.calibrated.residuals)),
                    fitted_pixels("nominal", calibration, Some(&calibration.nominal.residuals)),
                ],
            });
        Ok(Scene {
            session,
            model,
            frames,
            mechanism: spm,
            registration: calibration.parameters.camera,
            camera_model: calibration.parameters.camera_model,
            series,
            iterations: calibration.calibrated.log.clone(),
            documents: vec![
                (
                    "before".to_string(),
                    tables::parameters("Nominal parameters", &Parameters::nominal(&model.spm, None)),
                ),
                ("after".to_string(), after),
            ]
            .into_iter()
            .chain(
                calibration
                    .report
                    .predicted_error_deg
                    .as_ref()
                    .map(|e| ("predicted_error_map".to_string(), tables::predicted_error_by_region(e))),
            )
            .collect(),
            fitted_markers,
            image_planes,
        })
    }
}

impl Scene<'_> {
    /// `spmcal compare --rrd`: each parameter set's MP frames and per-pose errors, with vision by the
    /// estimator the comparison used.
    ///
    /// # Errors
    /// A [`SceneError`] when the vision estimate fails, a parameter set is invalid, no registration can be estimated or the reference pose has no FDA.
    pub fn comparison<'a>(
        session: &'a Session,
        model: &'a RobotModel,
        sets: &[(String, Parameters)],
        results: &[SetComparison],
        method: Method,
    ) -> Result<Scene<'a>, SceneError> {
        let last = sets.last().map(|(_, p)| p);
        let mut scene = if results.iter().any(|r| r.level == Level::Markers) {
            // The measured markers through the last set's registration, as `replay` shows them.
            let mut scene = Scene::replay(session, model, last)?;
            scene.frames.clear();
            scene.series.clear();
            scene
        } else {
            let estimate = SessionEstimate::of(session, method)?;
            let mut scene = vision_scene(session, model, last.filter(|p| p.camera.is_some()), &estimate)?;
            scene.frames.retain(|f| f.name == "vision");
            scene
        };
        for (label, params) in sets {
            scene.frames.push(fda_frames(&format!("fda_{label}"), &params.spm()?, session));
            scene.documents.push((label.clone(), tables::parameters(label, params)));
        }
        for r in results {
            scene.series.push(Series { name: comparison_series(r), values: r.per_pose.iter().copied().collect() });
        }
        Ok(scene)
    }
}

/// The entity of a comparison's per-pose errors: `fda_vs_vision/LABEL` (degrees),
/// `markers_mm/LABEL`, or for a pixel session's reprojection error `pixels_px/LABEL`.
fn comparison_series(r: &SetComparison) -> String {
    match (r.level, r.unit) {
        (Level::Orientations, _) => format!("fda_vs_vision/{}", r.label),
        (Level::Markers, "px") => format!("pixels_px/{}", r.label),
        (Level::Markers, _) => format!("markers_mm/{}", r.label),
    }
}
