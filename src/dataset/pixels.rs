//! `pixels.csv`: the markers each camera of a rig saw, pixel by pixel — `pose,marker,camera,u_px,v_px`
//! in a static session (beside `joints.csv`), `time_s,marker,camera,u_px,v_px` in a free-motion
//! recording (beside `encoders.csv`; the rows of one capture share its time) — with the rig in
//! `cameras.yaml` (Kalibr's camchain, `model::camchain`). One row per marker per camera that saw
//! it; a marker no camera saw has no row.
//!
//! Each row is checked as a `markers.csv` row is (finite numbers, a known marker, no repeat of a
//! (pose, marker, camera)), and more: its camera must be one of `cameras.yaml`, and its pixel
//! inside that camera's image. Everything that works on points (the per-pose estimator, compare,
//! replay) sees the points the rig triangulates from the pixels ([`triangulate`]).

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Vector2, Vector3};

use super::markers::{MAX_COORDINATE_M, MarkerLookup};
use crate::io::files::{FileError, number};
use crate::io::table::{Row, Table, first_repeat};
use crate::model::Rig;

/// A marker seen by one camera of a rig (`pixels.csv`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenPixel {
    /// Marker index (as in the session's `markers`).
    pub marker: usize,
    /// Camera index (as in the rig's `cameras`).
    pub camera: usize,
    /// `(u, v)` (px).
    pub pixel: Vector2<f64>,
    /// Line of `pixels.csv` (0 when not read from a file).
    pub line: usize,
}

/// One row of `pixels.csv`: a pixel and when it was seen — `K` is the pose id (`u64`) in a static
/// session, the time on the camera's clock (`f64`, s) in a recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PixelRow<K> {
    /// The pose, or the time of the capture.
    pub(crate) at: K,
    /// What was seen.
    pub(crate) seen: SeenPixel,
}

/// The columns of a static session's `pixels.csv`.
const POSE_COLUMNS: [&str; 5] = ["pose", "marker", "camera", "u_px", "v_px"];
/// The columns of a recording's `pixels.csv`.
const TIME_COLUMNS: [&str; 5] = ["time_s", "marker", "camera", "u_px", "v_px"];

/// Read a static session's `pixels.csv`; every problem is an error naming the line and column.
///
/// # Errors
/// A [`FileError`] at the first bad value, unknown marker or camera, pixel outside its camera's
/// image, or repeated (pose, marker, camera).
pub(crate) fn read_pose_pixels(path: &Path, names: &[String], rig: &Rig) -> Result<Vec<PixelRow<u64>>, FileError> {
    let mut table = Table::open(path, &POSE_COLUMNS)?;
    let (markers, cameras) = (MarkerLookup::new(names), CameraLookup::new(rig));
    let out = table.read_all(|row, _| Ok(PixelRow { at: row.index(0)?, seen: seen(row, &markers, &cameras)? }))?;
    let keys = out.iter().map(|r| ((r.at, r.seen.marker, r.seen.camera), r.seen.line));
    if let Some(((pose, marker, camera), line)) = first_repeat(keys) {
        let reason =
            format!("marker `{}` is seen twice by camera `{}` at pose {pose}", names[marker], cameras.name(camera));
        return Err(table.error_at(line, 2, reason));
    }
    Ok(out)
}

/// Read a recording's `pixels.csv`: as a static session's, with times that never go back.
///
/// # Errors
/// As [`read_pose_pixels`], and a time before the previous row's.
pub(crate) fn read_timed_pixels(path: &Path, names: &[String], rig: &Rig) -> Result<Vec<PixelRow<f64>>, FileError> {
    let mut table = Table::open(path, &TIME_COLUMNS)?;
    let (markers, cameras) = (MarkerLookup::new(names), CameraLookup::new(rig));
    let out = table.read_all(|row, before: &[PixelRow<f64>]| {
        let time_s = row.number(0)?;
        if let Some(last) = before.last().filter(|l| time_s < l.at) {
            return Err(row.error(0, format!("time {time_s} s goes back from the previous row's {} s", last.at)));
        }
        Ok(PixelRow { at: time_s, seen: seen(row, &markers, &cameras)? })
    })?;
    // Time never goes back, so a repeat is within one capture: its time's bits, marker and camera.
    let keys = out.iter().map(|r| ((r.at.to_bits(), r.seen.marker, r.seen.camera), r.seen.line));
    if let Some(((bits, marker, camera), line)) = first_repeat(keys) {
        let time_s = f64::from_bits(bits);
        let reason =
            format!("marker `{}` is seen twice by camera `{}` at {time_s} s", names[marker], cameras.name(camera));
        return Err(table.error_at(line, 2, reason));
    }
    Ok(out)
}

/// The marker, camera and pixel of a row (columns 1 to 4).
fn seen(row: &Row<'_>, markers: &MarkerLookup<'_>, cameras: &CameraLookup<'_>) -> Result<SeenPixel, FileError> {
    let marker = markers.marker(row, 1)?;
    let camera = cameras.camera(row, 2)?;
    let pixel = Vector2::new(row.number(3)?, row.number(4)?);
    if let Some((axis, reason)) = outside_image(cameras.rig, camera, &pixel) {
        return Err(row.error(3 + axis, reason));
    }
    Ok(SeenPixel { marker, camera, pixel, line: row.line })
}

/// Whether `pixel` lies outside camera `camera`'s image — whose pixels' centres run from 0 to
/// width − 1 and height − 1, so that the image spans −0.5 to width − 0.5 — as (0 for `u`, 1 for
/// `v`, why); `None` inside. A pixel outside is no observation of that camera (a row of another
/// camera, a pixel in another image's size).
pub(crate) fn outside_image(rig: &Rig, camera: usize, pixel: &Vector2<f64>) -> Option<(usize, String)> {
    let cam = rig.cameras.get(camera)?;
    let [width, height] = cam.lens.resolution;
    let axis = (0..2)
        .find(|&a| !(pixel[a].is_finite() && (-0.5..=f64::from([width, height][a]) - 0.5).contains(&pixel[a])))?;
    let reason = format!(
        "{} = {} px is outside camera `{}`'s image: its {width} × {height} pixels (cameras.yaml) span u from -0.5 to {} and v from -0.5 to {}",
        ["u", "v"][axis],
        number(pixel[axis]),
        cam.name,
        f64::from(width) - 0.5,
        f64::from(height) - 0.5
    );
    Some((axis, reason))
}

/// The rig's camera names by their bytes: one hash look-up per row, whatever the number of cameras.
struct CameraLookup<'a> {
    rig: &'a Rig,
    index: foldhash::HashMap<&'a [u8], usize>,
}

impl<'a> CameraLookup<'a> {
    fn new(rig: &'a Rig) -> Self {
        let index = rig.cameras.iter().enumerate().map(|(k, c)| (c.name.as_bytes(), k)).collect();
        CameraLookup { rig, index }
    }

    fn name(&self, camera: usize) -> &str {
        self.rig.cameras.get(camera).map_or("?", |c| c.name.as_str())
    }

    /// The `k`-th field of `row` as a camera of the rig; an unknown name is an error naming it and
    /// the rig's cameras (the first few when there are many).
    fn camera(&self, row: &Row<'_>, k: usize) -> Result<usize, FileError> {
        let bytes = row.field(k);
        self.index.get(bytes).copied().ok_or_else(|| {
            const SHOWN: usize = 8;
            let shown = String::from_utf8_lossy(bytes);
            let cameras = &self.rig.cameras;
            let mut listed = cameras.iter().take(SHOWN).map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ");
            if cameras.len() > SHOWN {
                listed += &format!(", … ({} in all)", cameras.len());
            }
            row.error(k, format!("camera `{shown}` is not in cameras.yaml ({listed})"))
        })
    }
}

/// What the rig makes of the pixels of one pose (or one capture of a recording).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Triangulation {
    /// `(marker, point in cam0's frame, line of its first pixel row)` of each marker seen by two
    /// cameras or more whose rays meet, in marker order.
    pub(crate) points: Vec<(usize, Vector3<f64>, usize)>,
    /// The markers seen by two cameras or more whose rays do not meet in front of them (within
    /// `MAX_COORDINATE_M`): `(marker, line of its first pixel row, the cameras)`.
    pub(crate) unmet: Vec<(usize, usize, Vec<usize>)>,
}

/// The points `rig` triangulates from `pixels` ([`Rig::triangulate`]): one per marker that two
/// cameras or more saw; a marker one camera saw gives none (its pixels are data all the same).
/// Linear in the pixels, whatever the number of markers.
pub(crate) fn triangulate(rig: &Rig, pixels: &[SeenPixel]) -> Triangulation {
    let mut order: Vec<usize> = (0..pixels.len()).collect();
    // Stable: within a marker, the rows stay in file order, so the first is its first row.
    order.sort_by_key(|&i| pixels[i].marker);
    let mut out = Triangulation::default();
    for group in order.chunk_by(|&a, &b| pixels[a].marker == pixels[b].marker) {
        if group.len() < 2 {
            continue;
        }
        let first = &pixels[group[0]];
        let rays: Vec<(usize, Vector2<f64>)> = group.iter().map(|&i| (pixels[i].camera, pixels[i].pixel)).collect();
        match rig.triangulate(&rays).filter(|p| p.amax() <= MAX_COORDINATE_M) {
            Some(point) => out.points.push((first.marker, point, first.line)),
            None => out.unmet.push((first.marker, first.line, rays.iter().map(|r| r.0).collect())),
        }
    }
    out
}

/// Why a marker's rays gave no point, for a warning: `marker `m2`: …`.
pub(crate) fn unmet_message(names: &[String], rig: &Rig, marker: usize, cameras: &[usize]) -> String {
    let name = |c: &usize| rig.cameras.get(*c).map_or("?", |c| c.name.as_str());
    let listed = cameras.iter().map(name).collect::<Vec<_>>().join(", ");
    format!(
        "marker `{}`: the rays of its pixels in {listed} do not meet in front of the cameras within {MAX_COORDINATE_M} m: no point is triangulated (its pixels are kept)",
        names.get(marker).map_or("?", String::as_str)
    )
}

/// Whether `rows` (`(pose or time as written, pixel)`) can be written as a `pixels.csv` that reads
/// back: known markers and cameras, finite pixels inside their images; else why, naming the row.
pub(crate) fn check_rows<'a>(
    rows: impl Iterator<Item = (String, &'a SeenPixel)>,
    markers: usize,
    rig: &Rig,
) -> Result<(), String> {
    for (at, p) in rows {
        if p.marker >= markers {
            return Err(format!("{at}: marker {} of a session of {markers} markers", p.marker));
        }
        if p.camera >= rig.cameras.len() {
            return Err(format!("{at}: camera {} of a rig of {} cameras", p.camera, rig.cameras.len()));
        }
        if let Some((_, reason)) = outside_image(rig, p.camera, &p.pixel) {
            return Err(format!("{at}: {reason}"));
        }
    }
    Ok(())
}

/// A static session's `pixels.csv` text, with full precision: `rows` are `(pose, pixel)`.
pub(crate) fn pose_pixels_csv<'a>(
    rows: impl Iterator<Item = (u64, &'a SeenPixel)>,
    names: &[String],
    rig: &Rig,
) -> String {
    let mut text = POSE_COLUMNS.join(",") + "\n";
    for (pose, p) in rows {
        push_row(&mut text, &pose.to_string(), p, names, rig);
    }
    text
}

/// A recording's `pixels.csv` text, with full precision.
pub(crate) fn timed_pixels_csv(rows: &[PixelRow<f64>], names: &[String], rig: &Rig) -> String {
    let mut text = TIME_COLUMNS.join(",") + "\n";
    for r in rows {
        push_row(&mut text, &number(r.at), &r.seen, names, rig);
    }
    text
}

fn push_row(text: &mut String, at: &str, p: &SeenPixel, names: &[String], rig: &Rig) {
    let marker = names.get(p.marker).map_or("?", String::as_str);
    let camera = rig.cameras.get(p.camera).map_or("?", |c| c.name.as_str());
    let _ = writeln!(text, "{at},{marker},{camera},{},{}", number(p.pixel.x), number(p.pixel.y));
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    use super::*;
    use crate::model::{DistortionModel, Lens, RigCamera};

    fn rig() -> Rig {
        let lens = Lens {
            intrinsics: [900.0, 900.0, 640.0, 400.0],
            distortion_model: DistortionModel::Radtan,
            distortion: [-0.1, 0.02, 0.001, -0.001],
            resolution: [1280, 800],
        };
        let second = Isometry3::from_parts(
            Translation3::new(-0.12, 0.0, 0.0),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.0, -0.1, 0.0)),
        );
        let camera = |k: usize, from_previous| RigCamera { name: format!("cam{k}"), lens, from_previous };
        Rig { cameras: vec![camera(0, Isometry3::identity()), camera(1, second)] }
    }

    fn seen(marker: usize, camera: usize, pixel: Vector2<f64>, line: usize) -> SeenPixel {
        SeenPixel { marker, camera, pixel, line }
    }

    #[test]
    fn markers_seen_twice_are_triangulated_once_seen_are_not_and_rays_apart_are_said() {
        let rig = rig();
        let (a, b) = (Vector3::new(0.05, -0.02, 0.6), Vector3::new(-0.03, 0.04, 0.7));
        let at = |c: usize, y: &Vector3<f64>| rig.project(c, y).unwrap().lens.pixel;
        let pixels = [
            seen(2, 1, at(1, &a), 5),
            seen(0, 0, at(0, &b), 6),
            seen(2, 0, at(0, &a), 7),
            // Marker 1: both cameras, but looking apart (cam0 left of itself, cam1 right of itself):
            // the rays' nearest approach lies behind them.
            seen(1, 0, at(0, &Vector3::new(-0.2, 0.0, 0.5)), 8),
            seen(1, 1, at(1, &Vector3::new(0.4, 0.0, 0.5)), 9),
        ];
        let t = triangulate(&rig, &pixels);
        assert_eq!(t.points.len(), 1, "{t:?}");
        let (marker, point, line) = t.points[0];
        assert_eq!((marker, line), (2, 5));
        assert!((point - a).norm() < 1e-10, "{}", (point - a).norm());
        assert_eq!(t.unmet, vec![(1, 8, vec![0, 1])]);
        let message = unmet_message(&["m1".into(), "m2".into(), "m3".into()], &rig, 1, &[0, 1]);
        assert!(message.starts_with("marker `m2`: the rays of its pixels in cam0, cam1 do not meet"), "{message}");
    }

    #[test]
    fn a_pixel_outside_its_image_is_named_by_its_axis_and_the_image() {
        let rig = rig();
        assert_eq!(outside_image(&rig, 0, &Vector2::new(-0.5, 799.5)), None);
        let (axis, reason) = outside_image(&rig, 1, &Vector2::new(10.0, 799.6)).unwrap();
        assert_eq!(axis, 1);
        assert!(reason.contains("v = 799.6 px is outside camera `cam1`'s image: its 1280 × 800 pixels"), "{reason}");
        assert_eq!(outside_image(&rig, 0, &Vector2::new(f64::NAN, 1.0)).map(|o| o.0), Some(0));
    }
}
