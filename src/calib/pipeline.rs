//! The calibration of a session, one pipeline for every fit level:
//!
//! observations → a [`Residuals`] (the [`Level`] prepares it) → the nominal baseline (registration
//! alone) → identifiability → the robust fit → gross errors excluded and refitted → uncertainty →
//! cross-validation → one verdict → the level's parameters file and report.
//!
//! What differs between the orientation-level and the marker-level fit is only what differs in
//! their data and model: how observations are made and registered, and what their report adds.
//! With `camera_model: auto` the marker level's camera model is chosen first (`camera_choice.rs`,
//! from one fit of the projective model) and the pipeline then runs the choice as if it had been
//! named, adding the choice to its report.

use nalgebra::DVector;

use super::agreement::{best_registration, registration_mask};
use super::calibration::{CalibError, Calibration, Solution};
use super::camera_choice::{CameraModelChoice, MOST_OBSERVATIONS, choose, subsample};
use super::config::{CalibConfig, FitLevel, Group, IfNotBetter, Unidentifiable};
use super::fit::{FitOutcome, FitSettings, IterationLog, fit};
use super::identify::Direction;
use super::joint_scales;
use super::level::{Level, LevelResults, MIN_MOTION_DEG, Origin, check_enough};
use super::model_check::Structure;
use super::parameterisation::{Kind, Parameterisation};
use super::platform_sag::{self, Trial};
use super::report::{CalibrationReport, FlaggedObservation, Verdict};
use super::residuals::Residuals;
use super::uncertainty::{covariance, identifiability_at};
use super::validation::{CrossValidation, cross_validate};
use super::{levels, report};
use crate::dataset::Session;
use crate::model::{CameraModelKind, RobotModel};

/// Calibrate `session` on the nominal `robot`; `on_iteration` sees every iteration of the main fit.
///
/// # Errors
/// A [`CalibError`] for an invalid config, too few usable poses, no motion, no starting
/// registration, unidentifiable directions (with `unidentifiable: refuse`), a failed fit, a
/// calibration not better than nominal (with `if_not_better: refuse`) or an unpredictable
/// held-out pose.
pub fn calibrate(
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    config.check().map_err(|(key, reason)| CalibError::Config { key, reason })?;
    // A free-motion recording's poses at the configured camera clock; when the marker-level fit
    // estimates the latency (and the clock's rate), only frames inside the encoder stream for
    // every latency (and rate) within their bounds.
    let clock = crate::dataset::Clock { latency_s: config.latency_s, rate_ppm: config.clock_rate_ppm };
    let range = match config.fit == FitLevel::Markers && !config.freeze.contains(&Group::Latency) {
        true => (-config.latency_bound_s, config.latency_bound_s),
        false => (clock.latency_s, clock.latency_s),
    };
    let rates = match levels::clock_rate_held(session, config) {
        None => (-config.clock_rate_bound_ppm, config.clock_rate_bound_ppm),
        Some(_) => (clock.rate_ppm, clock.rate_ppm),
    };
    let resampled = session.streams.is_some().then(|| session.at_clock_within(clock, range, rates));
    let (session, left_out) = match &resampled {
        Some((s, warnings)) => (s, warnings.iter().map(|w| w.to_string()).collect()),
        None => (session, Vec::new()),
    };
    let latency_free = resampled.is_some() && range.0 < range.1;
    // Every frame left out (a recording shorter than the latency window, or clocks that do not
    // overlap): said in those terms, not as a registration that cannot start from no observation.
    if let Some(streams) = session.streams.as_deref().filter(|_| resampled.is_some() && session.poses.is_empty()) {
        let frames = streams.frames().count();
        let (key, within) = match latency_free {
            true => ("latency_bound_s", format!("for some latency within ±{} s", config.latency_bound_s)),
            false => ("latency_s", format!("at the latency of {} s", clock.latency_s)),
        };
        let reason = format!(
            "every one of the recording's {frames} camera frames falls outside the encoder stream {within}, so none is left to calibrate from: the encoders must cover each frame's time less the latency (a recording of {:.2} s of camera time is too short for that window, or its clocks do not overlap)",
            streams.camera_span_s()
        );
        return Err(CalibError::Config { key: key.into(), reason });
    }
    // The orientation level cannot estimate the camera robot: it corrects the markers by the one
    // the config gives (the marker level fits it, starting there).
    let corrected;
    let session = match config.fit {
        FitLevel::Orientations => {
            corrected =
                session.undistorted(&config.camera_terms.model(config.camera_model_or_rigid())).ok_or_else(|| {
                    CalibError::Config { key: "camera_terms".into(), reason: "the camera robot is singular".into() }
                })?;
            &corrected
        }
        FitLevel::Markers => session,
    };
    let calibration = match config.fit {
        FitLevel::Markers => calibrate_markers(session, robot, config, left_out, on_iteration),
        FitLevel::Orientations if session.body.is_some() => Err(CalibError::Config {
            key: "fit".into(),
            reason: "a rigid body's poses are fitted at the marker level (`fit: markers`): its position and orientation are each observations there".into(),
        }),
        FitLevel::Orientations => run(
            levels::OrientationLevel::prepare(session, robot, config)?,
            session,
            robot,
            config,
            left_out,
            on_iteration,
        ),
    };
    // A fit of a free-motion recording that breaks down is most often a latency outside its
    // bound: the joints are read at the wrong instants. Say so in the user's terms first.
    match calibration {
        Err(CalibError::Fit { stage, error }) if latency_free => {
            Err(CalibError::FreeMotionFit { stage, error, latency_bound_s: config.latency_bound_s })
        }
        other => other,
    }
}

/// The marker-level calibration; with `camera_model: auto`, of the camera model chosen first,
/// run as if it had been named, with the choice added to its report and parameters file.
fn calibrate_markers(
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
    left_out: Vec<String>,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    let started = std::time::Instant::now();
    let Some((choice, iterations)) = choose_camera_model(session, robot, config) else {
        return run(
            levels::MarkerLevel::prepare(session, robot, config)?,
            session,
            robot,
            config,
            left_out,
            on_iteration,
        );
    };
    let seconds = started.elapsed().as_secs_f64();
    let chosen = CalibConfig { camera_model: choice.chosen.into(), ..config.clone() };
    let level = levels::MarkerLevel::prepare(session, robot, &chosen)?;
    let mut calibration = run(level, session, robot, &chosen, left_out, on_iteration)?;
    let stage = super::report::StageReport { name: "camera model choice", iterations, seconds };
    calibration.report.stages.insert(0, stage);
    if let Some(markers) = calibration.report.markers.as_mut() {
        markers.camera_model.choice = Some(choice);
    }
    calibration.parameters.fit = Some(report::fit_header(&calibration.report));
    Ok(calibration)
}

/// `camera_model: auto`'s choice (`camera_choice.rs`) and the iterations its fit took; `None` when
/// the config names the model. Where the projective model cannot be fitted to choose from, the
/// depth-scale model (a stereo camera's commonest error, and the default before `auto`), saying why.
fn choose_camera_model(
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
) -> Option<(CameraModelChoice, usize)> {
    if config.camera_model.named().is_some() {
        return None;
    }
    // A session seen through its pixels refines the camera rig itself: its points have no camera
    // model to choose (K = I).
    if session.rig.is_some() {
        let why = "a session seen through its pixels refines the camera rig itself, so no camera model";
        return Some((CameraModelChoice::without_choice(CameraModelKind::Rigid, why), 0));
    }
    if session.body.is_some() {
        let why = "a rigid body's poses come from a tracker, which has no line of sight: no camera model";
        return Some((CameraModelChoice::without_choice(CameraModelKind::Rigid, why), 0));
    }
    if config.freeze.contains(&Group::CameraModel) {
        let why = "the camera model is frozen (`freeze: [camera_model]`): a perfect camera";
        return Some((CameraModelChoice::without_choice(CameraModelKind::Rigid, why), 0));
    }
    Some(fit_largest_camera_model(session, robot, config).unwrap_or_else(|why| {
        let why = format!(
            "the projective model could not be fitted to choose from ({why}): depth_scale, the model of a stereo \
             camera's commonest error"
        );
        (CameraModelChoice::without_choice(CameraModelKind::DepthScale, &why), 0)
    }))
}

/// The projective model fitted as the calibration fits (registration, camera terms the data
/// cannot determine held, weak prior on unidentifiable directions, the robust fit), and the
/// nested models scored from it; the reason in words when it cannot be.
fn fit_largest_camera_model(
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
) -> Result<(CameraModelChoice, usize), String> {
    let largest = CalibConfig { camera_model: CameraModelKind::Projective.into(), ..config.clone() };
    let level = levels::MarkerLevel::prepare(session, robot, &largest).map_err(|e| e.to_string())?;
    let (p, mut free, problem) = (level.parameterisation(), level.free(), level.problem());
    // A long session is chosen for on a spread subsample (`camera_choice::MOST_OBSERVATIONS`).
    let problem = match subsample(&problem, MOST_OBSERVATIONS) {
        Some(rows) => problem.subset(&rows),
        None => problem,
    };
    check_enough(&joint_scales::counted(p, &free, config), problem.len(), problem.level().observations())
        .map_err(|e| e.to_string())?;
    if level.motion_deg() < MIN_MOTION_DEG {
        return Err(format!("the plate turns {:.2}° at most", level.motion_deg()));
    }
    let registration = registration_mask(p, &free);
    let nominal = best_registration(&problem, &p.start(), &registration, config).map_err(|e| e.to_string())?;
    let mut identifiability = identifiability_at(p, &nominal, &free, config);
    // The joint scales are free here (unless held by the config): held, a camera model would
    // be chosen to take up a scale error (a projective camera mimics part of one).
    let held = unidentified_camera_terms(p, &identifiability);
    if !held.is_empty() {
        held.iter().for_each(|&i| free[i] = false);
        identifiability = identifiability_at(p, &nominal, &free, config);
    }
    let prior = identifiability.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
    let settings = FitSettings {
        prior: prior.clone(),
        stage: "camera model choice",
        ..FitSettings::from_config(config, free.clone())
    };
    let robust = fit(&problem, &nominal.x, &settings, &mut |_| {}).map_err(|e| e.to_string())?;
    let default_folds = CalibConfig::default().folds;
    let folds = if config.folds >= 2 { config.folds } else { default_folds }.min(super::validation::groups(&problem));
    if folds < 2 {
        return Err("fewer than two poses to hold out".into());
    }
    let gross = 2.0 * config.outlier_threshold;
    let choice = choose(&problem, &robust, &free, prior.as_ref(), folds, gross)
        .ok_or("no held-out observation could be predicted")?;
    Ok((choice, robust.log.len()))
}

/// The pipeline, once for every level.
fn run<L: Level>(
    level: L,
    session: &Session,
    robot: &RobotModel,
    config: &CalibConfig,
    left_out: Vec<String>,
    on_iteration: &mut dyn FnMut(&IterationLog),
) -> Result<Calibration, CalibError> {
    let mut clock = Clock::start();
    let p = level.parameterisation();
    let mut free = level.free();
    let problem = level.problem();
    check_enough(&joint_scales::counted(p, &free, config), problem.len(), problem.level().observations())?;
    let registration = registration_mask(p, &free);
    let stage = |stage| move |error| CalibError::Fit { stage, error };
    let x0 = p.start();
    let nominal = best_registration(&problem, &x0, &registration, config).map_err(stage("nominal registration"))?;
    clock.lap("registration", nominal.log.len());
    // Identifiability at the start of the full fit; a session that barely moves is refused with
    // what it cannot tell apart.
    let mut identifiability = identifiability_at(p, &nominal, &free, config);
    // A camera term the data cannot determine is held at its start and said so, not fitted into
    // the noise (nor regularised with the mechanism).
    let held_camera = unidentified_camera_terms(p, &identifiability);
    // `joint_scales: auto` fits without the scales first, then frees them only where the data
    // show a scale error (a score test at that fit: `joint_scales::score`).
    let spans = joint_scales::spans_deg(session);
    let scale_legs = joint_scales::entries(p);
    let leg_of = |i: usize| scale_legs.iter().find(|(k, _)| *k == i).map_or(0, |(_, leg)| *leg);
    let tested: Vec<usize> = match joint_scales::auto(config) {
        true => scale_legs.iter().map(|(i, _)| *i).filter(|&i| free[i]).collect(),
        false => Vec::new(),
    };
    // `platform_sag: auto` likewise: the sag held, then tested at the fit without it.
    let sag_tested: Option<usize> =
        p.entries.iter().position(|e| e.kind == Kind::PlatformSag).filter(|&i| free[i] && config.sag_auto());
    // The scales held, each with why: the report's lines.
    let mut held_scales: Vec<(usize, String)> = Vec::new();
    if !held_camera.is_empty() || !tested.is_empty() || sag_tested.is_some() {
        held_camera.iter().chain(&tested).chain(&sag_tested).for_each(|&i| free[i] = false);
        identifiability = identifiability_at(p, &nominal, &free, config);
    }
    let camera_warnings = held_camera.iter().map(|&i| {
        format!(
            "the data cannot determine `{}` (the poses do not move the markers in the ways that tell it from the \
             mechanism and the registration): held at its start",
            p.entries[i].name
        )
    });
    let mut regularised: Vec<String> = identifiability.unidentifiable.iter().map(Direction::describe).collect();
    let max_deg = level.motion_deg();
    if max_deg < MIN_MOTION_DEG {
        let weak = if regularised.is_empty() { &identifiability.weakest } else { &identifiability.unidentifiable };
        // Directions that read alike (the same parameters, either sign) are named once: with no
        // motion the null space is wide and its basis arbitrary.
        let mut unidentifiable: Vec<String> = Vec::new();
        let mut seen: Vec<String> = Vec::new();
        for described in weak.iter().map(Direction::describe) {
            let what = described.split(" (").next().unwrap_or(&described).replace(['+', '-'], "");
            if !seen.contains(&what) {
                seen.push(what);
                unidentifiable.push(described);
            }
        }
        return Err(CalibError::NoMotion { max_deg, unidentifiable });
    }
    if !regularised.is_empty() && config.unidentifiable == Unidentifiable::Refuse {
        return Err(CalibError::Unidentifiable(regularised));
    }
    let mut prior = identifiability.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
    clock.lap("identifiability", 0);
    let mut settings =
        FitSettings { prior: prior.clone(), stage: "calibration", ..FitSettings::from_config(config, free.clone()) };
    let mut robust = fit(&problem, &nominal.x, &settings, on_iteration).map_err(stage("calibration"))?;
    clock.lap("calibration", robust.log.len());
    // `joint_scales: auto`: the scales the fit without them would determine (to ±0.1 %, or worse
    // where a scale's own score shows its error at 3σ) are tried, and `platform_sag: auto`'s sag
    // where its score at the fit without it is beyond 2σ: freed together in one trial fit, each
    // kept when the trial shows it (the Wald statistic: the score's own is blunted where the fit
    // without them bent the camera model and the robust weights to the error). Those that do not
    // show are held, the scales' lines saying why; a trial that keeps only some is fitted again
    // with those alone.
    let mut undetermined: Vec<(usize, f64, Option<f64>)> = Vec::new();
    let mut sag_held: Option<String> = None;
    let lambda = prior.as_ref().map(|(l, _)| l.clone());
    let mut groups: Vec<Trial> = Vec::new();
    if !tested.is_empty() {
        let score = joint_scales::score(&robust, &free, &tested, lambda.as_ref());
        for &(i, sigma) in &score.undetermined {
            undetermined.push((leg_of(i), spans[leg_of(i)], sigma));
            held_scales.push((i, joint_scales::held_reason(spans[leg_of(i)], sigma)));
        }
        if !score.determined.is_empty() {
            groups.push(Trial::Scales(score.determined.iter().map(|&(i, _, _)| i).collect()));
        }
    }
    if let Some(i) = sag_tested {
        match platform_sag::score(&robust, &free, i, lambda.as_ref()) {
            Some(z) if z.abs() >= platform_sag::AUTO_SCORE => {
                // The model check at this fit names the misfit's likeliest cause: a joint's scale
                // or a camera beyond its model raise the sag's score too, and a sag fitted then
                // takes up part of their misfit and hides it.
                let cov = covariance(&robust, &free, lambda.as_ref());
                let named = super::model_check::check(&problem, &robust, &free, &cov, None)
                    .and_then(|(c, _)| (!c.passed).then_some(c.cause).flatten())
                    .filter(|cause| ![Structure::Sag.name(), Structure::Overall.name()].contains(cause));
                match named {
                    Some(cause) => sag_held = Some(platform_sag::named_cause_reason(z, cause)),
                    None => groups.push(Trial::Sag(i)),
                }
            }
            z => sag_held = Some(platform_sag::held_reason(z)),
        }
    }
    let mut kept: Vec<Trial> = Vec::new();
    for round in 0..2 {
        let trying = if round == 0 { groups.clone() } else { kept.clone() };
        if trying.is_empty() || (round == 1 && kept.len() == groups.len()) {
            break;
        }
        let mut trial_free = free.clone();
        trying.iter().flat_map(Trial::indices).for_each(|i| trial_free[i] = true);
        let trial_id = identifiability_at(p, &nominal, &trial_free, config);
        let trial_prior = trial_id.prior(p.len()).map(|lambda| (lambda, nominal.x.clone()));
        let trial_settings = FitSettings {
            prior: trial_prior.clone(),
            stage: "calibration with the joint scales or the sag",
            ..FitSettings::from_config(config, trial_free.clone())
        };
        let mut trial = fit(&problem, &robust.x, &trial_settings, &mut |_| {}).map_err(stage("calibration"))?;
        clock.lap("joint-scale and sag test", trial.log.len());
        if round == 0 {
            let cov = covariance(&trial, &trial_free, trial_prior.as_ref().map(|(l, _)| l));
            // A misfit of another kind (a camera beyond its model, a joint's scale) leans on the
            // sag's column too, which the geometry leaves free to take it: a sag is kept only when,
            // fitted, it leaves no other structure for the model check to find.
            let other = sag_tested.is_some().then(|| other_structure(&problem, &trial, &trial_free, &cov)).flatten();
            for group in &groups {
                let indices = group.indices();
                let wald = joint_scales::wald(&trial.x, &cov, &indices);
                if let (Trial::Sag(i), Some(cause)) = (group, other) {
                    let sigma = cov[(*i, *i)].max(0.0).sqrt();
                    sag_held = Some(platform_sag::other_cause_reason(trial.x[*i], sigma, cause));
                    continue;
                }
                if group.shows(wald) {
                    kept.push(group.clone());
                    continue;
                }
                match group {
                    Trial::Scales(_) => {
                        for &i in &indices {
                            let sigma = cov[(i, i)].max(0.0).sqrt();
                            let change = trial.x[i] - nominal.x[i];
                            let why = joint_scales::insignificant_reason(change, sigma, wald, indices.len());
                            held_scales.push((i, why));
                        }
                    }
                    Trial::Sag(i) => {
                        let sigma = cov[(*i, *i)].max(0.0).sqrt();
                        sag_held = Some(platform_sag::insignificant_reason(trial.x[*i], sigma));
                    }
                }
            }
            if kept.len() != groups.len() {
                continue;
            }
        }
        trial.log.iter().for_each(&mut *on_iteration);
        trial.log = robust.log.iter().chain(&trial.log).copied().collect();
        robust = trial;
        free = trial_free;
        identifiability = trial_id;
        regularised = identifiability.unidentifiable.iter().map(Direction::describe).collect();
        prior = trial_prior;
        settings = trial_settings;
        break;
    }
    // Gross errors (centimetres, tens of degrees) are removed, not only down-weighted: they would
    // still pull. The baseline is refitted on the same observations as the calibration.
    let origin = |m: &L::Problem<'_>, j: usize| level.origin(m, j);
    let mut flagged = flag(&problem, &robust, config.outlier_threshold, &origin);
    let gross: Vec<usize> = flagged.iter().filter(|(_, f)| f.excluded).map(|(j, _)| *j).collect();
    let (problem, calibrated, nominal) = if gross.is_empty() {
        (problem, robust, nominal)
    } else {
        let mut keep = vec![true; problem.len()];
        gross.iter().for_each(|&j| keep[j] = false);
        let rows: Vec<usize> = (0..problem.len()).filter(|&j| keep[j]).collect();
        let problem = problem.subset(&rows);
        let again = FitSettings { stage: "refit without gross errors", ..settings.clone() };
        let mut refit =
            fit(&problem, &robust.x, &again, on_iteration).map_err(stage("calibration without the gross errors"))?;
        let refit_iterations = refit.log.len();
        // The report's iterations are every iteration of both fits, each naming its stage.
        refit.log = robust.log.iter().chain(&refit.log).copied().collect();
        flagged.retain(|(_, f)| f.excluded);
        flagged.extend(flag(&problem, &refit, config.outlier_threshold, &origin));
        let nominal =
            best_registration(&problem, &nominal.x, &registration, config).map_err(stage("nominal registration"))?;
        clock.lap("refit without gross errors", refit_iterations);
        (problem, refit, nominal)
    };
    // A parameter that ends at its bound is held there: the data want it further, and a standard
    // error computed as if it were free would claim a precision the bound, not the data, gives.
    let at_bound = at_bounds(p, &calibrated.x, &free);
    let determined: Vec<bool> = free.iter().zip(&at_bound).map(|(f, b)| *f && !b).collect();
    let covariance = covariance(&calibrated, &determined, prior.as_ref().map(|(l, _)| l));
    clock.lap("uncertainty", 0);
    let groups = super::validation::groups(&problem);
    if config.folds > groups {
        let reason = format!(
            "`folds: {}` is more than the {groups} poses (stations) there are to hold out: at most {groups}",
            config.folds
        );
        return Err(CalibError::Config { key: "folds".into(), reason });
    }
    let cross_validation =
        cross_validate(&problem, [&nominal, &calibrated], [&determined, &registration], prior.as_ref(), config.folds);
    clock.lap("cross-validation", 0);
    // Scales the session cannot tell are a note (a warning when the model check finds the residuals
    // following the joints' angles, below); ones that show no error the report's lines only.
    undetermined.sort_by_key(|u| u.0);
    let held_scales_message = joint_scales::undetermined_warning(&undetermined);
    let mut warnings: Vec<String> = camera_warnings.collect();
    if config.folds == 0 {
        // A legitimate quick run, but the one check of unseen poses is gone: say so.
        warnings.push(
            "cross-validation was not run (`folds: 0`): nothing but the held-out poses, if any, shows how the \
             calibrated model predicts unseen data"
                .to_string(),
        );
    }
    // The model check: are the residuals what the noise model says? When not, what the misfit can
    // do widens the predicted error (the parameters' covariance stays the data's).
    let held_out =
        cross_validation.as_ref().map(|cv| super::model_check::HeldOut { residuals: &cv.held_out, folds: cv.folds });
    let checked = super::model_check::check(&problem, &calibrated, &determined, &covariance, held_out);
    let predicted_covariance = match checked.as_ref().filter(|(c, _)| !c.passed) {
        Some((_, misfit)) => match &misfit.bias {
            Some(bias) => &covariance + bias * bias.transpose(),
            None => &covariance * misfit.scale,
        },
        None => covariance.clone(),
    };
    // Each residual's expected squared prediction error: the level's report's.
    let predicted_ms = super::uncertainty::residual_mean_squares(&calibrated, &predicted_covariance);
    if let Some(cv) = cross_validation.as_ref().filter(|cv| !cv.clearly_better) {
        let warning = not_better_warning(cv, &identifiability.unidentifiable, problem.poses());
        if config.if_not_better == IfNotBetter::Refuse {
            return Err(CalibError::NotBetter(warning));
        }
        warnings.push(warning);
    }
    if let Some(cv) = cross_validation.as_ref().filter(|cv| cv.unpredicted > 0) {
        warnings.push(format!(
            "{} held-out observations could not be predicted by the problem fitted without them (its forward \
             kinematics failed): the cross-validated error leaves them out",
            cv.unpredicted
        ));
    }
    let flagged: Vec<FlaggedObservation> = flagged.into_iter().map(|(_, f)| f).collect();
    let results = LevelResults {
        session,
        robot,
        problem,
        nominal,
        calibrated,
        free: determined,
        covariance: &covariance,
        predicted_covariance: &predicted_covariance,
        predicted_ms,
        flagged: &flagged,
    };
    let scales = joint_scales::report(p, &results.calibrated.x, &covariance, &results.free, &held_scales);
    let fitted_poses = results.problem.poses();
    let unit = results.problem.unit();
    let (nominal, calibrated) = (Solution::of(&results.nominal), Solution::of(&results.calibrated));
    let (iterations, convergence) = (results.calibrated.log.clone(), results.calibrated.status);
    let part = level.finish(results)?;
    clock.lap("report", 0);
    // The one report, assembled here from the pipeline's findings and the level's part.
    let mut excluded = part.excluded;
    excluded.extend(left_out);
    let mut report = CalibrationReport {
        session: session.name.clone(),
        fit: config.fit,
        vision_method: part.vision_method.unwrap_or(config.vision_method),
        loss: config.loss,
        poses: session.poses.len(),
        fit_poses: fitted_poses,
        held_out_poses: part.held_out_poses,
        excluded,
        verdict: Verdict::of(None, &part.before, &part.after, None, None, config),
        warnings: part.notes.into_iter().chain(warnings).chain(part.findings).collect(),
        notes: Vec::new(),
        cross_validation,
        model_check: checked.map(|(c, _)| c),
        predicted_error_unwidened_deg: part.predicted_error_unwidened_deg,
        before: part.before,
        after: part.after,
        iterations,
        convergence,
        parameters: part.parameters_report,
        not_significant: Vec::new(),
        high_correlations: super::uncertainty::correlations(p, &covariance, 0.9),
        identifiability,
        regularised,
        predicted_error_deg: part.predicted_error_deg,
        predicted_error_mm: part.predicted_error_mm,
        residual_sigma_deg: part.residual_sigma_deg,
        flagged,
        unit,
        at_bound: p.entries.iter().zip(&at_bound).filter(|(_, b)| **b).map(|(e, _)| e.name.clone()).collect(),
        camera_translation_m: part.camera_translation_m,
        camera_translation_std_error_m: part.camera_translation_std_error_m,
        markers: part.markers,
        joint_scales: scales,
        platform_sag_held: sag_held,
        stages: clock.stages,
    };
    if let Some(check) = report.model_check.as_mut() {
        let names: Vec<String> = report
            .markers
            .as_ref()
            .map(|m| m.after.per_marker.iter().map(|(n, _, _)| n.clone()).collect())
            .unwrap_or_default();
        check.name_markers(&names);
        let camera = report.markers.as_ref().map(|m| m.camera_model.model.name());
        check.diagnose(camera, unit == "px", config.freeze.contains(&Group::CameraModel));
        // Held scales are an alarm only when the residuals show one off: on every small clean
        // session they would ring.
        if let Some(message) = held_scales_message.clone().filter(|_| check.rejects(Structure::Joints)) {
            report.warnings.push(message);
        }
        if let (false, Some(before), Some(after)) =
            (check.passed, report.predicted_error_unwidened_deg, report.predicted_error_deg.as_ref())
        {
            check.widening = Some(after.rms / before.max(f64::MIN_POSITIVE));
        }
    }
    if let Some(message) = held_scales_message.filter(|m| !report.warnings.contains(m)) {
        report.notes.push(message);
    }
    report.verdict = Verdict::of(
        report.cross_validation.as_ref(),
        &report.before,
        &report.after,
        report.model_check.as_ref(),
        report.predicted_error_deg.as_ref(),
        config,
    );
    report.not_significant = super::uncertainty::not_significant(&report.parameters);
    let mut parameters = part.parameters;
    parameters.fit = Some(report::fit_header(&report));
    Ok(Calibration {
        parameters,
        report,
        parameterisation: p.clone(),
        fitted: part.fitted,
        nominal,
        calibrated,
        covariance,
    })
}

/// The stages' wall-clock times, lap by lap.
struct Clock {
    last: std::time::Instant,
    stages: Vec<super::report::StageReport>,
}

impl Clock {
    fn start() -> Self {
        Clock { last: std::time::Instant::now(), stages: Vec::new() }
    }

    /// The stage `name` ends now, after `iterations` fit iterations.
    fn lap(&mut self, name: &'static str, iterations: usize) {
        let now = std::time::Instant::now();
        let seconds = (now - self.last).as_secs_f64();
        self.stages.push(super::report::StageReport { name, iterations, seconds });
        self.last = now;
    }
}

/// A camera-model parameter weighs this much (scaled) in an unidentifiable direction: it is part
/// of what the data cannot determine.
const CAMERA_IN_NULL_DIRECTION: f64 = 0.3;

/// The camera-model parameters that take part in an unidentifiable direction (by their share of
/// the column-scaled direction, so that units do not decide).
pub(super) fn unidentified_camera_terms(
    p: &Parameterisation,
    identifiability: &super::identify::Identifiability,
) -> Vec<usize> {
    let camera: Vec<usize> = (0..p.len())
        .filter(|&i| matches!(p.entries[i].kind, super::parameterisation::Kind::CameraTerm { .. }))
        .collect();
    let mut held: Vec<usize> = identifiability
        .null_vectors
        .iter()
        .flat_map(|v| {
            let scaled = v.component_mul(&identifiability.column_norms);
            let norm = scaled.norm().max(f64::MIN_POSITIVE);
            camera.iter().copied().filter(move |&i| (scaled[i] / norm).abs() > CAMERA_IN_NULL_DIRECTION)
        })
        .collect();
    held.sort_unstable();
    held.dedup();
    held
}

/// The first structure other than the sag's (and the overall test) whose test in the model check of
/// `outcome` (a fit of the `free` parameters, covariance `cov`) rejects.
fn other_structure<M: Residuals>(
    problem: &M,
    outcome: &FitOutcome<M::Noise>,
    free: &[bool],
    cov: &nalgebra::DMatrix<f64>,
) -> Option<&'static str> {
    let (check, _) = super::model_check::check(problem, outcome, free, cov, None)?;
    let ignored = [Structure::Sag.name(), Structure::Overall.name()];
    check.tests.iter().find(|t| !ignored.contains(&t.structure) && t.p_value < t.alpha).map(|t| t.structure)
}

/// The free parameters that end at their bound.
fn at_bounds(p: &Parameterisation, x: &DVector<f64>, free: &[bool]) -> Vec<bool> {
    (0..p.len()).map(|i| free[i] && p.at_bound(x, i)).collect()
}

/// Observations beyond `threshold` robust standard deviations, most extreme first; beyond twice
/// that, gross errors to exclude.
fn flag<M: Residuals>(
    model: &M,
    outcome: &FitOutcome<M::Noise>,
    threshold: f64,
    origin: &dyn Fn(&M, usize) -> Origin,
) -> Vec<(usize, FlaggedObservation)> {
    let w = &outcome.weighting;
    let mut out: Vec<(usize, FlaggedObservation)> = outcome
        .evaluation
        .residuals
        .iter()
        .enumerate()
        .filter_map(|(j, r)| {
            let sigmas = w.whiten(j, r).norm() / w.sigma;
            (sigmas > threshold).then(|| {
                let (pose, marker, line) = origin(model, j);
                let f = FlaggedObservation {
                    pose,
                    marker,
                    line,
                    residual: r.norm() * model.unit_scale(),
                    sigmas,
                    weight: w.weights[j],
                    excluded: sigmas > 2.0 * threshold,
                };
                (j, f)
            })
        })
        .collect();
    out.sort_by(|a, b| b.1.sigmas.total_cmp(&a.1.sigmas));
    out
}

/// Why the calibrated model may not be better, in words.
fn not_better_warning(cv: &CrossValidation, weak: &[Direction], poses: usize) -> String {
    let mut cause = if poses < 40 {
        format!("only {poses} poses: capture more, spread over the workspace")
    } else {
        "the poses may be too similar: spread them over the workspace".to_string()
    };
    if let Some(d) = weak.first() {
        cause += &format!("; weakest direction {}", d.describe());
    }
    format!(
        "the calibrated model does not predict unseen poses clearly better than the nominal one \
         ({:.3} {unit} against {:.3} {unit} RMS, {}-fold cross-validation): {cause}",
        cv.calibrated_rms,
        cv.nominal_rms,
        cv.folds,
        unit = cv.unit
    )
}
