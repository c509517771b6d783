//! A report a person can read and share (`calibrate --report report.html`), on a desk's screen or
//! a phone's: one self-contained HTML file — inline SVG charts (`charts`), no script, no network —
//! with the verdict first (pass or warn against the config's thresholds), then the charts, then
//! the text report's content as tables (`html_tables`) and the text report itself, folded.

use std::fmt::Write as _;

use super::charts;
use super::figures::NARROW_BELOW_PX;
use super::html_tables;
use super::tables::{Align, Table, escape};
use crate::calib::{Calibration, CalibrationReport, FitLevel};

/// The title of a free-motion recording's section on its camera clock (`camera-clock`, after
/// the pose-by-pose errors).
const CLOCK_TITLE: &str = "Camera clock: the apparent latency against time";

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
    /// `text_report` (the text report) folded at its end.
    pub fn html(&self, text_report: &str) -> String {
        let report = &self.report;
        let mut html = head(report);
        html += &verdict(report);
        if let Some(figure) = charts::model_check(self) {
            html = html.trim_end_matches("</section>").to_string() + &figure.html() + "</section>";
        }
        let figures = [
            charts::per_pose(self),
            charts::residuals(self),
            charts::parameters(self),
            charts::identifiability(self),
            charts::coverage(self),
        ];
        for (figure, (id, title)) in figures.iter().zip(&SECTIONS[1..6]) {
            let _ = write!(html, "<section id=\"{id}\"><h2>{title}</h2>{}", figure.html());
            if *id == "identifiability" {
                html += &weakest(report);
            }
            html += "</section>";
            // A free-motion recording's camera clock, after the errors against time.
            if *id == "per-pose"
                && let Some(clock) = charts::apparent_latency(self)
            {
                let _ = write!(html, "<section id=\"camera-clock\"><h2>{CLOCK_TITLE}</h2>{}</section>", clock.html());
            }
        }
        let _ = writeln!(
            html,
            "<section id=\"tables\"><h2>Tables</h2>{}<details><summary>The text report, as <code>calibrate</code> prints it</summary><pre>{}</pre></details></section></body></html>",
            html_tables::all(self),
            escape(text_report)
        );
        html
    }
}

/// The page's style: the content's width follows the screen's; a chart's narrow drawing shows
/// below [`NARROW_BELOW_PX`], its wide one from there on; tables scroll inside their own box.
fn style() -> String {
    let narrow = NARROW_BELOW_PX - 1;
    format!(
        "*{{box-sizing:border-box}}\
         body{{font-family:system-ui,-apple-system,\"Segoe UI\",Roboto,sans-serif;line-height:1.45;max-width:1000px;margin:0 auto;padding:1em;color:#222}}\
         h1{{font-size:1.6em;margin:.3em 0;overflow-wrap:anywhere}}h2{{font-size:1.3em;margin:1.6em 0 .5em}}\
         p,li,figcaption,summary{{overflow-wrap:anywhere}}\
         .pass{{background:#e6f4ea;border-left:6px solid #2e7d32;padding:.6em .8em}}\
         .warn{{background:#fff4e5;border-left:6px solid #ef6c00;padding:.6em .8em}}\
         .meta,.note,figcaption{{color:#555}}.note{{font-size:.9em}}\
         figure{{margin:.5em 0 1em}}svg{{display:block;width:100%;height:auto}}.narrow{{display:none}}\
         @media (max-width:{narrow}px){{.wide{{display:none}}.narrow{{display:block}}}}\
         figcaption{{font-size:.9em;margin-top:.3em}}\
         .legend{{list-style:none;margin:.3em 0;padding:0;display:flex;flex-wrap:wrap;gap:.2em 1.4em;font-size:.9em}}\
         .legend span{{display:inline-block;width:.8em;height:.8em;margin-right:.4em;vertical-align:-.05em}}.legend .dot{{border-radius:50%}}\
         .table{{overflow-x:auto;margin:0 0 1em}}\
         h3{{font-size:1em;margin:1.4em 0 .2em}}table{{border-collapse:collapse;font-size:.9em}}\
         th,td{{padding:.3em .7em .3em 0;border-bottom:1px solid #ddd;text-align:left;vertical-align:top}}\
         thead th{{border-bottom:2px solid #bbb}}tbody th{{font-weight:500;color:#444}}\
         td{{overflow-wrap:break-word}}.n{{text-align:right;font-variant-numeric:tabular-nums}}td.n,td.k{{white-space:nowrap}}\
         details{{margin:1em 0}}summary{{cursor:pointer}}\
         pre{{background:#f6f6f6;padding:1em;font-size:12px;white-space:pre-wrap;overflow-wrap:anywhere}}"
    )
}

/// The document's head, the title and the line under it.
fn head(report: &CalibrationReport) -> String {
    format!(
        "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\"><head><meta charset=\"utf-8\"/>\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\
         <title>spmcal calibration of {session}</title><style>{style}</style></head><body>\
         <h1>Calibration of {session}</h1><p class=\"meta\">{fit} fit, loss {loss:?}, {poses} poses, {excluded} excluded; spmcal {version}</p>",
        session = escape(&report.session),
        style = style(),
        fit = match report.fit {
            FitLevel::Markers => "marker-level",
            FitLevel::Orientations => "orientation-level",
        },
        loss = report.loss,
        poses = report.poses,
        excluded = report.excluded.len(),
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// The verdict, the warnings, the predicted error on unseen poses, the camera model and the
/// cross-validation's check of the noise model.
fn verdict(report: &CalibrationReport) -> String {
    let v = &report.verdict;
    let class = if v.pass { "pass" } else { "warn" };
    let mut html = format!(
        "<section id=\"verdict\"><h2>Verdict</h2><p class=\"{class}\"><b>{}</b> — {}</p>",
        v.label(),
        escape(&format!("{}.", capitalised(&v.summary)))
    );
    for r in &v.reasons {
        let _ = write!(
            html,
            "<p class=\"warn\"><b>{}</b>: {}{}</p>",
            r.level,
            escape(&capitalised(&r.finding)),
            if r.action.is_empty() { ".".to_string() } else { format!(". What to do: {}.", escape(&r.action)) }
        );
    }
    for w in &report.warnings {
        let _ = write!(html, "<p class=\"warn\"><b>Warning</b>: {}</p>", escape(w));
    }
    for n in &report.notes {
        let _ = write!(html, "<p class=\"note\"><b>Note</b>: {}</p>", escape(n));
    }
    html += &predicted(report);
    html += &camera(report);
    html += &check(report);
    html + "</section>"
}

/// The predicted error of the calibrated model on unseen poses: the platform's orientation (°)
/// and the markers' positions (mm), one row each.
fn predicted(report: &CalibrationReport) -> String {
    let n = Align::Number;
    let columns = [("", Align::Text), ("RMS", n), ("90 % range", n), ("worst pose", n)];
    let mut t = Table::new("Predicted error of the calibrated model on unseen poses", &columns).with_named_rows();
    let markers = format!("markers, {}", report.markers.as_ref().map_or("mm", |m| m.before.unit));
    let orientation = report
        .predicted_error_deg
        .as_ref()
        .map_or(String::new(), |e| format!("orientation (FDA) on poses {}, °", super::html_tables::predicted_over(e)));
    let rows = [(orientation.as_str(), &report.predicted_error_deg), (markers.as_str(), &report.predicted_error_mm)];
    for (what, e) in rows {
        if let Some(e) = e {
            t.row([
                what.to_string(),
                format!("{:.4}", e.rms),
                format!("{:.4}–{:.4}", e.interval_90[0], e.interval_90[1]),
                format!("{:.4}", e.max),
            ]);
        }
    }
    if t.is_empty() { String::new() } else { t.html() }
}

/// The camera model in words, a warning when it is what the residuals want changed.
fn camera(report: &CalibrationReport) -> String {
    let Some(c) = report.markers.as_ref().map(|m| &m.camera_model) else { return String::new() };
    let depth = match c.depth_scale_std_error {
        Some(se) => format!("depth scale {:.4} ± {se:.4}", c.depth_scale),
        None => format!("depth scale {:.4} (held)", c.depth_scale),
    };
    format!(
        "<p class=\"{}\">Camera model <b>{}</b>{}: {depth}.{}</p>",
        if c.finding.is_some() { "warn" } else { "meta" },
        c.model.name(),
        c.choice.as_ref().map_or(String::new(), |choice| format!(" ({})", escape(&choice.summary))),
        c.finding.as_ref().map_or(String::new(), |f| format!(" {}.", escape(&capitalised(f))))
    )
}

/// The model check: whether the residuals are what the noise model says, each test's p-value, and
/// for a failed check its likely cause.
fn check(report: &CalibrationReport) -> String {
    let Some(check) = report.model_check.as_ref() else { return String::new() };
    let mut html = format!(
        "<p class=\"{}\">Model check: {}.</p>",
        if check.passed { "pass" } else { "warn" },
        escape(&check.summary())
    );
    if let (Some(finding), Some(action)) = (&check.finding, &check.action) {
        let _ =
            write!(html, "<p class=\"warn\">Likely cause: {}. What to do: {}.</p>", escape(finding), escape(action));
    }
    html
}

/// The weakest directions of the identification, and those regularised.
fn weakest(report: &CalibrationReport) -> String {
    let id = &report.identifiability;
    let mut html = format!(
        "<p>{} of {} directions identified, condition number {:.3e}.</p><ul>",
        id.rank, id.parameters, id.condition
    );
    for d in &id.weakest {
        let _ = write!(html, "<li>weak: {}</li>", escape(&d.describe()));
    }
    for d in &report.regularised {
        let _ = write!(html, "<li>REGULARISED (not identifiable, held at its start): {}</li>", escape(d));
    }
    html + "</ul>"
}

/// The sentence with its first letter in capitals.
fn capitalised(sentence: &str) -> String {
    let mut chars = sentence.chars();
    chars.next().map_or_else(String::new, |c| c.to_uppercase().chain(chars).collect())
}
