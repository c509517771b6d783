//! A report a person can read and share (`calibrate --report report.html`): one self-contained
//! HTML file — inline SVG plots drawn with plotters, no script, no network — with the verdict
//! first (pass or warn against the config's thresholds), then the plots and the tables of the
//! text report.

use std::fmt::Write as _;

use nalgebra::Vector3;
use plotters::prelude::*;

use crate::calib::{Calibration, FitLevel, Fitted, per_pose_rms_mm};
use crate::math::so3;

/// The sections of the report, in order: `(id, title)`.
const SECTIONS: [(&str, &str); 7] = [
    ("verdict", "Verdict"),
    ("per-pose", "Model against camera, pose by pose"),
    ("residuals", "Residuals by marker and camera axis"),
    ("parameters", "Parameter changes (± 2σ)"),
    ("identifiability", "Identifiability"),
    ("coverage", "Workspace coverage"),
    ("tables", "Tables"),
];

impl Calibration {
    /// The whole report as one HTML document (well-formed XML: XHTML with inline SVG), with
    /// `text_report` (the text report) as its tables.
    pub fn html(&self, text_report: &str) -> String {
        let report = &self.report;
        let verdict = &report.verdict;
        let (pass, sentence) = (verdict.pass, format!("{}.", capitalised(&verdict.summary)));
        let mut html = String::new();
        let _ = write!(
            html,
            "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\"><head><meta charset=\"utf-8\"/>\
             <title>spmcal calibration of {session}</title><style>{STYLE}</style></head><body>\
             <h1>Calibration of {session}</h1><p class=\"meta\">{fit} fit, loss {loss:?}, {poses} poses; spmcal {version}</p>",
            session = escape(&report.session),
            fit = match report.fit {
                FitLevel::Markers => "marker-level",
                FitLevel::Orientations => "orientation-level",
            },
            loss = report.loss,
            poses = report.poses,
            version = env!("CARGO_PKG_VERSION"),
        );
        let mark = if pass { ("pass", "PASS") } else { ("warn", "WARN") };
        let _ = write!(
            html,
            "<section id=\"verdict\"><h2>Verdict</h2><p class=\"{}\"><b>{}</b> — {}</p></section>",
            mark.0,
            mark.1,
            escape(&sentence)
        );
        html += &predicted(report);
        let plots = [
            ("per-pose", per_pose(self)),
            ("residuals", residuals(self)),
            ("parameters", parameters(self)),
            ("identifiability", identifiability(self)),
            ("coverage", coverage(self)),
        ];
        for ((id, svg), (_, title)) in plots.iter().zip(&SECTIONS[1..6]) {
            let _ = write!(html, "<section id=\"{id}\"><h2>{title}</h2>{svg}");
            if *id == "identifiability" {
                html += "<ul>";
                for d in &report.identifiability.weakest {
                    let _ = write!(html, "<li>weak: {}</li>", escape(&d.describe()));
                }
                html += "</ul>";
            }
            html += "</section>";
        }
        let _ = writeln!(
            html,
            "<section id=\"tables\"><h2>Tables</h2><pre>{}</pre></section></body></html>",
            escape(text_report)
        );
        html
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:960px;margin:2em auto;color:#222}\
    .pass{background:#e6f4ea;border-left:6px solid #2e7d32;padding:.8em}\
    .warn{background:#fff4e5;border-left:6px solid #ef6c00;padding:.8em}\
    .meta{color:#666}pre{background:#f6f6f6;padding:1em;overflow-x:auto;font-size:12px}svg{display:block}";

/// The predicted error on unseen poses beside the cross-validated one, as the text report says it.
fn predicted(report: &crate::calib::CalibrationReport) -> String {
    let mut out = String::new();
    for (e, unit) in [(&report.predicted_error_deg, "°"), (&report.predicted_error_mm, " mm")] {
        if let Some(e) = e {
            let _ = write!(
                out,
                "<p>Predicted error of the calibrated model on unseen poses: <b>{:.4}{unit} RMS</b> (90%: {:.4}–{:.4}{unit}; worst pose {:.4}{unit}).</p>",
                e.rms, e.interval_90[0], e.interval_90[1], e.max
            );
        }
    }
    if let Some(c) = report.markers.as_ref().map(|m| &m.camera_model) {
        let depth = match c.depth_scale_std_error {
            Some(se) => format!("depth scale {:.4} ± {se:.4}", c.depth_scale),
            None => format!("depth scale {:.4} (held)", c.depth_scale),
        };
        let _ = write!(
            out,
            "<p class=\"{}\">Camera model <b>{}</b>{}: {depth}.{}</p>",
            if c.finding.is_some() { "warn" } else { "meta" },
            c.model.name(),
            c.choice.as_ref().map_or(String::new(), |choice| format!(" ({})", escape(&choice.summary))),
            c.finding.as_ref().map_or(String::new(), |f| format!(" {}.", escape(&capitalised(f))))
        );
    }
    if let Some(cv) = &report.cross_validation
        && let Some(expected) = cv.expected_rms
    {
        let _ = write!(
            out,
            "<p class=\"{}\">Cross-validated {:.4} {unit} RMS against {expected:.4} {unit} expected from the camera noise and the predicted error: {}.</p>",
            if cv.consistent { "pass" } else { "warn" },
            cv.calibrated_rms,
            if cv.consistent {
                "consistent"
            } else {
                "they disagree beyond their uncertainty: the noise model or the model is wrong"
            },
            unit = cv.unit
        );
    }
    out
}

/// `&`, `<`, `>` and quotes escaped.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// An SVG drawn by `draw` into a `width × height` canvas; a drawing error becomes a note.
fn svg(
    width: u32,
    height: u32,
    draw: impl for<'a> FnOnce(
        &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    ) -> Result<(), Box<dyn std::error::Error>>,
) -> String {
    let mut out = String::new();
    let result = {
        let root = SVGBackend::with_string(&mut out, (width, height)).into_drawing_area();
        let drawn = root.fill(&WHITE).map_err(|e| e.to_string()).and_then(|()| draw(&root).map_err(|e| e.to_string()));
        drawn.and_then(|()| root.present().map_err(|e| e.to_string()))
    };
    match result {
        Ok(()) => out,
        Err(e) => format!("<p>(plot not drawn: {})</p>", escape(&e)),
    }
}

/// Per pose, before (nominal) and after calibration: the RMS marker error (mm) or the FDA-vs-vision
/// angle (°).
fn per_pose(c: &Calibration) -> String {
    let (unit, before, after) = match c.report.fit {
        FitLevel::Markers => {
            let by_pose = |residuals: &[Vector3<f64>]| -> Vec<(f64, f64)> {
                per_pose_rms_mm(marker_observations(c), residuals).into_iter().map(|(p, e)| (p as f64, e)).collect()
            };
            ("mm", by_pose(&c.nominal.residuals), by_pose(&c.calibrated.residuals))
        }
        FitLevel::Orientations => {
            let deg = |residuals: &[Vector3<f64>]| -> Vec<(f64, f64)> {
                fitted_poses(c).iter().zip(residuals).map(|(o, r)| (o.pose as f64, r.norm().to_degrees())).collect()
            };
            ("°", deg(&c.nominal.residuals), deg(&c.calibrated.residuals))
        }
    };
    let x_max = before.iter().map(|p| p.0).fold(1.0, f64::max);
    let y_max = before.iter().chain(&after).map(|p| p.1).fold(1e-9, f64::max) * 1.1;
    svg(900, 320, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..x_max, 0.0..y_max)?;
        chart.configure_mesh().light_line_style(TRANSPARENT).x_desc("pose").y_desc(format!("error ({unit})")).draw()?;
        let grey = RGBColor(160, 160, 160);
        let blue = RGBColor(31, 119, 180);
        chart
            .draw_series(before.iter().map(|&p| Circle::new(p, 2, grey.filled())))?
            .label("nominal (best-fit registration)")
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, grey.filled()));
        chart
            .draw_series(after.iter().map(|&p| Circle::new(p, 2, blue.filled())))?
            .label("calibrated")
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, blue.filled()));
        chart.configure_series_labels().border_style(BLACK).background_style(WHITE.mix(0.9)).draw()?;
        Ok(())
    })
}

/// RMS of the calibrated residuals along each camera axis: per marker (marker-level fit, mm) or
/// of the rotation vector (orientation-level, °).
fn residuals(c: &Calibration) -> String {
    let groups: Vec<(String, [f64; 3])> = match c.report.fit {
        FitLevel::Markers => {
            let names: Vec<String> = c
                .report
                .markers
                .as_ref()
                .map_or_else(Vec::new, |m| m.after.per_marker.iter().map(|(name, _, _)| name.clone()).collect());
            names
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    let of_k: Vec<&Vector3<f64>> = marker_observations(c)
                        .iter()
                        .zip(&c.calibrated.residuals)
                        .filter(|(o, _)| o.marker == k)
                        .map(|(_, r)| r)
                        .collect();
                    let rms = |axis: usize| crate::math::stats::rms(of_k.iter().map(|r| r[axis] * 1e3));
                    (name.clone(), [rms(0), rms(1), rms(2)])
                })
                .collect()
        }
        FitLevel::Orientations => {
            let r = &c.calibrated.residuals;
            let rms = |axis: usize| crate::math::stats::rms(r.iter().map(|v| v[axis].to_degrees()));
            vec![("rotation".into(), [rms(0), rms(1), rms(2)])]
        }
    };
    let unit = if c.report.fit == FitLevel::Markers { "mm" } else { "°" };
    let y_max = groups.iter().flat_map(|g| g.1).fold(1e-9, f64::max) * 1.6;
    let n = groups.len();
    svg(900, 300, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d((0..3 * n.max(1)).into_segmented(), 0.0..y_max)?;
        // Three bars per group (camera x, y, z); the group's name under the middle one.
        let labels: Vec<String> = groups.iter().flat_map(|g| [String::new(), g.0.clone(), String::new()]).collect();
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_labels(3 * n.max(1))
            .x_label_formatter(&|x| category(x, &labels))
            .y_desc(format!("RMS residual ({unit})"))
            .draw()?;
        let colours = [RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(31, 119, 180)];
        for (axis, (colour, name)) in colours.iter().zip(["camera x", "camera y", "camera z (depth)"]).enumerate() {
            let bars = groups.iter().enumerate().map(|(k, g)| {
                let slot = 3 * k + axis;
                Rectangle::new(
                    [(SegmentValue::Exact(slot), 0.0), (SegmentValue::Exact(slot + 1), g.1[axis])],
                    colour.filled(),
                )
            });
            let colour = *colour;
            chart
                .draw_series(bars)?
                .label(name)
                .legend(move |(x, y)| Rectangle::new([(x, y - 4), (x + 10, y + 4)], colour.filled()));
        }
        chart.configure_series_labels().border_style(BLACK).background_style(WHITE.mix(0.9)).draw()?;
        Ok(())
    })
}

/// The label of a category axis' value: the name at its centre, nothing elsewhere.
fn category(value: &SegmentValue<usize>, names: &[String]) -> String {
    match value {
        SegmentValue::CenterOf(k) => names.get(*k).cloned().unwrap_or_default(),
        _ => String::new(),
    }
}

/// Each free parameter's change from nominal with ± 2 standard errors (degrees).
fn parameters(c: &Calibration) -> String {
    let rows: Vec<(String, f64, f64)> = c
        .report
        .parameters
        .iter()
        .filter(|p| !p.frozen)
        .map(|p| (p.name.clone(), p.change_deg, 2.0 * p.std_error_deg.unwrap_or(0.0)))
        .collect();
    let reach = rows.iter().map(|r| r.1.abs() + r.2).fold(1e-6, f64::max) * 1.1;
    let n = rows.len();
    svg(900, 40 + 22 * n as u32, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(150)
            .build_cartesian_2d(-reach..reach, (0..n.max(1)).into_segmented())?;
        let names: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .y_labels(n.max(1))
            .y_label_formatter(&|y| category(y, &names))
            .x_desc("change from nominal (°), ± 2 standard errors")
            .draw()?;
        let blue = RGBColor(31, 119, 180);
        chart.draw_series(rows.iter().enumerate().map(|(k, r)| {
            let y = SegmentValue::CenterOf(k);
            PathElement::new([(r.1 - r.2, y.clone()), (r.1 + r.2, y)], blue.stroke_width(2))
        }))?;
        chart.draw_series(
            rows.iter().enumerate().map(|(k, r)| Circle::new((r.1, SegmentValue::CenterOf(k)), 3, blue.filled())),
        )?;
        let axis = [(0.0, SegmentValue::Exact(0)), (0.0, SegmentValue::Exact(n))];
        chart.draw_series(std::iter::once(PathElement::new(axis, BLACK.stroke_width(1))))?;
        Ok(())
    })
}

/// The scaled singular values of the identification Jacobian, largest first, log scale.
fn identifiability(c: &Calibration) -> String {
    let spectrum = &c.report.identifiability.spectrum;
    let low = spectrum.iter().copied().filter(|s| *s > 0.0).fold(1.0, f64::min).min(1e-3) / 2.0;
    let n = spectrum.len();
    svg(900, 260, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..n.max(1) as f64, (low..1.5).log_scale())?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_desc("direction (strongest first)")
            .y_desc("σ / σmax")
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()?;
        let blue = RGBColor(31, 119, 180);
        chart.draw_series(
            spectrum.iter().enumerate().map(|(k, s)| Circle::new((k as f64 + 0.5, s.max(low)), 3, blue.filled())),
        )?;
        Ok(())
    })
}

/// Where the poses are: the calibrated MP orientations' rotation vectors, x against y (degrees).
fn coverage(c: &Calibration) -> String {
    let points: Vec<(f64, f64)> = c
        .calibrated
        .orientations
        .iter()
        .map(|r| {
            let w = so3::log(r);
            (w.x.to_degrees(), w.y.to_degrees())
        })
        .collect();
    let reach = points.iter().map(|p| p.0.abs().max(p.1.abs())).fold(1.0, f64::max) * 1.1;
    svg(460, 440, |root| {
        let mut chart = ChartBuilder::on(root)
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(-reach..reach, -reach..reach)?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_desc("rotation about x (°)")
            .y_desc("rotation about y (°)")
            .draw()?;
        let blue = RGBColor(31, 119, 180);
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 2, blue.filled())))?;
        Ok(())
    })
}

/// The sentence with its first letter in capitals.
fn capitalised(sentence: &str) -> String {
    let mut chars = sentence.chars();
    chars.next().map_or_else(String::new, |c| c.to_uppercase().chain(chars).collect())
}

/// The marker observations a calibration fitted (none for an orientation-level one).
fn marker_observations(c: &Calibration) -> &[crate::calib::MarkerObservation] {
    match &c.fitted {
        Fitted::Markers(observations) => observations,
        _ => &[],
    }
}

/// The poses an orientation-level calibration fitted (none for a marker-level one).
fn fitted_poses(c: &Calibration) -> &[crate::calib::Observation] {
    match &c.fitted {
        Fitted::Orientations { fitted, .. } => fitted,
        _ => &[],
    }
}
