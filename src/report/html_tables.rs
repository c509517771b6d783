//! The text report's content as the HTML page's tables: the same numbers at the same precision,
//! tabulated so that a narrow screen wraps or scrolls each table in its own box instead of
//! running a monospace line off the page. Everything the text report says is here, in its order
//! (the verdict, the warnings and the predicted error head the page instead).

use super::tables::{Align, Table, escape, parameter_changes};
use crate::calib::{
    Calibration, CalibrationReport, CameraModelReport, ClockRate, Convergence, Latency, MarkerFitReport,
};
use crate::math::stats::Stats;

/// How many excluded or flagged items are listed before "… and N more", as in the text report.
const LISTED: usize = 10;

/// Every table of the report, with the sentences that go with them.
pub(crate) fn all(c: &Calibration) -> String {
    let r = &c.report;
    let mut html = excluded(r);
    html += &errors(r);
    html += &fit(r);
    html += &parameter_changes(c).html();
    if let Some(t) = super::tables::joint_scales(c) {
        html += &t.html();
    }
    html += &parameter_notes(r);
    html += &correlations(r);
    html += &residual_sigma(r);
    if let Some(e) = r.predicted_error_deg.as_ref().filter(|e| e.by_region.len() > 1) {
        html += &super::tables::by_region(e).html();
    }
    if let Some(m) = &r.markers {
        html += &camera_terms(&m.camera_model).html();
        if let Some(rig) = &m.rig {
            html += &rig_terms(rig);
        }
        html += &markers(m).html();
    }
    html + &flagged(r)
}

/// Which unseen poses the orientation error is predicted for, in words: the workspace the config
/// names, or poses like the session's own.
pub(crate) fn predicted_over(e: &crate::calib::PredictedError) -> String {
    match &e.workspace {
        Some(w) => format!("of the workspace (tilt ≤ {:.0}°, yaw ±{:.0}°)", w.max_tilt_deg, w.max_yaw_deg),
        None => "like the session's".to_string(),
    }
}

/// A paragraph of plain text.
fn note(text: &str) -> String {
    format!("<p class=\"note\">{}</p>", escape(text))
}

/// "… and N more" under a list cut at [`LISTED`], or nothing.
fn more(total: usize) -> String {
    match total > LISTED {
        true => note(&format!("… and {} more (all are listed by --json)", total - LISTED)),
        false => String::new(),
    }
}

/// The observations left out before the fit, and why.
fn excluded(r: &CalibrationReport) -> String {
    if r.excluded.is_empty() {
        return String::new();
    }
    let mut t = Table::new(format!("Excluded before the fit: {}", r.excluded.len()), &[("where and why", Align::Text)]);
    for e in r.excluded.iter().take(LISTED) {
        t.row([e.clone()]);
    }
    t.html() + &more(r.excluded.len())
}

/// RMS, median and largest error of each model.
fn error_table(caption: &str, rows: &[(&str, &Stats)]) -> Table {
    let n = Align::Number;
    let mut t = Table::new(caption, &[("model", Align::Text), ("RMS", n), ("median", n), ("max", n)]);
    for (label, e) in rows {
        t.row([(*label).to_string(), format!("{:.4}", e.rms), format!("{:.4}", e.median), format!("{:.4}", e.max)]);
    }
    t
}

/// The model against the camera (markers) and against the per-pose vision estimate.
fn errors(r: &CalibrationReport) -> String {
    let Some(m) = &r.markers else {
        let mut rows = vec![("nominal, fitted poses", &r.before.fit), ("calibrated, fitted poses", &r.after.fit)];
        if let (Some(b), Some(a)) = (&r.before.held_out, &r.after.held_out) {
            rows.extend([("nominal, held out", b), ("calibrated, held out", a)]);
        }
        return error_table("FDA vs vision (deg)", &rows).html();
    };
    let unit = m.before.unit;
    let what = if unit == "px" { "pixels" } else { "markers" };
    let caption = format!("FDA vs camera, {what} ({unit}): {} observations at {} poses", m.observations, m.poses);
    let mut html = error_table(&caption, &[("nominal", &m.before.errors), ("calibrated", &m.after.errors)]).html();
    let n = Align::Number;
    let (nominal, calibrated) = (format!("nominal RMS ({unit})"), format!("calibrated RMS ({unit})"));
    let columns = [("marker", Align::Label), ("observations", n), (nominal.as_str(), n), (calibrated.as_str(), n)];
    let mut per_marker = Table::new("Per marker", &columns);
    for ((name, count, b), (_, _, a)) in m.before.per_marker.iter().zip(&m.after.per_marker) {
        per_marker.row([name.clone(), count.to_string(), format!("{b:.3}"), format!("{a:.3}")]);
    }
    html += &per_marker.html();
    html + &match r.before.fit.count {
        0 => note("FDA vs vision per pose: no pose (station) sees three markers"),
        _ => error_table("FDA vs vision per pose (deg)", &[("nominal", &r.before.fit), ("calibrated", &r.after.fit)])
            .html(),
    }
}

/// How the fit went and what it found besides the parameters: convergence, identifiability, the
/// camera's registration, latency, model and noise.
fn fit(r: &CalibrationReport) -> String {
    let mut t = Table::facts("The fit");
    t.row(["convergence".to_string(), convergence(r)]);
    let id = &r.identifiability;
    t.row([
        "identifiability".to_string(),
        format!("{} of {} directions, condition number {:.3e}", id.rank, id.parameters, id.condition),
    ]);
    t.row(["camera translation t_CB".to_string(), translation(r)]);
    if let Some(m) = &r.markers {
        if let Some(l) = &m.latency {
            t.row(["camera latency".to_string(), latency(l, m.clock_rate_ppm.as_ref())]);
        }
        if let Some(c) = &m.clock_rate_ppm {
            t.row(["camera clock rate".to_string(), clock_rate(c)]);
        }
        t.row(["camera model".to_string(), camera_model(&m.camera_model)]);
        if let Some(n) = &m.stereo_noise {
            let (what, value) = noise(n);
            t.row([what, value]);
        }
        for (name, frame) in m.markers.iter().filter_map(|k| Some((&k.name, body_frame(k)?))) {
            t.row([format!("{name}'s frame on the MP (body → P)"), frame]);
        }
        if let Some(first) = m.fast_captures.first() {
            t.row([
                "fast captures".to_string(),
                format!(
                    "{} taken while a joint turned faster than `max_joint_speed_deg_s`, down-weighted ({})",
                    m.fast_captures.len(),
                    super::tables::fast_capture(first)
                ),
            ]);
        }
    }
    t.html()
}

/// The noise the fit estimated, in words: a stereo camera's σ's across and along the line of
/// sight, or a rigid body's position and orientation σ's; `(what, value)`.
pub(crate) fn noise(n: &crate::calib::StereoNoise) -> (String, String) {
    let se = |v: Option<f64>| v.unwrap_or(f64::NAN);
    match (n.body_position_m, n.body_orientation_rad) {
        (Some(position), Some(orientation)) => (
            "rigid body noise".to_string(),
            format!(
                "position {:.4} ± {:.4} mm, orientation {:.4} ± {:.4} deg (per axis)",
                position * 1e3,
                se(n.body_position_std_error_m) * 1e3,
                orientation.to_degrees(),
                se(n.body_orientation_std_error_rad).to_degrees()
            ),
        ),
        _ => (
            format!("stereo noise at {:.3} m", n.reference_distance_m),
            format!(
                "across the line of sight {:.4} ± {:.4} mm, along it {:.4} ± {:.4} mm",
                n.lateral_m * 1e3,
                n.lateral_std_error_m * 1e3,
                n.depth_m * 1e3,
                n.depth_std_error_m * 1e3
            ),
        ),
    }
}

/// A rigid body's fitted frame orientation in words (`None` for a marker).
pub(crate) fn body_frame(k: &crate::calib::MarkerReport) -> Option<String> {
    let q = k.rotation_wxyz?;
    let se = k
        .rotation_std_error_deg
        .map_or("held".to_string(), |s| format!("± [{:.4}, {:.4}, {:.4}] deg", s[0], s[1], s[2]));
    Some(format!("qw,qx,qy,qz [{:.6}, {:+.6}, {:+.6}, {:+.6}] {se}", q[0], q[1], q[2], q[3]))
}

/// The fit's convergence in words, as the text report says it.
fn convergence(r: &CalibrationReport) -> String {
    let iterations = r.iterations.len();
    match r.convergence {
        Convergence::Converged => {
            let to = r.iterations.last().map_or(String::new(), |l| {
                let clarabel = r.iterations.iter().filter(|l| l.solver == crate::calib::Solver::Clarabel).count();
                format!(
                    " ({} Gauss–Newton, {clarabel} clarabel steps; the last {:.1e} standard errors from the optimum)",
                    iterations - clarabel,
                    l.decrement
                )
            });
            format!("converged in {iterations} iterations{to}")
        }
        Convergence::StalledAtMinimum => format!(
            "stalled at a minimum after {iterations} iterations (the cost stopped changing before the steps fell below the tolerance)"
        ),
    }
}

/// The camera latency in words (the text report's too): at time 0 when the clock's rate was
/// estimated.
pub(super) fn latency(l: &Latency, rate: Option<&ClockRate>) -> String {
    let at = match rate {
        Some(c) if c.held.is_none() => " at time 0",
        _ => "",
    };
    match l.std_error_s {
        Some(se) => format!("{:.3} ± {:.3} ms{at} (estimated)", l.value_s * 1e3, se * 1e3),
        None if l.at_bound => format!(
            "{:.3} ms{at}, AT ITS BOUND (`latency_bound_s`): the data want it further; no standard error",
            l.value_s * 1e3
        ),
        None => format!("{:.3} ms{at} (as given; frozen)", l.value_s * 1e3),
    }
}

/// How much faster the camera's clock runs, in words (the text report's too): estimated, with
/// the drift it makes over the recording, or held and why.
pub(super) fn clock_rate(c: &ClockRate) -> String {
    let drift = c.value * 1e-6 * c.span_s * 1e3;
    match (c.std_error, c.held) {
        (Some(se), _) => format!(
            "{:+.2} ± {se:.2} ppm (estimated): the latency drifts {drift:+.2} ms over the recording's {:.0} s",
            c.value, c.span_s
        ),
        (None, None) if c.at_bound => format!(
            "{:+.2} ppm, AT ITS BOUND (`clock_rate_bound_ppm`): the data want it further; no standard error",
            c.value
        ),
        (None, Some("frozen")) => format!("{:+.2} ppm (as given; frozen)", c.value),
        (None, Some("short_recording")) => format!(
            "{:+.2} ppm (held: the recording spans {:.1} s, shorter than `clock_rate_min_duration_s`)",
            c.value, c.span_s
        ),
        (None, Some(_)) => format!("{:+.2} ppm (held: the orientation-level fit does not estimate it)", c.value),
        (None, None) => format!("{:+.2} ppm (unidentifiable: no standard error)", c.value),
    }
}

/// The camera's translation with its standard error, or why there is none (the text report's
/// words too).
pub(super) fn translation(r: &CalibrationReport) -> String {
    match (r.camera_translation_m, r.camera_translation_std_error_m) {
        (Some(t), Some(se)) => format!(
            "[{:.4}, {:.4}, {:.4}] m (± [{:.4}, {:.4}, {:.4}] mm)",
            t[0],
            t[1],
            t[2],
            se[0] * 1e3,
            se[1] * 1e3,
            se[2] * 1e3
        ),
        _ => "undetermined (the poses do not fix the centre of rotation); no camera registration written".to_string(),
    }
}

/// The camera model's name and what it says in words.
fn camera_model(c: &CameraModelReport) -> String {
    match &c.finding {
        Some(finding) => format!("{} — {finding}", c.model.name()),
        None => c.model.name().to_string(),
    }
}

/// The camera model's terms: value, standard error, and why a held one is held.
fn camera_terms(c: &CameraModelReport) -> Table {
    let n = Align::Number;
    let columns = [("term", Align::Label), ("value", n), ("std error", n), ("held", Align::Text)];
    let mut t = Table::new(format!("Camera model: {}", c.model.name()), &columns);
    for term in &c.terms {
        let se = term.std_error.map_or(String::new(), |se| format!("{se:.5}"));
        let held = match (term.std_error, term.held, term.released) {
            (Some(_), _, _) | (None, None, Some(_)) => String::new(),
            (None, Some(why), Some((v, se))) => {
                format!("{}; freed it would be {v:.5} ± {se:.5}", why.replace('_', " "))
            }
            (None, why, None) => why.unwrap_or("frozen").replace('_', " "),
        };
        t.row([term.name.clone(), format!("{:.5}", term.value), se, held]);
    }
    t
}

/// A pixel session's rig, as the text report gives it: each camera's pixel noise, what was held
/// for scale, and every term from the file's value to the fit's.
fn rig_terms(rig: &crate::calib::RigReport) -> String {
    let noise: Vec<String> = rig.pixel_noise_px.iter().map(|(c, s, e)| format!("{c} {s:.3} ± {e:.3} px")).collect();
    let scale = if rig.baseline_held_m > 0.0 {
        format!(
            "its baseline held at {:.2} mm (the rig's scale: an SPM's rotation cannot tell it)",
            rig.baseline_held_m * 1e3
        )
    } else {
        "its scale set by the markers' spacing in the model".to_string()
    };
    let n = Align::Number;
    let columns = [("term", Align::Label), ("file value", n), ("change", n), ("std error", n), ("unit", Align::Text)];
    let mut t = Table::new("Camera rig (cameras.yaml) refined with the mechanism", &columns);
    for term in &rig.terms {
        let file = term.file_value.map_or(String::new(), |v| format!("{v:.6}"));
        let (change, se) = match term.std_error {
            Some(se) => (format!("{:+.6}", term.change), format!("{se:.6}")),
            None => ("held".to_string(), String::new()),
        };
        t.row([term.name.clone(), file, change, se, term.unit.to_string()]);
    }
    note(&format!("Pixel noise (σ per coordinate): {}. The rig is {scale}.", noise.join(", "))) + &t.html()
}

/// Which changes are not distinguishable from nominal, which ended at a bound, and why the
/// platform's sag was held (the regularised directions are under the identifiability chart).
fn parameter_notes(r: &CalibrationReport) -> String {
    let mut html = String::new();
    if !r.not_significant.is_empty() {
        html += &note(&format!(
            "Not distinguishable from nominal (|change| < 2 std errors): {} of {}: {}",
            r.not_significant.len(),
            r.parameters.iter().filter(|p| !p.frozen).count(),
            r.not_significant.join(", ")
        ));
    }
    if !r.at_bound.is_empty() {
        html += &note(&format!(
            "AT A BOUND (held there, no standard error; the data want them further — widen `bounds` if the device can be that far off): {}",
            r.at_bound.join(", ")
        ));
    }
    if let Some(why) = &r.platform_sag_held {
        html += &note(&format!("platform.sag held at its start: {why}"));
    }
    html
}

/// The strongest correlations between fitted parameters (the first five).
fn correlations(r: &CalibrationReport) -> String {
    let mut t = Table::new(
        "Strongest correlations",
        &[("parameter", Align::Label), ("with", Align::Label), ("ρ", Align::Number)],
    );
    for c in r.high_correlations.iter().take(5) {
        t.row([c.a.clone(), c.b.clone(), format!("{:+.3}", c.rho)]);
    }
    if t.is_empty() { String::new() } else { t.html() }
}

/// The orientation residuals' σ along each camera axis, by how many markers a pose saw.
fn residual_sigma(r: &CalibrationReport) -> String {
    let n = Align::Number;
    let columns = [("markers", n), ("poses", n), ("camera x (°)", n), ("camera y (°)", n), ("camera z (°)", n)];
    let mut t = Table::new("Residual σ of the per-pose orientations", &columns);
    for (markers, poses, s) in &r.residual_sigma_deg {
        let cells = [markers.to_string(), poses.to_string()];
        t.row(cells.into_iter().chain(s.iter().map(|v| format!("{v:.4}"))));
    }
    if t.is_empty() { String::new() } else { t.html() }
}

/// Each marker's fitted position on the platform, its change from the model and its standard
/// error. The three coordinates share a cell, which wraps on a narrow screen.
fn markers(m: &MarkerFitReport) -> Table {
    let columns = [
        ("marker", Align::Label),
        ("fitted position in P (m)", Align::Text),
        ("change from the model (mm)", Align::Text),
        ("std error (mm)", Align::Text),
    ];
    let mut t = Table::new("Markers on the platform", &columns);
    for k in &m.markers {
        let [x, y, z] = k.fitted_m;
        let [dx, dy, dz] = k.change_mm;
        let se = k
            .std_error_mm
            .map_or("held at the model".to_string(), |s| format!("{:.3}, {:.3}, {:.3}", s[0], s[1], s[2]));
        t.row([k.name.clone(), format!("{x:+.5}, {y:+.5}, {z:+.5}"), format!("{dx:+.3}, {dy:+.3}, {dz:+.3}"), se]);
    }
    t
}

/// The observations the robust fit flagged (the first ten): each marker observation with its file
/// line, or each pose of an orientation-level fit.
fn flagged(r: &CalibrationReport) -> String {
    let excluded = r.flagged.iter().filter(|o| o.excluded).count();
    let caption = format!("Flagged observations: {} ({excluded} excluded as gross errors)", r.flagged.len());
    if r.flagged.is_empty() {
        return format!("<h3>{}</h3>", escape(&caption));
    }
    let n = Align::Number;
    let (line, residual) = (format!("{} line", r.observations_file()), format!("residual ({})", r.unit));
    let mut columns = vec![("pose", n), ("marker", Align::Label), (line.as_str(), n)];
    let markers = r.markers.is_some();
    if !markers {
        columns.truncate(1);
    }
    columns.extend([(residual.as_str(), n), ("σ", n), ("excluded", Align::Text)]);
    let mut t = Table::new(caption, &columns);
    for o in r.flagged.iter().take(LISTED) {
        let place = match markers {
            // A bag's observation has no line: a dash.
            true => vec![
                o.pose.to_string(),
                o.marker.clone().unwrap_or_default(),
                if o.line > 0 { o.line.to_string() } else { "—".to_string() },
            ],
            false => vec![o.pose.to_string()],
        };
        let excluded = (if o.excluded { "excluded" } else { "" }).to_string();
        t.row(place.into_iter().chain([format!("{:.3}", o.residual), format!("{:.1}", o.sigmas), excluded]));
    }
    t.html() + &more(r.flagged.len())
}
