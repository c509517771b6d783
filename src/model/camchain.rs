//! Kalibr's camchain (`cameras.yaml`): a camera rig as the camera calibration that measured it
//! writes it, read into a [`Rig`] and written back from one.
//!
//! ```yaml
//! cam0:
//!   camera_model: pinhole
//!   intrinsics: [fu, fv, pu, pv]          # px
//!   distortion_model: radtan              # or equidistant; Kalibr's `none` reads as radtan, zeros
//!   distortion_coeffs: [k1, k2, r1, r2]
//!   resolution: [1280, 800]
//! cam1:
//!   T_cn_cnm1:                            # cam0 coordinates -> cam1 coordinates (m)
//!   - [r11, r12, r13, t1]
//!   - [r21, r22, r23, t2]
//!   - [r31, r32, r33, t3]
//!   - [0.0, 0.0, 0.0, 1.0]
//!   camera_model: pinhole
//!   …
//! ```
//!
//! Cameras are `cam0`, `cam1`, … without gaps, in any order in the file (Kalibr's writer sorts
//! keys, so `cam10` comes before `cam2`); each camera after the first is given relative to the
//! one before it. Kalibr's other keys (`rostopic`, `cam_overlaps`, `line_delay`, `T_cam_imu`,
//! `timeshift_cam_imu`) are accepted and ignored; any other key is an error naming it, so a typo
//! is never silently ignored. Every error names the file and the line of the value it is about
//! (a missing key: the line of its camera).
//!
//! Numbers are written as the shortest text that reads back to the same `f64`, always with a
//! decimal point and a signed exponent (`7.3e-7` stays, `1e-7` is written `1.0e-7`): YAML
//! 1.1 readers such as PyYAML, which Kalibr uses, read `1e-7` as a string.
//!
//! A rotation's matrix holds it only to rounding, and several nearby unit quaternions give the
//! same matrix, so no reader can recover an arbitrary quaternion from it bit for bit. The reader
//! therefore returns each rotation in a canonical form ([`canonical_rotation`]): the nearest
//! rotation's quaternion with three of its components on a grid of 2⁻⁴⁰ (a picoradian) and the
//! largest one made positive and recomputed from them. Writing such a rotation and reading it
//! back gives it bit for bit, so a rig read from a file — or passed through [`as_written`] —
//! survives any number of write → read round trips unchanged.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Matrix4, Quaternion, Translation3, UnitQuaternion, Vector3, Vector4};
use serde_yaml::{Mapping, Value};

use super::limits::MAX_POSITION_M;
use super::rig::{DistortionModel, Lens, Rig, RigCamera};
use crate::io::files::{FileError, number, write_atomic};
use crate::io::yaml::KeyLines;
use crate::math::so3::nearest_rotation;

/// Kalibr's keys of a camera that spmcal does not use: accepted and ignored.
const IGNORED_KEYS: [&str; 5] = ["rostopic", "cam_overlaps", "line_delay", "T_cam_imu", "timeshift_cam_imu"];

/// The keys spmcal reads, in the order it writes them.
const KEYS: [&str; 6] =
    ["T_cn_cnm1", "camera_model", "intrinsics", "distortion_model", "distortion_coeffs", "resolution"];

/// How far `T_cn_cnm1`'s rotation may depart from a rotation (`RᵀR` from the identity, `det R`
/// from 1) and its last row from `0 0 0 1`: a matrix written to full precision departs by about
/// 1e-15, one written with seven decimals by up to about 2e-7 (six: 2e-6).
pub(crate) const ROTATION_TOLERANCE: f64 = 1e-6;

/// Shortest first baseline accepted (m): two cameras at one place see no depth, and the first
/// baseline is the rig's metric scale.
pub(crate) const MIN_BASELINE_M: f64 = 1e-3;

/// The grid (2⁻⁴⁰) of a canonical rotation's quaternion components: far coarser than the
/// rounding of a written matrix (about 1e-16), far finer than any rig is known (1e-12 rad is a
/// picometre at a metre).
const GRID: f64 = 1.0 / (1u64 << 40) as f64;

/// Read a camchain file.
///
/// # Errors
/// A [`FileError`] naming the file, the line and the key of the first problem.
pub(crate) fn read_camchain(path: &Path) -> Result<Rig, FileError> {
    let (top, keys) = crate::io::yaml::read::<Value>(path)?;
    let file = File { path, keys: &keys };
    let top = match top {
        Value::Mapping(m) => m,
        Value::Null => Mapping::new(),
        _ => return Err(file.error("", "a camchain is a mapping of cameras `cam0`, `cam1`, … (Kalibr's layout)")),
    };
    let cameras = file.cameras(&top)?;
    let mut rig = Rig { cameras: Vec::with_capacity(cameras.len()) };
    for (k, camera) in cameras.iter().enumerate() {
        rig.cameras.push(file.camera(k, camera)?);
    }
    Ok(rig)
}

/// The camchain text of `rig`: cameras `cam0`, `cam1`, … in the rig's order (whatever their
/// names; [`write_camchain`] refuses a rig whose names are not these), each number as the
/// shortest text that reads back to it.
pub(crate) fn camchain_yaml(rig: &Rig) -> String {
    let mut out = String::from(
        "# A camera rig in Kalibr's camchain format, written by spmcal. cam0's frame is the camera frame C\n\
         # (x right, y down, z along the optical axis); each later camera's T_cn_cnm1 maps the previous\n\
         # camera's coordinates to its own (metres). Intrinsics [fu, fv, pu, pv] in pixels, the top-left\n\
         # pixel's centre at (0, 0).\n",
    );
    for (k, camera) in rig.cameras.iter().enumerate() {
        let _ = writeln!(out, "cam{k}:");
        if k > 0 {
            out.push_str("  T_cn_cnm1:\n");
            let m = camera.from_previous.to_homogeneous();
            for r in 0..4 {
                let _ = writeln!(out, "  - {}", flow(&[m[(r, 0)], m[(r, 1)], m[(r, 2)], m[(r, 3)]]));
            }
        }
        let lens = &camera.lens;
        out.push_str("  camera_model: pinhole\n");
        let _ = writeln!(out, "  intrinsics: {}", flow(&lens.intrinsics));
        let _ = writeln!(out, "  distortion_model: {}", lens.distortion_model.name());
        let _ = writeln!(out, "  distortion_coeffs: {}", flow(&lens.distortion));
        let _ = writeln!(out, "  resolution: [{}, {}]", lens.resolution[0], lens.resolution[1]);
    }
    out
}

/// Write `rig` as a camchain file, atomically.
///
/// # Errors
/// A [`FileError`] when the rig has no camera, a camera is not named `cam<k>` by its place (the
/// pixels of a session name cameras as the camchain does), the first camera is not the frame
/// itself (its pose is the identity), or the file cannot be written.
pub(crate) fn write_camchain(path: &Path, rig: &Rig) -> Result<(), FileError> {
    check_writable(rig).map_err(|reason| FileError::new(path, format!("{reason}; not written")))?;
    write_atomic(path, camchain_yaml(rig).as_bytes())
}

/// Why `rig` cannot be written as a camchain that reads back as itself, if it cannot.
pub(crate) fn check_writable(rig: &Rig) -> Result<(), String> {
    if rig.cameras.is_empty() {
        return Err("the rig has no camera".into());
    }
    if let Some((k, camera)) = rig.cameras.iter().enumerate().find(|(k, c)| c.name != format!("cam{k}")) {
        return Err(format!(
            "camera {k} of the rig is named `{}`: a camchain names its cameras by their place, `cam{k}`",
            camera.name
        ));
    }
    if rig.cameras[0].from_previous != Isometry3::identity() {
        return Err("cam0's pose is not the identity: cam0 is the camera frame itself".into());
    }
    Ok(())
}

/// `rig` exactly as a camchain file holds it: each rotation in its canonical form (the rest of a
/// rig is written exactly). A rig made in memory (the simulator's) and compared with one read
/// back goes through this first.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn as_written(rig: &Rig) -> Rig {
    let mut out = rig.clone();
    for camera in out.cameras.iter_mut().skip(1) {
        let matrix = *camera.from_previous.rotation.to_rotation_matrix().matrix();
        if let Some(rotation) = canonical_rotation(&matrix) {
            camera.from_previous.rotation = rotation;
        }
    }
    out
}

/// The rotation nearest to `m` in canonical form: its unit quaternion's largest component (the
/// first of those within 1e-9 of the largest) positive and recomputed from the other three,
/// which are rounded to multiples of [`GRID`]. A written and re-read canonical rotation comes
/// back bit for bit: the matrix it is written as gives its components again to about 1e-16,
/// which round back onto the same grid points. `None` when `m` has no nearest rotation.
pub(crate) fn canonical_rotation(m: &Matrix3<f64>) -> Option<UnitQuaternion<f64>> {
    let rotation = nearest_rotation(m)?;
    let q = UnitQuaternion::from_rotation_matrix(&rotation).into_inner().normalize();
    let c = q.coords;
    let largest = c.amax();
    let d = (0..4).find(|&k| c[k].abs() >= largest - 1e-9)?;
    let sign = c[d].signum();
    let mut out = Vector4::zeros();
    for k in (0..4).filter(|&k| k != d) {
        out[k] = (sign * c[k] / GRID).round() * GRID;
    }
    let rest: f64 = (0..4).filter(|&k| k != d).map(|k| out[k] * out[k]).sum();
    out[d] = (1.0 - rest).max(0.0).sqrt();
    Some(UnitQuaternion::new_unchecked(Quaternion::from(out)))
}

/// `[a, b, c]` with each number as [`yaml_number`] writes it.
fn flow(values: &[f64]) -> String {
    format!("[{}]", values.iter().map(|&x| yaml_number(x)).collect::<Vec<_>>().join(", "))
}

/// The shortest text that reads back to `x`, with a decimal point and a signed exponent when it
/// has one (`1e-7` → `1.0e-7`, `1.5e22` → `1.5e+22`), which YAML 1.1 readers need to see a float.
fn yaml_number(x: f64) -> String {
    let text = number(x);
    match text.split_once('e') {
        Some((mantissa, exponent)) => {
            let point = if mantissa.contains('.') { "" } else { ".0" };
            let sign = if exponent.starts_with('-') { "" } else { "+" };
            format!("{mantissa}{point}e{sign}{exponent}")
        }
        None => text,
    }
}

/// A camchain being read: its path and the lines of its keys.
struct File<'a> {
    path: &'a Path,
    keys: &'a KeyLines,
}

impl File<'_> {
    /// An error about the value at `key` (`cam1.intrinsics[2]`), at its line or its nearest
    /// enclosing key's.
    fn error(&self, key: &str, reason: impl Into<String>) -> FileError {
        if key.is_empty() {
            return FileError::new(self.path, reason).at_line(1);
        }
        self.keys.error(self.path, key, reason)
    }

    /// The cameras' mappings in order `cam0`, `cam1`, …; any other key, a gap or no camera is an
    /// error.
    fn cameras<'m>(&self, top: &'m Mapping) -> Result<Vec<(String, &'m Mapping)>, FileError> {
        let mut numbered: Vec<(usize, String, &Mapping)> = Vec::with_capacity(top.len());
        for (key, value) in top {
            let name = key_name(key);
            let number = name.strip_prefix("cam").and_then(|n| n.parse::<usize>().ok());
            let Some(n) = number.filter(|n| format!("cam{n}") == name) else {
                return Err(self.error(
                    &name,
                    format!("unknown key `{name}`: a camchain holds cameras `cam0`, `cam1`, … (Kalibr's layout)"),
                ));
            };
            let Value::Mapping(camera) = value else {
                let reason = format!("`{name}` must be a mapping of its keys ({}, …)", KEYS[1..].join(", "));
                return Err(self.error(&name, reason));
            };
            numbered.push((n, name, camera));
        }
        numbered.sort_by_key(|(n, ..)| *n);
        if numbered.is_empty() {
            return Err(self.error("", "no cameras: a camchain lists its cameras `cam0`, `cam1`, …"));
        }
        if let Some((k, (_, name, _))) = numbered.iter().enumerate().find(|(k, (n, ..))| n != k) {
            let reason = format!(
                "`{name}` without `cam{k}`: the cameras are numbered cam0, cam1, … without a gap (each after the first is given relative to the one before it)"
            );
            return Err(self.error(name, reason));
        }
        Ok(numbered.into_iter().map(|(_, name, camera)| (name, camera)).collect())
    }

    /// Camera `k`, every key checked.
    fn camera(&self, k: usize, (name, m): &(String, &Mapping)) -> Result<RigCamera, FileError> {
        for key in m.keys().map(key_name) {
            if !KEYS.contains(&key.as_str()) && !IGNORED_KEYS.contains(&key.as_str()) {
                let reason = format!(
                    "unknown key `{key}` in `{name}`: a camera has {} (and Kalibr's {}, which are ignored)",
                    KEYS.join(", "),
                    IGNORED_KEYS.join(", ")
                );
                return Err(self.error(&format!("{name}.{key}"), reason));
            }
        }
        let at = |key: &str| format!("{name}.{key}");
        let model = self.text(m, name, "camera_model")?;
        if model != "pinhole" {
            let reason = format!(
                "`{name}`: camera model `{model}` is not one spmcal reads: `pinhole` (with `radtan`, `equidistant` or `none` distortion)"
            );
            return Err(self.error(&at("camera_model"), reason));
        }
        let intrinsics = self.numbers::<4>(m, name, "intrinsics", "[fu, fv, pu, pv] in pixels")?;
        if let Some(i) = (0..2).find(|&i| intrinsics[i] <= 0.0) {
            let reason = format!("`{name}`: focal length {} = {} px must be positive", ["fu", "fv"][i], intrinsics[i]);
            return Err(self.error(&format!("{}[{i}]", at("intrinsics")), reason));
        }
        let (distortion_model, distortion) = self.distortion(m, name)?;
        let resolution = self.resolution(m, name)?;
        let from_previous = self.pose(m, k, name)?;
        let lens = Lens { intrinsics, distortion_model, distortion, resolution };
        if let Some((angle, share)) = lens.radial_fold() {
            let reason = format!(
                "`{name}`: these {} coefficients {:?} fold the image back on itself: its distorted radius stops growing {angle:.1}° off the axis, {:.0} % of the way to the image's farthest corner, which no lens does (a sign or the order [{}] wrong?)",
                distortion_model.name(),
                distortion,
                100.0 * share,
                distortion_model.coefficient_names().join(", ")
            );
            return Err(self.error(&at("distortion_coeffs"), reason));
        }
        Ok(RigCamera { name: name.clone(), lens, from_previous })
    }

    /// The value of `key` in camera `name`'s mapping, or an error at the camera's line.
    fn get<'m>(&self, m: &'m Mapping, name: &str, key: &str, what: &str) -> Result<&'m Value, FileError> {
        m.get(key).ok_or_else(|| self.error(&format!("{name}.{key}"), format!("`{name}` has no `{key}` ({what})")))
    }

    /// A string value.
    fn text<'m>(&self, m: &'m Mapping, name: &str, key: &str) -> Result<&'m str, FileError> {
        let value = self.get(m, name, key, "`pinhole`")?;
        value.as_str().ok_or_else(|| self.error(&format!("{name}.{key}"), format!("`{name}.{key}` must be a name")))
    }

    /// `N` finite numbers at `key` (`what` says which).
    fn numbers<const N: usize>(&self, m: &Mapping, name: &str, key: &str, what: &str) -> Result<[f64; N], FileError> {
        let at = format!("{name}.{key}");
        self.list(self.get(m, name, key, what)?, &at, what)
    }

    /// `N` finite numbers in the list `value` at key path `at`.
    fn list<const N: usize>(&self, value: &Value, at: &str, what: &str) -> Result<[f64; N], FileError> {
        let items = match value {
            Value::Sequence(items) if items.len() == N => items,
            Value::Sequence(items) => {
                let reason = format!("`{at}` has {} numbers; it must have {N}: {what}", items.len());
                return Err(self.error(at, reason));
            }
            _ => return Err(self.error(at, format!("`{at}` must be a list of {N} numbers: {what}"))),
        };
        let mut out = [0.0; N];
        for (i, item) in items.iter().enumerate() {
            out[i] = item.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                self.error(&format!("{at}[{i}]"), format!("`{at}[{i}]` is {}, not a finite number", shown(item)))
            })?;
        }
        Ok(out)
    }

    /// The distortion model and its four coefficients; Kalibr's `none` (no coefficients, or four
    /// zeros) is `radtan` with zeros.
    fn distortion(&self, m: &Mapping, name: &str) -> Result<(DistortionModel, [f64; 4]), FileError> {
        let key = "distortion_model";
        let value = self.get(m, name, key, "`radtan`, `equidistant` or `none`")?;
        let model = match value.as_str() {
            Some("radtan") => Some(DistortionModel::Radtan),
            Some("equidistant") => Some(DistortionModel::Equidistant),
            Some("none") => None,
            _ => {
                let reason = format!(
                    "`{name}`: distortion model {} is not one spmcal reads: `radtan`, `equidistant` or `none` (Kalibr's names)",
                    shown(value)
                );
                return Err(self.error(&format!("{name}.{key}"), reason));
            }
        };
        let coefficients = "distortion_coeffs";
        match model {
            Some(model) => {
                let what = format!("[{}]", model.coefficient_names().join(", "));
                Ok((model, self.numbers::<4>(m, name, coefficients, &what)?))
            }
            None => {
                let at = format!("{name}.{coefficients}");
                let zeros = match m.get(coefficients) {
                    None => true,
                    Some(Value::Sequence(items)) if items.is_empty() => true,
                    Some(value) => self.list::<4>(value, &at, "none, or four zeros")? == [0.0; 4],
                };
                if !zeros {
                    let reason =
                        format!("`{name}`: distortion model `none` has no coefficients, but these are not zero");
                    return Err(self.error(&at, reason));
                }
                Ok((DistortionModel::Radtan, [0.0; 4]))
            }
        }
    }

    /// `[width, height]`: two positive integers.
    fn resolution(&self, m: &Mapping, name: &str) -> Result<[u32; 2], FileError> {
        let key = "resolution";
        let at = format!("{name}.{key}");
        let value = self.get(m, name, key, "[width, height] in pixels")?;
        let items = match value {
            Value::Sequence(items) if items.len() == 2 => items,
            _ => return Err(self.error(&at, format!("`{at}` must be [width, height]: two positive integers (px)"))),
        };
        let mut out = [0u32; 2];
        for (i, item) in items.iter().enumerate() {
            out[i] = item.as_u64().and_then(|n| u32::try_from(n).ok()).filter(|&n| n > 0).ok_or_else(|| {
                let reason = format!("`{at}[{i}]` is {}, not a positive integer (px)", shown(item));
                self.error(&format!("{at}[{i}]"), reason)
            })?;
        }
        Ok(out)
    }

    /// Camera `k`'s pose relative to the previous one (`T_cn_cnm1`), the identity for cam0.
    fn pose(&self, m: &Mapping, k: usize, name: &str) -> Result<Isometry3<f64>, FileError> {
        let key = "T_cn_cnm1";
        let at = format!("{name}.{key}");
        if k == 0 {
            if m.contains_key(key) {
                let reason = "`cam0` has a `T_cn_cnm1`: cam0 is the rig's frame, and each later camera is given relative to the one before it";
                return Err(self.error(&at, reason));
            }
            return Ok(Isometry3::identity());
        }
        let what = "the previous camera's coordinates to this one's, a 4×4 matrix of 4 rows";
        let rows = match self.get(m, name, key, what)? {
            Value::Sequence(rows) if rows.len() == 4 => rows,
            _ => return Err(self.error(&at, format!("`{at}` must be 4 rows of 4 numbers: {what}"))),
        };
        let mut t = Matrix4::zeros();
        for (r, row) in rows.iter().enumerate() {
            let values = self.list::<4>(row, &format!("{at}[{r}]"), "a row of a 4×4 matrix")?;
            t.row_mut(r).copy_from_slice(&values);
        }
        let last = [t[(3, 0)], t[(3, 1)], t[(3, 2)], t[(3, 3)]];
        if (Vector4::from(last) - Vector4::w()).amax() > ROTATION_TOLERANCE {
            let reason =
                format!("`{name}`: the last row of `T_cn_cnm1` is {last:?}; a rigid transform's is [0, 0, 0, 1]");
            return Err(self.error(&format!("{at}[3]"), reason));
        }
        let rotation = self.rotation(&t.fixed_view::<3, 3>(0, 0).into_owned(), name, &at)?;
        let translation = Vector3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]);
        self.translation(&translation, k, name, &at)?;
        Ok(Isometry3::from_parts(Translation3::from(translation), rotation))
    }

    /// The rotation part of `T_cn_cnm1`, checked to be one, in canonical form.
    fn rotation(&self, r: &Matrix3<f64>, name: &str, at: &str) -> Result<UnitQuaternion<f64>, FileError> {
        let det = r.determinant();
        let departure = (r.transpose() * r - Matrix3::identity()).amax();
        let not_a_rotation =
            |why: String| self.error(at, format!("`{name}`: the rotation of `T_cn_cnm1` is not a rotation: {why}"));
        if det < 0.0 {
            return Err(not_a_rotation(format!("its determinant is {det:.6}, a reflection")));
        }
        if departure > ROTATION_TOLERANCE || (det - 1.0).abs() > ROTATION_TOLERANCE {
            return Err(not_a_rotation(format!(
                "RᵀR departs from the identity by {departure:.2e} and det R is {det:.9} (at most {ROTATION_TOLERANCE:e} for a rotation)"
            )));
        }
        canonical_rotation(r).ok_or_else(|| not_a_rotation("it has no nearest rotation".into()))
    }

    /// A camera's translation: within [`MAX_POSITION_M`]; the first baseline at least
    /// [`MIN_BASELINE_M`].
    fn translation(&self, t: &Vector3<f64>, k: usize, name: &str, at: &str) -> Result<(), FileError> {
        let length = t.norm();
        if length > MAX_POSITION_M {
            let reason = format!(
                "`{name}` stands {length} m from the previous camera; translations are metres, at most {MAX_POSITION_M} m (millimetres written as metres?)"
            );
            return Err(self.error(at, reason));
        }
        if k == 1 && length < MIN_BASELINE_M {
            let reason = format!(
                "`{name}` stands {:.3} mm from cam0: a stereo rig's cameras stand apart (its first baseline, at least {} mm, is its metric scale)",
                length * 1e3,
                MIN_BASELINE_M * 1e3
            );
            return Err(self.error(at, reason));
        }
        Ok(())
    }
}

/// A mapping key as text (a number or other scalar as YAML writes it).
fn key_name(key: &Value) -> String {
    match key {
        Value::String(s) => s.clone(),
        other => shown(other),
    }
}

/// A value as a message shows it: a scalar as written, anything else by its kind.
fn shown(value: &Value) -> String {
    match value {
        Value::Null => "empty".into(),
        Value::Bool(b) => format!("`{b}`"),
        Value::Number(n) => format!("`{n}`"),
        Value::String(s) => format!("`{s}`"),
        Value::Sequence(_) => "a list".into(),
        Value::Mapping(_) => "a mapping".into(),
        Value::Tagged(t) => format!("a value tagged `{}`", t.tag),
    }
}

impl Rig {
    /// Read a rig from a Kalibr camchain (`cameras.yaml`, or what `calibrate --cameras-out`
    /// wrote).
    ///
    /// # Errors
    /// A [`FileError`] naming the file, line and reason for an unreadable or malformed camchain.
    pub fn read(path: &Path) -> Result<Rig, FileError> {
        read_camchain(path)
    }

    /// The rig as a Kalibr camchain (`cameras.yaml`): what `spmcal calibrate --cameras-out`
    /// writes for a pixel session's refined rig.
    pub fn to_camchain(&self) -> String {
        camchain_yaml(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> Rig {
        let lens = |model, distortion| Lens {
            intrinsics: [912.3456789, 910.25, 641.5, 399.75],
            distortion_model: model,
            distortion,
            resolution: [1280, 800],
        };
        let second = Isometry3::from_parts(
            Translation3::new(-0.12, 0.000_731, -0.002_2),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.004, -0.087, 0.0013)),
        );
        let third = Isometry3::from_parts(
            Translation3::new(0.05, -0.3, 1e-7),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, std::f64::consts::PI)),
        );
        Rig {
            cameras: vec![
                RigCamera {
                    name: "cam0".into(),
                    lens: lens(DistortionModel::Radtan, [-0.28, 0.07, 7.3e-5, -1e-7]),
                    from_previous: Isometry3::identity(),
                },
                RigCamera {
                    name: "cam1".into(),
                    lens: lens(DistortionModel::Radtan, [0.01, -1.5e-22, 0.0, -0.0]),
                    from_previous: second,
                },
                RigCamera {
                    name: "cam2".into(),
                    lens: lens(DistortionModel::Equidistant, [0.02, -0.01, 0.003, -0.001]),
                    from_previous: third,
                },
            ],
        }
    }

    fn read_text(text: &str) -> Result<Rig, FileError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cameras.yaml");
        std::fs::write(&path, text).unwrap();
        read_camchain(&path)
    }

    #[test]
    fn a_written_rig_reads_back_bit_for_bit_once_canonical() {
        let rig = rig();
        let read = read_text(&camchain_yaml(&rig)).unwrap();
        // Everything but the rotations is written exactly; each rotation comes back canonical,
        // within a grid step (2⁻⁴⁰ ≈ 9e-13) of the rig's.
        assert_eq!(read, as_written(&rig));
        for (a, b) in read.cameras.iter().zip(&rig.cameras) {
            assert_eq!((a.lens, a.from_previous.translation), (b.lens, b.from_previous.translation));
            assert!(a.from_previous.rotation.angle_to(&b.from_previous.rotation) < 2e-12);
        }
        // And from there on, bit for bit, the text too.
        let text = camchain_yaml(&read);
        let again = read_text(&text).unwrap();
        assert_eq!(again, read);
        assert_eq!(camchain_yaml(&again), text);
    }

    #[test]
    fn canonical_rotations_are_fixed_points_of_writing_and_reading() {
        let mut seed = 7u64;
        let mut draw = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let half = std::f64::consts::FRAC_PI_2;
        // Rotations whose quaternions tie in their largest components, and random ones.
        let mut axes = vec![
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, half),
            Vector3::new(0.0, 0.0, std::f64::consts::PI),
            Vector3::new(1.0, 1.0, 1.0).normalize() * (2.0 * std::f64::consts::FRAC_PI_3),
        ];
        axes.extend((0..20_000).map(|i| Vector3::new(draw(), draw(), draw()) * if i % 2 == 0 { 0.2 } else { 3.1 }));
        for axis in axes {
            let matrix = *UnitQuaternion::from_scaled_axis(axis).to_rotation_matrix().matrix();
            let q = canonical_rotation(&matrix).unwrap();
            assert!((q.coords.norm() - 1.0).abs() < 1e-15);
            let written = q.to_rotation_matrix().matrix().map(|x| yaml_number(x).parse::<f64>().unwrap());
            assert_eq!(canonical_rotation(&written).unwrap(), q, "{axis}");
        }
    }

    #[test]
    fn numbers_are_floats_to_yaml_one_one_and_exact() {
        for (x, text) in [
            (1e-7, "1.0e-7"),
            (7.3e-5, "0.000073"),
            (7.3e-7, "7.3e-7"),
            (1.5e22, "1.5e+22"),
            (0.1, "0.1"),
            (900.0, "900.0"),
        ] {
            assert_eq!(yaml_number(x), text);
            assert_eq!(text.parse::<f64>().unwrap(), x);
        }
    }

    const GOOD: &str = "cam0:\n  camera_model: pinhole\n  intrinsics: [900, 900.5, 640.0, 400.0]\n  distortion_model: none\n  distortion_coeffs: []\n  resolution: [1280, 800]\n  rostopic: /cam0/image_raw\n  cam_overlaps: [1]\ncam1:\n  T_cn_cnm1:\n  - [1.0, 0.0, 0.0, -0.12]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n  camera_model: pinhole\n  intrinsics: [900.0, 900.0, 640.0, 400.0]\n  distortion_model: equidistant\n  distortion_coeffs: [0.1, 0.0, 0.0, 0.0]\n  resolution: [1280, 800]\n  line_delay: 0.0\n";

    #[test]
    fn kalibrs_none_reads_as_radtan_with_zeros_and_its_other_keys_are_ignored() {
        let rig = read_text(GOOD).unwrap();
        assert_eq!(rig.cameras[0].lens.distortion_model, DistortionModel::Radtan);
        assert_eq!(rig.cameras[0].lens.distortion, [0.0; 4]);
        assert_eq!(rig.cameras[0].lens.intrinsics, [900.0, 900.5, 640.0, 400.0]);
        assert_eq!(rig.cameras[1].lens.distortion_model, DistortionModel::Equidistant);
        assert_eq!(rig.baseline_m(), 0.12);
        // Cameras in any order of the file (Kalibr sorts keys: cam10 before cam2).
        let (first, second) = GOOD.split_at(GOOD.find("cam1:").unwrap());
        assert_eq!(read_text(&format!("{second}{first}")).unwrap(), rig);
    }

    fn error(text: &str) -> (Option<usize>, String) {
        let e = read_text(text).unwrap_err();
        (e.line, e.to_string())
    }

    #[test]
    fn every_refusal_names_the_line_and_why() {
        let cases: [(&str, &str, usize, &str); 10] = [
            ("  intrinsics: [900.0, 900.0, 640.0, 400.0]\n", "", 9, "`cam1` has no `intrinsics`"),
            ("  - [0.0, 1.0, 0.0, 0.0]\n", "  - [0.0, 1.0, 0.1, 0.0]\n", 10, "is not a rotation: RᵀR departs"),
            (
                "  - [0.0, 0.0, 1.0, 0.0]\n",
                "  - [0.0, 0.0, -1.0, 0.0]\n",
                10,
                "its determinant is -1.000000, a reflection",
            ),
            ("  line_delay: 0.0\n", "  line_dealy: 0.0\n", 20, "unknown key `line_dealy` in `cam1`"),
            ("distortion_model: equidistant", "distortion_model: fov", 17, "distortion model `fov` is not one"),
            ("cam1:", "camera1:", 9, "unknown key `camera1`"),
            ("cam1:", "cam2:", 9, "`cam2` without `cam1`"),
            (
                "[1280, 800]\n  line",
                "[1280.0, 800]\n  line",
                19,
                "`cam1.resolution[0]` is `1280.0`, not a positive integer",
            ),
            ("intrinsics: [900, 900.5", "intrinsics: [-900, 900.5", 3, "focal length fu = -900 px must be positive"),
            (
                "  camera_model: pinhole\n  intrinsics: [900.0",
                "  camera_model: omni\n  intrinsics: [900.0",
                15,
                "camera model `omni`",
            ),
        ];
        for (old, new, line, reason) in cases {
            assert!(GOOD.contains(old), "{old}");
            let (at, message) = error(&GOOD.replacen(old, new, 1));
            assert_eq!(at, Some(line), "{message}");
            assert!(message.contains("cameras.yaml") && message.contains(reason), "{message}");
        }
        let (at, message) = error("cam0:\n  camera_model: pinhole\n  intrinsics: [1.0, .nan, 2, 3]\n");
        assert_eq!(at, Some(3));
        assert!(message.contains("`cam0.intrinsics[1]` is `.nan`, not a finite number"), "{message}");
        // Kalibr's `none` has no coefficients; cam0 is the frame, with no pose of its own.
        let (at, message) = error(&GOOD.replace("distortion_coeffs: []", "distortion_coeffs: [0.1, 0.0, 0.0, 0.0]"));
        assert_eq!(at, Some(5));
        assert!(message.contains("distortion model `none` has no coefficients, but these are not zero"), "{message}");
        let pose = "  T_cn_cnm1:\n  - [1.0, 0.0, 0.0, 0.1]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n";
        let (at, message) = error(&GOOD.replacen("cam0:\n", &format!("cam0:\n{pose}"), 1));
        assert_eq!(at, Some(2));
        assert!(message.contains("`cam0` has a `T_cn_cnm1`: cam0 is the rig's frame"), "{message}");
        // Coefficients that fold the image: θ(1 - 5θ²) stops growing at θ = 1/√15 (14.8°).
        let (at, message) =
            error(&GOOD.replace("distortion_coeffs: [0.1, 0.0, 0.0, 0.0]", "distortion_coeffs: [-5.0, 0.0, 0.0, 0.0]"));
        assert_eq!(at, Some(18), "{message}");
        assert!(
            message.contains("`cam1`: these equidistant coefficients [-5.0, 0.0, 0.0, 0.0] fold the image back on itself: its distorted radius stops growing 14.8° off the axis"),
            "{message}"
        );
        let (at, message) = error("# nothing\n");
        assert_eq!(at, Some(1));
        assert!(message.contains("no cameras"), "{message}");
    }

    #[test]
    fn a_rig_named_otherwise_is_not_written() {
        let mut rig = rig();
        rig.cameras[1].name = "right".into();
        let dir = tempfile::tempdir().unwrap();
        let e = write_camchain(&dir.path().join("cameras.yaml"), &rig).unwrap_err();
        assert!(e.reason.contains("camera 1 of the rig is named `right`"), "{e}");
        assert!(!dir.path().join("cameras.yaml").exists());
    }
}
