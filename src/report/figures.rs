//! How a chart reaches the page: drawn with plotters as inline SVG that scales with the page
//! (a `viewBox`, `width: 100 %`, no fixed size), twice — wide for screens and narrow for phones,
//! the page's style showing one — so that its text stays readable at either width; its legend
//! is HTML under it (it wraps, and never covers the data); its caption says how to read it.

use std::error::Error;
use std::fmt::Write as _;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::tables::escape;

/// The page shows the narrow drawing below this width (CSS pixels), the wide one from it on.
pub(crate) const NARROW_BELOW_PX: u32 = 640;

/// The usual widths of the wide and the narrow drawing (SVG units; a drawing is shown at most
/// [`GROWS_TO`] times its width, so its text stays between about 9 and 15 px).
pub(crate) const WIDE: u32 = 760;
pub(crate) const NARROW: u32 = 380;

/// How far a drawing may grow past its own width on a wide page.
const GROWS_TO: f64 = 1.25;

/// Tick labels and axis titles: 15 plotters units, 12 px in the SVG (plotters divides by 1.24).
const FONT: (&str, u32) = ("sans-serif", 15);

/// Which of the two drawings is being drawn, and its size.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    /// Width of the drawing (SVG units).
    pub(crate) width: u32,
    /// Height of the drawing (SVG units).
    pub(crate) height: u32,
    /// The phone's drawing: fewer ticks, narrower label areas.
    pub(crate) narrow: bool,
}

impl Layout {
    /// Tick labels along a horizontal axis.
    pub(crate) fn x_labels(&self) -> usize {
        if self.narrow { 5 } else { 10 }
    }
}

/// What a legend entry shows beside its label.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Mark {
    /// A dot (points).
    Dot,
    /// A square (bars, bands, cells).
    Square,
}

/// One legend entry.
#[derive(Debug, Clone)]
pub(crate) struct Key {
    pub(crate) colour: RGBColor,
    pub(crate) mark: Mark,
    pub(crate) label: String,
}

/// A chart for the page: its two drawings, the legend and the caption.
#[derive(Debug, Clone)]
pub(crate) struct Figure {
    drawings: String,
    keys: Vec<Key>,
    caption: String,
}

/// The drawing function of a chart: called once per layout.
pub(crate) type Draw<'f> =
    dyn for<'a> Fn(&DrawingArea<SVGBackend<'a>, Shift>, &Layout) -> Result<(), Box<dyn Error>> + 'f;

impl Figure {
    /// `draw` drawn at the `wide` and the `narrow` `(width, height)`; `label` names the chart for
    /// a screen reader.
    pub(crate) fn new(label: &str, wide: (u32, u32), narrow: (u32, u32), draw: &Draw<'_>) -> Figure {
        let wide = Layout { width: wide.0, height: wide.1, narrow: false };
        let narrow = Layout { width: narrow.0, height: narrow.1, narrow: true };
        let drawings = svg(label, "wide", &wide, draw) + &svg(label, "narrow", &narrow, draw);
        Figure { drawings, keys: Vec::new(), caption: String::new() }
    }

    /// With a legend.
    pub(crate) fn keys(mut self, keys: Vec<Key>) -> Figure {
        self.keys = keys;
        self
    }

    /// With a caption (plain text).
    pub(crate) fn caption(mut self, caption: impl Into<String>) -> Figure {
        self.caption = caption.into();
        self
    }

    /// The figure as HTML: the drawings, the legend under them, the caption.
    pub(crate) fn html(&self) -> String {
        let mut s = format!("<figure>{}", self.drawings);
        if !self.keys.is_empty() {
            s += "<ul class=\"legend\">";
            for k in &self.keys {
                let RGBColor(r, g, b) = k.colour;
                let shape = match k.mark {
                    Mark::Dot => "dot",
                    Mark::Square => "square",
                };
                let _ = write!(
                    s,
                    "<li><span class=\"{shape}\" style=\"background:#{r:02x}{g:02x}{b:02x}\"></span>{}</li>",
                    escape(&k.label)
                );
            }
            s += "</ul>";
        }
        if !self.caption.is_empty() {
            let _ = write!(s, "<figcaption>{}</figcaption>", escape(&self.caption));
        }
        s + "</figure>"
    }
}

/// One drawing as an SVG element that scales with its box (class `class`, no width or height of
/// its own: the page's style sets them); a drawing error becomes a note instead.
fn svg(label: &str, class: &str, layout: &Layout, draw: &Draw<'_>) -> String {
    let (width, height) = (layout.width, layout.height);
    let mut out = String::new();
    let result = {
        let root = SVGBackend::with_string(&mut out, (width, height)).into_drawing_area();
        let drawn =
            root.fill(&WHITE).map_err(|e| e.to_string()).and_then(|()| draw(&root, layout).map_err(|e| e.to_string()));
        drawn.and_then(|()| root.present().map_err(|e| e.to_string()))
    };
    match result {
        Ok(()) => lean(&out).replacen(
            &format!("<svg width=\"{width}\" height=\"{height}\" "),
            &format!(
                "<svg class=\"{class}\" style=\"max-width:{:.0}px\" role=\"img\" aria-label=\"{}\" ",
                f64::from(width) * GROWS_TO,
                escape(label)
            ),
            1,
        ),
        Err(e) => format!("<p class=\"{class}\">(plot not drawn: {})</p>", escape(&e)),
    }
}

/// The drawing without the attributes plotters writes on every element that only restate SVG's
/// defaults (`opacity="1"`, no stroke on a filled shape): half the bytes of a dot.
fn lean(svg: &str) -> String {
    svg.replace(" opacity=\"1\"", "").replace(" stroke=\"none\" stroke-width=\"1\"", "")
}

/// The font of tick labels and axis titles.
pub(crate) fn font() -> TextStyle<'static> {
    FONT.into_font().into()
}

/// A tick label of a continuous axis: as few decimals as the value needs (`50`, `0.5`, `−1.25`),
/// never `50.0`.
pub(crate) fn tick(value: f64) -> String {
    let s = format!("{value:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.replace('-', "−") }
}

/// A tick label of a counting axis (poses, directions): the whole numbers, nothing between them.
pub(crate) fn whole(value: f64) -> String {
    if value.fract() == 0.0 { tick(value) } else { String::new() }
}

/// A tick label of a log axis: the power of ten, `1e-3`.
pub(crate) fn power(value: f64) -> String {
    format!("{value:.0e}").replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_have_the_decimals_they_need() {
        let cases =
            [(50.0, "50"), (0.5, "0.5"), (-1.25, "−1.25"), (0.30000000000000004, "0.3"), (-0.0, "0"), (0.0, "0")];
        for (v, s) in cases {
            assert_eq!(tick(v), s);
        }
        assert_eq!((whole(150.0), whole(2.5)), ("150".to_string(), String::new()));
        assert_eq!(power(0.001), "1e−3");
    }

    #[test]
    fn a_drawing_scales_with_its_box() {
        let draw: &Draw<'_> = &|root, _| {
            root.draw(&Circle::new((5, 5), 2, BLUE.filled()))?;
            Ok(())
        };
        let html = Figure::new("a dot", (760, 200), (380, 100), draw).caption("one dot").html();
        assert!(html.contains("<svg class=\"wide\" style=\"max-width:950px\" role=\"img\" aria-label=\"a dot\" viewBox=\"0 0 760 200\""), "{html}");
        assert!(html.contains("<svg class=\"narrow\" style=\"max-width:475px\" role=\"img\" aria-label=\"a dot\" viewBox=\"0 0 380 100\""), "{html}");
        assert!(!html.contains("<svg width") && html.ends_with("<figcaption>one dot</figcaption></figure>"));
        // The dot keeps what draws it and loses what restates the defaults.
        assert!(html.contains("<circle cx=\"5\" cy=\"5\" r=\"2\" fill=\"#0000FF\"/>"), "{html}");
    }
}
