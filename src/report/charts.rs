//! The report's five charts: the error pose by pose (or against time), the residuals by marker
//! and camera axis, the parameters' changes with ± 2σ, the identifiability spectrum and the
//! workspace the poses cover. A recording with more than [`DOTS_AT_MOST`] poses is summarised
//! (`summary`): the errors as a median and a 5–95 % band per time bin, the workspace as a grid of
//! counts.

use std::collections::HashMap;
use std::error::Error;

use nalgebra::Vector3;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::figures::{Figure, Key, Layout, Mark, NARROW, WIDE, font, power, tick, whole};
use super::summary::{Bin, binned, density, runs};
use crate::calib::{Calibration, FitLevel, Fitted, MarkerObservation, per_pose_rms};
use crate::math::so3;

/// Above this many points a series is summarised rather than drawn dot by dot.
pub(crate) const DOTS_AT_MOST: usize = 2000;

/// Bins of a summarised series (the same at both widths: the caption states their span).
const BINS: usize = 100;

/// Cells along each axis of the summarised workspace.
const CELLS: usize = 24;

const GREY: RGBColor = RGBColor(150, 150, 150);
const BLUE: RGBColor = RGBColor(31, 119, 180);

/// What the horizontal axis of the error chart counts.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Along {
    /// Pose ids.
    Pose,
    /// Seconds from the first capture.
    Seconds,
    /// Minutes from the first capture (a recording over ten minutes long).
    Minutes,
}

impl Along {
    fn title(self) -> &'static str {
        match self {
            Along::Pose => "pose",
            Along::Seconds => "time from the first capture (s)",
            Along::Minutes => "time from the first capture (min)",
        }
    }
}

/// The error of every pose, nominal and calibrated, in the fit's unit: `(x, error)`.
struct Errors {
    unit: &'static str,
    along: Along,
    before: Vec<(f64, f64)>,
    after: Vec<(f64, f64)>,
}

impl Errors {
    fn of(c: &Calibration) -> Errors {
        match c.report.fit {
            FitLevel::Markers => {
                let observations = marker_observations(c);
                let (unit, to_unit) = marker_unit(c);
                let by_pose = |r: &[Vector3<f64>]| -> Vec<(u64, f64)> { per_pose_rms(observations, r, to_unit) };
                let (before, after) = (by_pose(&c.nominal.residuals), by_pose(&c.calibrated.residuals));
                let recording = c.report.markers.as_ref().is_some_and(|m| m.latency.is_some());
                let (along, x) = abscissa(observations, &after, recording);
                let with_x = |poses: Vec<(u64, f64)>| poses.into_iter().map(|(p, e)| (x(p), e)).collect();
                Errors { unit, along, before: with_x(before), after: with_x(after) }
            }
            FitLevel::Orientations => {
                let deg = |r: &[Vector3<f64>]| -> Vec<(f64, f64)> {
                    fitted_poses(c).iter().zip(r).map(|(o, r)| (o.pose as f64, r.norm().to_degrees())).collect()
                };
                Errors {
                    unit: "°",
                    along: Along::Pose,
                    before: deg(&c.nominal.residuals),
                    after: deg(&c.calibrated.residuals),
                }
            }
        }
    }
}

/// The unit of a marker-level fit's residuals and the factor from their own (metres, or pixels
/// for a pixel session's) to it.
fn marker_unit(c: &Calibration) -> (&'static str, f64) {
    match c.report.markers.as_ref().map_or("mm", |m| m.before.unit) {
        "px" => ("px", 1.0),
        _ => ("mm", 1e3),
    }
}

/// The horizontal axis of the marker-level error chart: for a free-motion `recording` whose every
/// pose has a time, the time from the first capture; else the pose id. And the map from pose to
/// it.
fn abscissa(
    observations: &[MarkerObservation],
    poses: &[(u64, f64)],
    recording: bool,
) -> (Along, Box<dyn Fn(u64) -> f64>) {
    let mut times: HashMap<u64, f64> = HashMap::new();
    for o in observations {
        if let Some(t) = o.time_s {
            times.entry(o.pose).or_insert(t);
        }
    }
    let timed = recording && poses.len() > 1 && poses.iter().all(|(p, _)| times.contains_key(p));
    if !timed {
        return (Along::Pose, Box::new(|p| p as f64));
    }
    let t0 = times.values().copied().fold(f64::INFINITY, f64::min);
    let span = times.values().copied().fold(f64::NEG_INFINITY, f64::max) - t0;
    let (along, scale) = if span > 600.0 { (Along::Minutes, 60.0) } else { (Along::Seconds, 1.0) };
    (along, Box::new(move |p| times.get(&p).map_or(0.0, |t| (t - t0) / scale)))
}

/// Per pose, before (nominal) and after calibration: the RMS marker error (mm) or the
/// FDA-vs-vision angle (°); summarised in time bins for a long recording.
pub(crate) fn per_pose(c: &Calibration) -> Figure {
    let e = Errors::of(c);
    let x_max = e.before.iter().chain(&e.after).map(|p| p.0).fold(1.0, f64::max);
    let summarised = e.after.len().max(e.before.len()) > DOTS_AT_MOST;
    let mark = if summarised { Mark::Square } else { Mark::Dot };
    let keys = vec![
        Key { colour: GREY, mark, label: "nominal (best-fit registration)".into() },
        Key { colour: BLUE, mark, label: "calibrated".into() },
    ];
    let what = match e.unit {
        "°" => "the angle between the model's and the camera's orientation (°)".to_string(),
        unit => format!("its markers' RMS error ({unit})"),
    };
    if !summarised {
        let y_max = e.before.iter().chain(&e.after).map(|p| p.1).fold(1e-9, f64::max) * 1.1;
        let figure = Figure::new(
            "the error of each pose, nominal and calibrated",
            (WIDE, 320),
            (NARROW, 300),
            &|root, layout| {
                errors_chart(root, layout, &e, (x_max, y_max), &|chart| {
                    for (series, colour) in [(&e.before, GREY), (&e.after, BLUE)] {
                        chart.draw_series(series.iter().map(|&p| Circle::new(p, 2, colour.filled())))?;
                    }
                    Ok(())
                })
            },
        );
        return figure.keys(keys).caption(format!("Each dot is a pose: {what}."));
    }
    let bins = |s: &[(f64, f64)]| binned(s, (0.0, x_max), BINS);
    let (before, after) = (bins(&e.before), bins(&e.after));
    let y_max = before.iter().chain(&after).map(|b| b.high).fold(1e-9, f64::max) * 1.1;
    let figure = Figure::new(
        "the error against time, nominal and calibrated, in bins",
        (WIDE, 320),
        (NARROW, 300),
        &|root, layout| {
            errors_chart(root, layout, &e, (x_max, y_max), &|chart| {
                for (bins, colour) in [(&before, GREY), (&after, BLUE)] {
                    draw_band(chart, bins, x_max / BINS as f64, colour)?;
                }
                Ok(())
            })
        },
    );
    figure.keys(keys).caption(format!(
        "{} poses in {BINS} bins of {}: in each bin the line is the median of {what}, the band holds 90 % of the poses (5th to 95th percentile).",
        thousands(e.after.len()),
        bin_span(e.along, x_max / BINS as f64)
    ))
}

/// How long a bin is, in words: `36 s`, `4 poses`.
fn bin_span(along: Along, width: f64) -> String {
    match along {
        Along::Pose => format!("{} poses", tick(width.round().max(1.0))),
        Along::Seconds => format!("{} s", tick((width * 10.0).round() / 10.0)),
        Along::Minutes => format!("{} s", tick((width * 60.0).round())),
    }
}

/// `51988` as `51,988`.
fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A chart of two continuous axes over the SVG backend.
type Xy<'a, 'b> = ChartContext<'b, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// What draws a chart's series into its axes.
type Series<'f, 'a> = dyn for<'b> Fn(&mut Xy<'a, 'b>) -> Result<(), Box<dyn Error>> + 'f;

/// Linear axes over `x × y` with the charts' common mesh (no light lines, the report's font, six
/// y labels), `y_area` the y label area's width (narrow, wide) and `x_ticks` the x labels' format.
fn linear_axes<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    layout: &Layout,
    (x, y): (std::ops::Range<f64>, std::ops::Range<f64>),
    (x_desc, y_desc): (&str, &str),
    (narrow_area, wide_area): (u32, u32),
    x_ticks: fn(f64) -> String,
) -> Result<ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>, Box<dyn Error>> {
    let mut chart = ChartBuilder::on(root)
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(if layout.narrow { narrow_area } else { wide_area })
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .label_style(font())
        .axis_desc_style(font())
        .x_labels(layout.x_labels())
        .y_labels(6)
        .x_label_formatter(&|v| x_ticks(*v))
        .y_label_formatter(&|v| tick(*v))
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()?;
    Ok(chart)
}

/// The error chart's axes over `[0, x_max] × [0, y_max]`, then `series` drawn into them.
fn errors_chart<'a>(
    root: &DrawingArea<SVGBackend<'a>, Shift>,
    layout: &Layout,
    e: &Errors,
    (x_max, y_max): (f64, f64),
    series: &Series<'_, 'a>,
) -> Result<(), Box<dyn Error>> {
    let x_ticks = if e.along == Along::Pose { whole } else { tick };
    let y_desc = format!("error ({})", e.unit);
    let mut chart = linear_axes(root, layout, (0.0..x_max, 0.0..y_max), (e.along.title(), &y_desc), (48, 60), x_ticks)?;
    series(&mut chart)
}

/// A binned series: its 5–95 % band, light, and its median, a line, over each run of bins.
fn draw_band(chart: &mut Xy<'_, '_>, bins: &[Bin], width: f64, colour: RGBColor) -> Result<(), Box<dyn Error>> {
    for run in runs(bins) {
        let (first, last) = (run[0], run[run.len() - 1]);
        let ends = |b: Bin, side: f64, v: f64| (b.x + side * width / 2.0, v);
        let mut outline = vec![ends(first, -1.0, first.low)];
        outline.extend(run.iter().map(|b| (b.x, b.low)));
        outline.push(ends(last, 1.0, last.low));
        outline.push(ends(last, 1.0, last.high));
        outline.extend(run.iter().rev().map(|b| (b.x, b.high)));
        outline.push(ends(first, -1.0, first.high));
        chart.draw_series(std::iter::once(Polygon::new(outline, colour.mix(0.3).filled())))?;
        let mut median = vec![ends(first, -1.0, first.median)];
        median.extend(run.iter().map(|b| (b.x, b.median)));
        median.push(ends(last, 1.0, last.median));
        chart.draw_series(LineSeries::new(median, colour.stroke_width(2)))?;
    }
    Ok(())
}

/// RMS of the calibrated residuals along each camera axis: per marker (marker-level fit, mm) or
/// of the rotation vector (orientation-level, °).
pub(crate) fn residuals(c: &Calibration) -> Figure {
    let groups = residual_groups(c);
    let unit = if c.report.fit == FitLevel::Markers { marker_unit(c).0 } else { "°" };
    let y_max = groups.iter().flat_map(|g| g.1).fold(1e-9, f64::max) * 1.15;
    let n = groups.len().max(1);
    let colours = [RGBColor(214, 39, 40), RGBColor(44, 160, 44), BLUE];
    let names = ["camera x", "camera y", "camera z (depth)"];
    // Four slots per group: a gap, then the bars of camera x, y and z, the group's name under the
    // middle one; one more gap closes the axis.
    let labels: Vec<String> =
        groups.iter().flat_map(|g| [String::new(), String::new(), g.0.clone(), String::new()]).collect();
    let figure =
        Figure::new("the residuals' RMS by marker and camera axis", (WIDE, 300), (NARROW, 280), &|root, layout| {
            let mut chart = ChartBuilder::on(root)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(if layout.narrow { 52 } else { 64 })
                .build_cartesian_2d((0..4 * n).into_segmented(), 0.0..y_max)?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .label_style(font())
                .axis_desc_style(font())
                .disable_x_mesh()
                .x_labels(4 * n + 1)
                .y_labels(6)
                .x_label_formatter(&|x| category(x, &labels))
                .y_label_formatter(&|y| tick(*y))
                .y_desc(format!("RMS residual ({unit})"))
                .draw()?;
            for (axis, colour) in colours.iter().enumerate() {
                chart.draw_series(groups.iter().enumerate().map(|(k, g)| {
                    let slot = 4 * k + 1 + axis;
                    let corners = [(SegmentValue::Exact(slot), 0.0), (SegmentValue::Exact(slot + 1), g.1[axis])];
                    Rectangle::new(corners, colour.filled())
                }))?;
            }
            Ok(())
        });
    let keys =
        colours.iter().zip(names).map(|(&colour, label)| Key { colour, mark: Mark::Square, label: label.into() });
    figure.keys(keys.collect())
}

/// `(name, RMS along camera x, y, z)` of the calibrated residuals: per marker (mm) or of the
/// rotation vector (°).
fn residual_groups(c: &Calibration) -> Vec<(String, [f64; 3])> {
    match c.report.fit {
        FitLevel::Markers => {
            let names: Vec<String> = c
                .report
                .markers
                .as_ref()
                .map_or_else(Vec::new, |m| m.after.per_marker.iter().map(|(name, _, _)| name.clone()).collect());
            let observations = marker_observations(c);
            names
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    let of_k: Vec<&Vector3<f64>> = observations
                        .iter()
                        .zip(&c.calibrated.residuals)
                        .filter(|(o, _)| o.marker == k)
                        .map(|(_, r)| r)
                        .collect();
                    let to_unit = marker_unit(c).1;
                    let rms = |axis: usize| crate::math::stats::rms(of_k.iter().map(|r| r[axis] * to_unit));
                    (name.clone(), [rms(0), rms(1), rms(2)])
                })
                .collect()
        }
        FitLevel::Orientations => {
            let r = &c.calibrated.residuals;
            let rms = |axis: usize| crate::math::stats::rms(r.iter().map(|v| v[axis].to_degrees()));
            vec![("rotation".into(), [rms(0), rms(1), rms(2)])]
        }
    }
}

/// The label of a category axis' value: the name at its centre, nothing elsewhere.
fn category(value: &SegmentValue<usize>, names: &[String]) -> String {
    match value {
        SegmentValue::CenterOf(k) => names.get(*k).cloned().unwrap_or_default(),
        _ => String::new(),
    }
}

/// Each free parameter's change from nominal with ± 2 standard errors (degrees).
pub(crate) fn parameters(c: &Calibration) -> Figure {
    let rows: Vec<(String, f64, f64)> = c
        .report
        .parameters
        .iter()
        .filter(|p| !p.frozen)
        .map(|p| (p.name.clone(), p.change_deg, 2.0 * p.std_error_deg.unwrap_or(0.0)))
        .collect();
    let reach = rows.iter().map(|r| r.1.abs() + r.2).fold(1e-6, f64::max) * 1.1;
    let n = rows.len();
    // The first parameter on top: row k in segment `top − k` (plotters' segments include the
    // range's end, so `0..top` has `top + 1` of them).
    let top = n.max(2) - 1;
    let names: Vec<String> = (0..=top).map(|j| rows.get(top - j).map_or(String::new(), |r| r.0.clone())).collect();
    let row = |k: usize| SegmentValue::CenterOf(top - k);
    let height = 56 + 22 * n as u32;
    let figure = Figure::new(
        "each free parameter's change from nominal with ± 2 standard errors",
        (WIDE, height),
        (NARROW, height),
        &|root, layout| {
            let mut chart = ChartBuilder::on(root)
                .margin(12)
                .x_label_area_size(44)
                .y_label_area_size(if layout.narrow { 132 } else { 160 })
                .build_cartesian_2d(-reach..reach, (0..top).into_segmented())?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .label_style(font())
                .axis_desc_style(font())
                .x_labels(if layout.narrow { 5 } else { 9 })
                .y_labels(top + 1)
                .x_label_formatter(&|x| tick(*x))
                .y_label_formatter(&|y| category(y, &names))
                .x_desc("change from nominal (°)")
                .draw()?;
            chart.draw_series(
                rows.iter()
                    .enumerate()
                    .map(|(k, r)| PathElement::new([(r.1 - r.2, row(k)), (r.1 + r.2, row(k))], BLUE.stroke_width(2))),
            )?;
            chart.draw_series(rows.iter().enumerate().map(|(k, r)| Circle::new((r.1, row(k)), 3, BLUE.filled())))?;
            let axis = [(0.0, SegmentValue::Exact(0)), (0.0, SegmentValue::Last)];
            chart.draw_series(std::iter::once(PathElement::new(axis, BLACK.stroke_width(1))))?;
            Ok(())
        },
    );
    figure.caption(
        "Each free parameter's change from nominal (dot) with ± 2 standard errors (bar); a bar across zero: not distinguishable from nominal.",
    )
}

/// The scaled singular values of the identification Jacobian, largest first, log scale.
pub(crate) fn identifiability(c: &Calibration) -> Figure {
    let spectrum = &c.report.identifiability.spectrum;
    let low = spectrum.iter().copied().filter(|s| *s > 0.0).fold(1.0, f64::min).min(1e-3) / 2.0;
    let n = spectrum.len();
    let figure = Figure::new("the identifiability spectrum", (WIDE, 280), (NARROW, 260), &|root, layout| {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(if layout.narrow { 52 } else { 60 })
            .build_cartesian_2d(0.0..(n + 1) as f64, (low..1.5).log_scale())?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .label_style(font())
            .axis_desc_style(font())
            .x_labels(layout.x_labels())
            .x_label_formatter(&|x| whole(*x))
            .y_label_formatter(&|y| power(*y))
            .x_desc("direction (strongest first)")
            .y_desc("σ / σmax")
            .draw()?;
        chart.draw_series(
            spectrum.iter().enumerate().map(|(k, s)| Circle::new(((k + 1) as f64, s.max(low)), 3, BLUE.filled())),
        )?;
        Ok(())
    });
    figure.caption("The identification Jacobian's scaled singular values over the largest, strongest direction first (log scale): a direction far below the others is poorly identified by these poses.")
}

/// Where the poses are: the calibrated MP orientations' rotation vectors, x against y (degrees);
/// for many poses, how many fall in each cell of a grid.
pub(crate) fn coverage(c: &Calibration) -> Figure {
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
    let summarised = points.len() > DOTS_AT_MOST;
    let cells = if summarised { density(&points, reach, CELLS) } else { Vec::new() };
    let most = cells.iter().map(|c| c.2).max().unwrap_or(1);
    let figure = Figure::new("the workspace the poses cover", (440, 440), (380, 380), &|root, layout| {
        let mut chart = ChartBuilder::on(root)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d(-reach..reach, -reach..reach)?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .label_style(font())
            .axis_desc_style(font())
            .x_labels(if layout.narrow { 5 } else { 7 })
            .y_labels(if layout.narrow { 5 } else { 7 })
            .x_label_formatter(&|x| tick(*x))
            .y_label_formatter(&|y| tick(*y))
            .x_desc("rotation about x (°)")
            .y_desc("rotation about y (°)")
            .draw()?;
        if summarised {
            let size = 2.0 * reach / CELLS as f64;
            chart.draw_series(cells.iter().map(|&(i, j, count)| {
                let (x, y) = (-reach + size * i as f64, -reach + size * j as f64);
                let shade = (count as f64 / most as f64).sqrt();
                Rectangle::new([(x, y), (x + size, y + size)], BLUE.mix(0.1 + 0.9 * shade).filled())
            }))?;
        } else {
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 2, BLUE.filled())))?;
        }
        Ok(())
    });
    let caption = match summarised {
        true => format!(
            "{} calibrated orientations (rotation vector, x against y) counted in cells of {}°: the darker the cell, the more poses (the darkest holds {}).",
            thousands(points.len()),
            tick((20.0 * reach / CELLS as f64).round() / 10.0),
            thousands(most)
        ),
        false => "Each dot is a pose's calibrated orientation (its rotation vector, x against y).".to_string(),
    };
    figure.caption(caption)
}

/// The marker observations a calibration fitted (none for an orientation-level one).
fn marker_observations(c: &Calibration) -> &[MarkerObservation] {
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

/// A free-motion recording's camera clock: the latency each time bin of the recording implies
/// (`Latency::apparent`, ± 2σ) against the encoders' time, with the fitted line `τ + ρ·t` — a
/// clock running at another rate shows as a slope, one the model misses as dots off the line.
/// `None` without a recording (or too few frames for a bin).
pub(crate) fn apparent_latency(c: &Calibration) -> Option<Figure> {
    let m = c.report.markers.as_ref()?;
    let (l, rate) = (m.latency.as_ref()?, m.clock_rate_ppm.as_ref()?);
    let apparent = &m.apparent_latency;
    if apparent.len() < 2 {
        return None;
    }
    let (first, last) = (apparent[0][0], apparent[apparent.len() - 1][0]);
    let (along, scale) = if last > 600.0 { (Along::Minutes, 60.0) } else { (Along::Seconds, 1.0) };
    let title = match along {
        Along::Minutes => "time on the encoders' clock (min)",
        _ => "time on the encoders' clock (s)",
    };
    let line = |t: f64| (l.value_s + rate.value * 1e-6 * t) * 1e3;
    let points: Vec<(f64, f64, f64)> = apparent.iter().map(|&[t, v, s]| (t / scale, v * 1e3, 2.0 * s * 1e3)).collect();
    let lows = points.iter().map(|p| p.1 - p.2).chain([line(first), line(last)]);
    let highs = points.iter().map(|p| p.1 + p.2).chain([line(first), line(last)]);
    let (lo, hi) = (lows.fold(f64::INFINITY, f64::min), highs.fold(f64::NEG_INFINITY, f64::max));
    let pad = ((hi - lo) * 0.1).max(0.05);
    let (y0, y1) = (lo - pad, hi + pad);
    let (x0, x1) = (0.0_f64.min(first / scale), last / scale * 1.02);
    const ORANGE: RGBColor = RGBColor(230, 120, 20);
    let figure = Figure::new(
        "the camera's apparent latency against time, with the fitted clock",
        (WIDE, 300),
        (NARROW, 280),
        &|root, layout| {
            let mut chart = linear_axes(root, layout, (x0..x1, y0..y1), (title, "latency (ms)"), (52, 64), tick)?;
            let ends = [(first / scale, line(first)), (last / scale, line(last))];
            chart.draw_series(LineSeries::new(ends, ORANGE.stroke_width(2)))?;
            chart.draw_series(
                points.iter().map(|&(t, v, e)| PathElement::new(vec![(t, v - e), (t, v + e)], BLUE.stroke_width(1))),
            )?;
            chart.draw_series(points.iter().map(|&(t, v, _)| Circle::new((t, v), 3, BLUE.filled())))?;
            Ok(())
        },
    );
    let fitted = match rate.held {
        None => format!(
            "τ = {:.2} ms at time 0, ρ = {:+.2} ppm (a drift of {:+.2} ms over the recording)",
            l.value_s * 1e3,
            rate.value,
            rate.value * 1e-6 * rate.span_s * 1e3
        ),
        Some(_) => format!("{:.2} ms, its rate held at {:+.2} ppm", l.value_s * 1e3, rate.value),
    };
    let keys = vec![
        Key { colour: BLUE, mark: Mark::Dot, label: "apparent latency of a time bin (± 2σ)".into() },
        Key { colour: ORANGE, mark: Mark::Square, label: "the fitted clock: τ + ρ·t".into() },
    ];
    Some(figure.keys(keys).caption(format!(
        "Each dot is the latency the frames of one of {} time bins imply: the fitted latency there plus the step their residuals ask for with everything else held, with ± 2 standard errors. The line is the fitted clock, {fitted}. A camera clock that runs at another rate than the encoders' shows as a slope; dots off the line say the clock model misses something.",
        points.len()
    )))
}

/// The evidence of a failed model check: the residuals against the feature of the structure that
/// explains most (binned means ± 2 standard errors); `None` when the check passed.
pub(crate) fn model_check(c: &Calibration) -> Option<Figure> {
    let check = c.report.model_check.as_ref().filter(|m| !m.passed)?;
    let [x_label, y_label] = check.figure_axes.clone()?;
    let bins = check.figure_bins.clone();
    if bins.is_empty() {
        return None;
    }
    let (x_min, x_max) = bins.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v[0]), b.max(v[0])));
    let pad = ((x_max - x_min) * 0.05).max(1e-9);
    let (y_min, y_max) = bins
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v[1] - 2.0 * v[2]), b.max(v[1] + 2.0 * v[2])));
    let y_pad = ((y_max - y_min) * 0.1).max(1e-9);
    let (y_min, y_max) = (y_min.min(0.0) - y_pad, y_max.max(0.0) + y_pad);
    let figure =
        Figure::new("the residuals against what explains them", (WIDE, 280), (NARROW, 260), &|root, layout| {
            let ranges = ((x_min - pad)..(x_max + pad), y_min..y_max);
            let mut chart = linear_axes(root, layout, ranges, (x_label.as_str(), y_label.as_str()), (52, 64), tick)?;
            chart.draw_series(LineSeries::new([(x_min - pad, 0.0), (x_max + pad, 0.0)], GREY.stroke_width(1)))?;
            chart.draw_series(bins.iter().map(|b| {
                PathElement::new([(b[0], b[1] - 2.0 * b[2]), (b[0], b[1] + 2.0 * b[2])], BLUE.stroke_width(2))
            }))?;
            chart.draw_series(bins.iter().map(|b| Circle::new((b[0], b[1]), 4, BLUE.filled())))?;
            Ok(())
        });
    Some(figure.caption(format!(
        "{}: each dot is the mean residual of a bin of observations, its bar ± 2 standard errors; a model that \
         explains the data keeps them around zero.",
        check.finding.as_deref().unwrap_or("the residuals")
    )))
}
