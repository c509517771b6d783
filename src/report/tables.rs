//! The report's tables, one [`Table`] type for every view: markdown for the Rerun recording (a
//! parameter set, the calibrated parameters' changes, the predicted error by region of the
//! workspace, the fit's iterations) and HTML for the report page. A section added later (another
//! camera model's terms, a rig's cameras) builds a `Table` and gets both renderings.

use std::fmt::Write as _;

use nalgebra::Vector3;

use crate::calib::{Calibration, IterationLog, PredictedError};
use crate::model::Parameters;

/// How a column's cells read: words flush left, numbers flush right with figures of equal width
/// (so that decimal points line up down the column).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Align {
    /// Words, sentences: left, wrapping where the page is narrow.
    Text,
    /// Short labels (a band `10–20°`, a name): left, never broken inside.
    Label,
    /// Numbers: right, never broken inside.
    Number,
}

/// A table: a caption, column headings (the unit in the heading) and rows of cells already
/// formatted. Cells are plain text; the HTML rendering escapes them.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Table {
    caption: String,
    columns: Vec<(String, Align)>,
    rows: Vec<Vec<String>>,
    /// Each row's first cell names the row (a table of facts: what, then its value).
    named_rows: bool,
}

impl Table {
    /// An empty table with these `(heading, alignment)` columns.
    pub(crate) fn new(caption: impl Into<String>, columns: &[(&str, Align)]) -> Table {
        let columns = columns.iter().map(|(h, a)| ((*h).to_string(), *a)).collect();
        Table { caption: caption.into(), columns, rows: Vec::new(), named_rows: false }
    }

    /// A table of facts: each row a name and its value, no column headings.
    pub(crate) fn facts(caption: impl Into<String>) -> Table {
        Table::new(caption, &[("", Align::Text), ("", Align::Text)]).with_named_rows()
    }

    /// The same table with each row's first cell as the row's name.
    pub(crate) fn with_named_rows(mut self) -> Table {
        self.named_rows = true;
        self
    }

    /// Adds a row; a short row is padded with empty cells, a long one cut to the columns.
    pub(crate) fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        let mut row: Vec<String> = cells.into_iter().map(Into::into).take(self.columns.len()).collect();
        row.resize(self.columns.len(), String::new());
        self.rows.push(row);
    }

    /// The table has no row.
    pub(crate) fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The table in markdown (header, rule, rows; the caption is the caller's heading).
    pub(crate) fn markdown(&self) -> String {
        let line = |cells: &mut dyn Iterator<Item = &str>| {
            let mut s = String::from("|");
            for c in cells {
                let _ = write!(s, " {c} |");
            }
            s + "\n"
        };
        let mut s = line(&mut self.columns.iter().map(|c| c.0.as_str()));
        s += &"|---".repeat(self.columns.len());
        s += "|\n";
        for r in &self.rows {
            s += &line(&mut r.iter().map(String::as_str));
        }
        s
    }

    /// The table in HTML under its caption (a heading: a table's own caption would be as narrow
    /// as the table and scroll away with it), inside its own box that scrolls sideways when the
    /// page is narrower than the table (the page itself never does).
    pub(crate) fn html(&self) -> String {
        let class = |a: Align| match a {
            Align::Text => "",
            Align::Label => " class=\"k\"",
            Align::Number => " class=\"n\"",
        };
        let mut s = format!("<h3>{}</h3><div class=\"table\"><table>", escape(&self.caption));
        if self.columns.iter().any(|c| !c.0.is_empty()) {
            s += "<thead><tr>";
            for (heading, align) in &self.columns {
                let _ = write!(s, "<th scope=\"col\"{}>{}</th>", class(*align), escape(heading));
            }
            s += "</tr></thead>";
        }
        s += "<tbody>";
        for r in &self.rows {
            s += "<tr>";
            for (k, (cell, (_, align))) in r.iter().zip(&self.columns).enumerate() {
                let tag = if k == 0 && self.named_rows { "th scope=\"row\"" } else { "td" };
                let end = &tag[..2];
                let _ = write!(s, "<{tag}{}>{}</{end}>", class(*align), escape(cell));
            }
            s += "</tr>";
        }
        s + "</tbody></table></div>"
    }
}

/// A fast capture, as the text and HTML reports give the first: its line of `captures.csv`, or
/// its frame and marker when it came from a bag.
pub(crate) fn fast_capture(c: &crate::calib::FastCapture) -> String {
    let at = crate::calib::file_line("captures.csv", c.line)
        .unwrap_or_else(|| format!("frame {}, marker {}", c.pose, c.marker));
    format!("e.g. {at}, {:.0} deg/s", c.speed_deg_s)
}

/// `&`, `<`, `>` and quotes escaped for HTML text and attributes.
pub(crate) fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A markdown table of a parameter set.
pub(crate) fn parameters(title: &str, p: &Parameters) -> String {
    let mut s = format!("# {title}\n\n");
    let v = |x: &Vector3<f64>| format!("[{:.5}, {:.5}, {:.5}]", x.x, x.y, x.z);
    let mut table = Table::new(
        title,
        &[
            ("leg", Align::Number),
            ("u", Align::Text),
            ("z", Align::Text),
            ("α1 (°)", Align::Number),
            ("α2 (°)", Align::Number),
            ("v0", Align::Text),
            ("δ (°)", Align::Number),
            ("s", Align::Number),
        ],
    );
    for (i, g) in p.legs.iter().enumerate() {
        table.row([
            (i + 1).to_string(),
            v(&g.u),
            v(&g.z),
            format!("{:.4}", g.alpha1.to_degrees()),
            format!("{:.4}", g.alpha2.to_degrees()),
            v(&g.v0),
            format!("{:.4}", g.delta.to_degrees()),
            format!("{:.6}", g.scale),
        ]);
    }
    s += &table.markdown();
    if p.platform_sag_deg != 0.0 {
        let se = p.platform_sag_std_error_deg.map_or(String::new(), |se| format!(" ± {se:.4}"));
        let _ = write!(s, "\nPlatform sag: {:.4}{se}° per unit of the gravity torque's arm\n", p.platform_sag_deg);
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

/// Each parameter's change with its standard error (degrees; "frozen" where it was held).
pub(crate) fn parameter_changes(calibration: &Calibration) -> Table {
    let mut table = Table::new(
        "Parameter changes from nominal",
        &[("parameter", Align::Label), ("change (°)", Align::Number), ("std error (°)", Align::Number)],
    );
    for r in &calibration.report.parameters {
        let se = match r.std_error_deg {
            Some(s) => format!("{s:.4}"),
            None if r.at_bound => "at bound".to_string(),
            None => "frozen".to_string(),
        };
        table.row([r.name.clone(), format!("{:+.4}", r.change_deg), se]);
    }
    table
}

/// Each leg's joint scale (`φ = sθ + δ`): its value, its change in ppm with its standard error,
/// or why it was held; `None` when the fit had no scales.
pub(crate) fn joint_scales(calibration: &Calibration) -> Option<Table> {
    let scales = &calibration.report.joint_scales;
    if scales.is_empty() {
        return None;
    }
    let mut table = Table::new(
        "Joint scales (φ = s·θ + δ)",
        &[
            ("leg", Align::Number),
            ("s", Align::Number),
            ("change (ppm)", Align::Number),
            ("std error (ppm)", Align::Number),
        ],
    );
    for s in scales {
        let se = match (s.std_error_ppm, &s.held) {
            (Some(se), _) => format!("{se:.0}"),
            (None, Some(why)) if why.starts_with("frozen") => "frozen".to_string(),
            (None, Some(why)) if why.starts_with("at its bound") => "at bound".to_string(),
            (None, Some(why)) if why.starts_with("not distinguishable") => {
                format!("held: {}", why.split(" (").next().unwrap_or(why))
            }
            (None, _) => format!("held (see {})", super::text::held_scales_list(&calibration.report)),
        };
        table.row([s.leg.to_string(), format!("{:.6}", s.scale), format!("{:+.0}", s.change_ppm), se]);
    }
    Some(table)
}

/// The calibrated parameter set and each parameter's change with its standard error.
pub(crate) fn calibrated_parameters(calibration: &Calibration) -> String {
    let mut after = parameters("Calibrated parameters", &calibration.parameters);
    after.push('\n');
    after += &parameter_changes(calibration).markdown();
    if let Some(t) = joint_scales(calibration) {
        after.push('\n');
        after += &t.markdown();
    }
    after
}

/// A band of tilt or |yaw|, `0–10°` or `> 30°`.
fn band(b: [f64; 2]) -> String {
    match b[1].is_finite() {
        true => format!("{:.0}–{:.0}°", b[0], b[1]),
        false => format!("> {:.0}°", b[0]),
    }
}

/// The predicted orientation error by band of tilt and |yaw|.
pub(crate) fn by_region(e: &PredictedError) -> Table {
    let mut table = Table::new(
        "Predicted orientation error by region of the workspace",
        &[
            ("tilt", Align::Label),
            ("yaw (abs)", Align::Label),
            ("poses", Align::Number),
            ("RMS (°)", Align::Number),
            ("worst (°)", Align::Number),
        ],
    );
    for g in &e.by_region {
        table.row([
            band(g.tilt_deg),
            band(g.yaw_deg),
            g.poses.to_string(),
            format!("{:.4}", g.rms),
            format!("{:.4}", g.worst),
        ]);
    }
    table
}

/// The predicted orientation error by band of tilt and |yaw|, as a markdown table.
pub(crate) fn predicted_error_by_region(e: &PredictedError) -> String {
    format!(
        "# Predicted error after calibration\n\n{:.4}° RMS over the session's poses (90%: {:.4}–{:.4}°), as `compare` measures it.\n\n{}",
        e.rms,
        e.interval_90[0],
        e.interval_90[1],
        by_region(e).markdown()
    )
}

/// The fit's iterations as a markdown table.
pub(crate) fn iterations(iterations: &[IterationLog]) -> String {
    let columns = [
        ("iteration", Align::Number),
        ("cost (whitened)", Align::Number),
        ("RMS (° or mm)", Align::Number),
        ("step (rad)", Align::Number),
        ("radius (rad)", Align::Number),
        ("ratio", Align::Number),
        ("accepted", Align::Text),
    ];
    let mut table = Table::new("The fit, iteration by iteration", &columns);
    for it in iterations {
        table.row([
            it.iteration.to_string(),
            format!("{:.6e}", it.cost),
            format!("{:.5}", it.rms),
            format!("{:.3e}", it.step),
            format!("{:.3e}", it.radius),
            format!("{:.3}", it.ratio),
            (if it.accepted { "yes" } else { "no" }).to_string(),
        ]);
    }
    format!(
        "# The fit, iteration by iteration\n\nPlots of these columns are on the `iteration` timeline.\n\n{}",
        table.markdown()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_and_html_hold_the_same_cells() {
        let mut t = Table::new("Errors <mm>", &[("model", Align::Text), ("RMS (mm)", Align::Number)]);
        t.row(["nominal", "4.3594"]);
        t.row(["a & b"]);
        assert_eq!(t.markdown(), "| model | RMS (mm) |\n|---|---|\n| nominal | 4.3594 |\n| a & b |  |\n");
        let html = t.html();
        assert!(html.starts_with("<h3>Errors &lt;mm&gt;</h3><div class=\"table\"><table>"), "{html}");
        assert!(html.contains("<th scope=\"col\" class=\"n\">RMS (mm)</th>"), "{html}");
        assert!(html.contains("<td>nominal</td><td class=\"n\">4.3594</td>"), "{html}");
        assert!(html.contains("<td>a &amp; b</td><td class=\"n\"></td>"), "{html}");
        assert!(html.ends_with("</table></div>"));
        let mut facts = Table::facts("The fit");
        facts.row(["converged", "in 8 iterations"]);
        let html = facts.html();
        assert!(!html.contains("<thead>"), "{html}");
        assert!(html.contains("<tr><th scope=\"row\">converged</th><td>in 8 iterations</td></tr>"), "{html}");
    }
}
