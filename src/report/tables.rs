//! The report's tables in markdown, as the Rerun recording shows them beside the 3-D view: a
//! parameter set, the calibrated parameters' changes, the predicted error by region of the
//! workspace and the fit's iterations.

use std::fmt::Write as _;

use nalgebra::Vector3;

use crate::calib::{Calibration, IterationLog, PredictedError};
use crate::model::Parameters;

/// A markdown table of a parameter set.
pub(crate) fn parameters(title: &str, p: &Parameters) -> String {
    let mut s = format!("# {title}\n\n| leg | u | z | α1 (°) | α2 (°) | v0 | δ (°) |\n|---|---|---|---|---|---|---|\n");
    let v = |x: &Vector3<f64>| format!("[{:.5}, {:.5}, {:.5}]", x.x, x.y, x.z);
    for (i, g) in p.legs.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.4} | {:.4} | {} | {:.4} |",
            i + 1,
            v(&g.u),
            v(&g.z),
            g.alpha1.to_degrees(),
            g.alpha2.to_degrees(),
            v(&g.v0),
            g.delta.to_degrees()
        );
    }
    if !p.camera_model.is_perfect() {
        let terms: Vec<String> = p
            .camera_model
            .kind
            .terms()
            .iter()
            .map(|t| match p.camera_model.std_error(*t) {
                Some(se) => format!("{} {:.5} ± {se:.5}", t.name(), p.camera_model.value(*t)),
                None => format!("{} {:.5}", t.name(), p.camera_model.value(*t)),
            })
            .collect();
        let _ = write!(s, "\nCamera model ({}): {}\n", p.camera_model.kind.name(), terms.join(", "));
    }
    if let Some(c) = &p.camera {
        let q = crate::math::so3::to_wxyz(&c.rotation);
        let _ = write!(
            s,
            "\nCamera: R_CB (wxyz) [{:.5}, {:.5}, {:.5}, {:.5}], t_CB {} m\n",
            q[0],
            q[1],
            q[2],
            q[3],
            v(&c.translation)
        );
    }
    s
}

/// The calibrated parameter set and each parameter's change with its standard error.
pub(crate) fn calibrated_parameters(calibration: &Calibration) -> String {
    let mut after = parameters("Calibrated parameters", &calibration.parameters);
    after.push_str("\n| parameter | change (°) | std error (°) |\n|---|---|---|\n");
    for r in &calibration.report.parameters {
        let se = r.std_error_deg.map_or("frozen".to_string(), |s| format!("{s:.4}"));
        let _ = writeln!(after, "| {} | {:+.4} | {se} |", r.name, r.change_deg);
    }
    after
}

/// The predicted orientation error by band of tilt and |yaw|, as a markdown table.
pub(crate) fn predicted_error_by_region(e: &PredictedError) -> String {
    let band = |b: [f64; 2]| match b[1].is_finite() {
        true => format!("{:.0}–{:.0}°", b[0], b[1]),
        false => format!("> {:.0}°", b[0]),
    };
    let mut text = format!(
        "# Predicted error after calibration\n\n{:.4}° RMS over the session's poses (90%: {:.4}–{:.4}°), as `compare` measures it.\n\n| tilt | yaw (abs) | poses | RMS (°) | worst (°) |\n|---|---|---|---|---|\n",
        e.rms, e.interval_90[0], e.interval_90[1]
    );
    for g in &e.by_region {
        let _ = writeln!(
            text,
            "| {} | {} | {} | {:.4} | {:.4} |",
            band(g.tilt_deg),
            band(g.yaw_deg),
            g.poses,
            g.rms,
            g.worst
        );
    }
    text
}

/// The fit's iterations as a markdown table.
pub(crate) fn iterations(iterations: &[IterationLog]) -> String {
    let mut s = String::from(
        "# The fit, iteration by iteration\n\nPlots of these columns are on the `iteration` timeline.\n\n\
         | iteration | cost (whitened) | RMS (° or mm) | step (rad) | radius (rad) | ratio | accepted |\n|---|---|---|---|---|---|---|\n",
    );
    for it in iterations {
        s += &format!(
            "| {} | {:.6e} | {:.5} | {:.3e} | {:.3e} | {:.3} | {} |\n",
            it.iteration,
            it.cost,
            it.rms,
            it.step,
            it.radius,
            it.ratio,
            if it.accepted { "yes" } else { "no" }
        );
    }
    s
}
