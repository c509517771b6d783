//! The calibration report as text: what `calibrate` prints, and what the HTML report embeds.

use std::fmt;

use crate::calib::{CalibrationReport, CameraModelReport, Convergence, FitLevel, MarkerFitReport};
use crate::math::stats::Stats;

/// How many excluded or flagged items a text report lists before "… and N more".
const LISTED: usize = 10;

/// Where the report says why the joint scales it could not determine were held: its notes, or its
/// warnings when the model check found a scale off.
pub(crate) fn held_scales_list(r: &CalibrationReport) -> &'static str {
    if r.notes.iter().any(|n| n.contains("joint scale")) { "notes" } else { "warnings" }
}

fn error_line(f: &mut fmt::Formatter<'_>, label: &str, e: &Stats) -> fmt::Result {
    writeln!(f, "  {label:<26} {:8.4} {:8.4} {:8.4}", e.rms, e.median, e.max)
}

/// A setting's value as the config file spells it (`least_squares`, `paper`).
fn word(value: impl serde::Serialize) -> String {
    serde_json::to_value(value).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default()
}

impl fmt::Display for CalibrationReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self;
        match r.fit {
            FitLevel::Markers => writeln!(
                f,
                "{}: {} poses, {} excluded; marker-level fit, loss {}",
                r.session,
                r.poses,
                r.excluded.len(),
                word(r.loss)
            )?,
            FitLevel::Orientations => writeln!(
                f,
                "{}: {} poses, {} fitted, {} held out, {} excluded; orientation-level fit, vision {}, loss {}",
                r.session,
                r.poses,
                r.fit_poses,
                r.held_out_poses,
                r.excluded.len(),
                word(r.vision_method),
                word(r.loss)
            )?,
        }
        for e in r.excluded.iter().take(LISTED) {
            writeln!(f, "  excluded {e}")?;
        }
        if r.excluded.len() > LISTED {
            writeln!(f, "  … and {} more (all are listed by --json)", r.excluded.len() - LISTED)?;
        }
        writeln!(f, "verdict: {}", r.verdict)?;
        for w in &r.warnings {
            writeln!(f, "WARNING: {w}")?;
        }
        for n in &r.notes {
            writeln!(f, "note: {n}")?;
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
        let to = r.iterations.last().map_or(String::new(), |l| {
            format!(
                " ({} steps; the last {:.1e} standard errors from the optimum)",
                solver_mix(&r.iterations),
                l.decrement
            )
        });
        match r.convergence {
            Convergence::Converged => writeln!(f, "converged in {iterations} iterations{to}")?,
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
                None if p.at_bound => writeln!(f, "  {:<26} {:+12.5}       at bound", p.name, p.change_deg)?,
                None => writeln!(f, "  {:<26} {:+12.5}         frozen", p.name, p.change_deg)?,
            }
        }
        if let Some(why) = &r.platform_sag_held {
            writeln!(f, "  platform.sag held at its start: {why}")?;
        }
        for s in &r.joint_scales {
            let name = format!("leg{}.scale", s.leg);
            match (s.std_error_ppm, &s.held) {
                (Some(se), _) => writeln!(f, "  {name:<26} {:.6} ({:+.0} ± {se:.0} ppm)", s.scale, s.change_ppm)?,
                (None, Some(why)) if why.starts_with("frozen") => writeln!(f, "  {name:<26} {:.6} (frozen)", s.scale)?,
                (None, Some(why)) if why.starts_with("at its bound") => {
                    writeln!(f, "  {name:<26} {:.6} ({:+.0} ppm, at bound)", s.scale, s.change_ppm)?
                }
                (None, Some(why)) if why.starts_with("not distinguishable") => {
                    writeln!(f, "  {name:<26} {:.6} (held: {why})", s.scale)?
                }
                (None, _) => writeln!(f, "  {name:<26} {:.6} (held: see the {})", s.scale, held_scales_list(r))?,
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
        if !r.at_bound.is_empty() {
            writeln!(
                f,
                "AT A BOUND (held there, no standard error; the data want them further — widen `bounds` if the device can be that far off): {}",
                r.at_bound.join(", ")
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
        predicted(f, r)?;
        writeln!(f, "camera translation t_CB: {}", super::html_tables::translation(r))?;
        if let Some(m) = &r.markers {
            marker_details(f, m)?;
        }
        flagged(f, r)
    }
}

/// The predicted error on unseen poses, beside the cross-validated one.
fn predicted(f: &mut fmt::Formatter<'_>, r: &CalibrationReport) -> fmt::Result {
    if let Some(e) = &r.predicted_error_deg {
        writeln!(
            f,
            "predicted error of the calibrated FDA on unseen poses {} (as `compare` measures it, from the parameter covariance): {:.4} deg RMS (90%: {:.4}–{:.4}), worst pose {:.4} deg",
            super::html_tables::predicted_over(e),
            e.rms,
            e.interval_90[0],
            e.interval_90[1],
            e.max
        )?;
    }
    if let Some(e) = &r.predicted_error_mm {
        writeln!(
            f,
            "predicted error of the calibrated markers on unseen poses: {:.4} {unit} RMS (90%: {:.4}–{:.4}), worst pose {:.4} {unit}",
            e.rms,
            e.interval_90[0],
            e.interval_90[1],
            e.max,
            unit = r.unit
        )?;
    }
    if let Some(e) = r.predicted_error_deg.as_ref().filter(|e| e.by_region.len() > 1) {
        writeln!(f, "  by region of the workspace (deg RMS / worst, poses):")?;
        for g in &e.by_region {
            let band = |b: [f64; 2]| match b[1].is_finite() {
                true => format!("{:.0}–{:.0}°", b[0], b[1]),
                false => format!("> {:.0}°", b[0]),
            };
            writeln!(
                f,
                "    tilt {:<7} |yaw| {:<7} {:.4} / {:.4} ({})",
                band(g.tilt_deg),
                band(g.yaw_deg),
                g.rms,
                g.worst,
                g.poses
            )?;
        }
    }
    if let Some(check) = &r.model_check {
        writeln!(f, "model check: {}", check.summary())?;
        if let (Some(finding), Some(action)) = (&check.finding, &check.action) {
            writeln!(f, "  likely cause: {finding} — {action}")?;
        }
    }
    Ok(())
}

/// The marker errors of a marker-level calibration.
fn marker_summary(f: &mut fmt::Formatter<'_>, m: &MarkerFitReport) -> fmt::Result {
    writeln!(f, "marker-level fit: {} observations at {} poses", m.observations, m.poses)?;
    let unit = m.before.unit;
    match unit {
        "px" => writeln!(f, "FDA vs camera, pixels (px)   RMS      median   max")?,
        _ => writeln!(f, "FDA vs camera, markers (mm)  RMS      median   max")?,
    }
    for (label, e) in [("nominal", &m.before), ("calibrated", &m.after)] {
        writeln!(f, "  {:<26} {:8.4} {:8.4} {:8.4}", label, e.errors.rms, e.errors.median, e.errors.max)?;
    }
    let per_marker: Vec<String> = m
        .before
        .per_marker
        .iter()
        .zip(&m.after.per_marker)
        .map(|((name, n, b), (_, _, a))| format!("{name} {b:.3} → {a:.3} ({n})"))
        .collect();
    writeln!(f, "  per marker, {unit} RMS (observations): {}", per_marker.join(", "))
}

/// The per-pose orientation errors beside a marker-level fit, when the estimator had poses.
fn per_pose_lines(f: &mut fmt::Formatter<'_>, r: &CalibrationReport) -> fmt::Result {
    if r.before.fit.count == 0 {
        return writeln!(f, "FDA vs vision per pose: no pose (station) sees three markers");
    }
    writeln!(f, "FDA vs vision per pose (deg)  RMS      median   max")?;
    error_line(f, "nominal", &r.before.fit)?;
    error_line(f, "calibrated", &r.after.fit)
}

/// How many steps each solver found, e.g. `6 Gauss–Newton, 1 clarabel`.
fn solver_mix(log: &[crate::calib::IterationLog]) -> String {
    let clarabel = log.iter().filter(|l| l.solver == crate::calib::Solver::Clarabel).count();
    format!("{} Gauss–Newton, {clarabel} clarabel", log.len() - clarabel)
}

/// A pixel session's rig: each camera's pixel noise, every term from the file's value to the
/// fit's, and what was held.
fn rig_lines(f: &mut fmt::Formatter<'_>, rig: &crate::calib::RigReport) -> fmt::Result {
    let noise: Vec<String> = rig.pixel_noise_px.iter().map(|(c, s, e)| format!("{c} {s:.3} ± {e:.3} px")).collect();
    writeln!(f, "pixel noise (σ per coordinate): {}", noise.join(", "))?;
    if rig.baseline_held_m > 0.0 {
        writeln!(
            f,
            "camera rig (cameras.yaml) refined with the mechanism; its baseline held at {:.2} mm (the rig's scale: an SPM's rotation cannot tell it)",
            rig.baseline_held_m * 1e3
        )?;
    } else {
        writeln!(
            f,
            "camera (cameras.yaml) refined with the mechanism; its scale set by the markers' spacing in the model"
        )?;
    }
    writeln!(f, "rig term               file value       change        std error")?;
    for t in &rig.terms {
        let file = t.file_value.map_or("".to_string(), |v| format!("{v:.6}"));
        let change = match t.std_error {
            Some(se) => format!("{:+.6} ± {se:.6} {}", t.change, t.unit),
            None => format!("held {}", t.unit),
        };
        writeln!(f, "  {:<20} {file:>14}   {change}", t.name)?;
    }
    Ok(())
}

/// Fitted markers, stereo noise and fast captures of a marker-level calibration.
fn marker_details(f: &mut fmt::Formatter<'_>, m: &MarkerFitReport) -> fmt::Result {
    if let Some(l) = &m.latency {
        writeln!(f, "camera latency: {}", super::html_tables::latency(l, m.clock_rate_ppm.as_ref()))?;
    }
    if let Some(c) = &m.clock_rate_ppm {
        writeln!(f, "camera clock rate: {}", super::html_tables::clock_rate(c))?;
    }
    match &m.rig {
        Some(rig) => rig_lines(f, rig)?,
        None => camera_model(f, &m.camera_model)?,
    }
    if let Some(n) = m.stereo_noise.as_ref().filter(|_| m.rig.is_none()) {
        let (what, value) = super::html_tables::noise(n);
        writeln!(f, "{what}: {value}")?;
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
        if let Some(frame) = super::html_tables::body_frame(k) {
            writeln!(f, "  {:<6} frame's orientation (body → P): {frame}", k.name)?;
        }
    }
    if !m.fast_captures.is_empty() {
        writeln!(
            f,
            "fast captures: {} taken while a joint turned faster than `max_joint_speed_deg_s`, down-weighted ({})",
            m.fast_captures.len(),
            super::tables::fast_capture(&m.fast_captures[0])
        )?;
    }
    Ok(())
}

/// The camera model, term by term, and what it says in words.
fn camera_model(f: &mut fmt::Formatter<'_>, c: &CameraModelReport) -> fmt::Result {
    let terms: Vec<String> = c
        .terms
        .iter()
        .map(|t| match (t.std_error, t.held, t.released) {
            (Some(se), _, _) => format!("{} {:.5} ± {se:.5}", t.name, t.value),
            (None, Some(why), Some((v, se))) => {
                format!(
                    "{} {:.5} (held: {}; freed it would be {v:.5} ± {se:.5})",
                    t.name,
                    t.value,
                    why.replace('_', " ")
                )
            }
            (None, why, None) => {
                format!("{} {:.5} (held: {})", t.name, t.value, why.unwrap_or("frozen").replace('_', " "))
            }
            (None, None, Some(_)) => format!("{} {:.5}", t.name, t.value),
        })
        .collect();
    // With `auto`, which model it chose and why, beside the model's name.
    let choice = c.choice.as_ref().map_or(String::new(), |choice| format!(" ({})", choice.summary));
    writeln!(f, "camera model: {}{choice} — {}", c.model.name(), terms.join(", "))?;
    if let Some(finding) = &c.finding {
        writeln!(f, "  camera: {finding}")?;
    }
    Ok(())
}

/// The observations the robust fit flagged.
fn flagged(f: &mut fmt::Formatter<'_>, r: &CalibrationReport) -> fmt::Result {
    let excluded = r.flagged.iter().filter(|o| o.excluded).count();
    writeln!(f, "flagged observations: {} ({excluded} excluded as gross errors)", r.flagged.len())?;
    let source = r.observations_file();
    for o in r.flagged.iter().take(LISTED) {
        let place = match &o.marker {
            Some(marker) => match crate::calib::file_line(source, o.line) {
                Some(at) => format!("pose {} marker {marker} ({at})", o.pose),
                None => format!("pose {} marker {marker}", o.pose),
            },
            None => format!("pose {}", o.pose),
        };
        writeln!(
            f,
            "  {place}: {:.3} {}, {:.1} sigma{}",
            o.residual,
            r.unit,
            o.sigmas,
            if o.excluded { ", excluded" } else { "" }
        )?;
    }
    if r.flagged.len() > LISTED {
        writeln!(f, "  … and {} more (all are listed by --json)", r.flagged.len() - LISTED)?;
    }
    Ok(())
}
