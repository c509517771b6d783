//! A simulated camera rig seen through its pixels (`camera.rig` of a simulation config): the true
//! rig that images the markers, the miscalibrated rig its `cameras.yaml` states — off the way a
//! lab's calibration is (a baseline a little long, focal lengths and principal points a little
//! off, the second camera turned a little, a residual distortion left out) — and the pixel noise.
//!
//! Camera `cam0`'s frame is the simulator's camera frame C; every camera after it is placed
//! relative to the previous one as a person describes a rig: its centre `baseline_m` along the
//! previous camera's x axis (to its right), turned `toe_in_deg` about its y axis towards the
//! previous camera, then by `rotation_deg` (a rotation vector in its own frame).

use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::math::so3;
use crate::model::camchain::as_written;
use crate::model::{DistortionModel, Lens, Rig, RigCamera};

/// The most cameras a simulated rig may have.
const MAX_CAMERAS: usize = 16;

/// The stereo rig a simulation sees the markers through (`camera.rig`): with it a session carries
/// each camera's pixels (`pixels.csv`) and the rig its file states (`cameras.yaml`), and the
/// stereo noise settings of `camera` (`lateral_sigma_m`, `depth_sigma_m`, `outlier_sigma_m`,
/// `baseline_m`) do not apply.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigSettings {
    /// The true cameras, `cam0` first (default: two 1280 × 800 cameras, f ≈ 900 px, 0.12 m
    /// apart, a residual radial distortion k1 = 0.01).
    pub cameras: Vec<RigCameraSettings>,
    /// Pixel noise, per coordinate (px), unless a camera sets its own.
    pub pixel_sigma_px: f64,
    /// Standard deviation of an outlier pixel, per coordinate (px); how often one is drawn is
    /// `camera.outlier_probability`.
    pub outlier_sigma_px: f64,
    /// What the rig's file (`cameras.yaml`) gets wrong (default: nothing).
    pub miscalibration: Miscalibration,
}

/// One true camera of a simulated rig.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigCameraSettings {
    /// `[fu, fv, pu, pv]` (px).
    pub intrinsics: [f64; 4],
    /// `radtan` or `equidistant`.
    pub distortion_model: String,
    /// The model's four coefficients (Kalibr's order).
    pub distortion_coeffs: [f64; 4],
    /// `[width, height]` (px).
    pub resolution: [u32; 2],
    /// Its centre's distance from the previous camera's, along that camera's x axis (m; 0 for
    /// `cam0`).
    pub baseline_m: f64,
    /// Its turn towards the previous camera, about its y axis (deg; 0 for `cam0`).
    pub toe_in_deg: f64,
    /// A further rotation of the camera, a rotation vector in its own frame (deg; 0 for `cam0`).
    pub rotation_deg: [f64; 3],
    /// Its own pixel noise (px), instead of the rig's `pixel_sigma_px`.
    pub pixel_sigma_px: Option<f64>,
}

/// What the file of a simulated rig gets wrong, camera by camera (lists shorter than the rig
/// leave the remaining cameras right).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Miscalibration {
    /// The file's distance between each camera and the previous one, over the true distance.
    pub baseline_scale: f64,
    /// Per camera, the file's `[fu, fv]` over the true ones.
    pub focal_scale: Vec<[f64; 2]>,
    /// Per camera, the file's `[pu, pv]` less the true ones (px).
    pub principal_point_px: Vec<[f64; 2]>,
    /// The file's rotation of `cam1` relative to the truth, a rotation vector in cam1's frame
    /// (deg): `R_file = exp(ω) R_true`.
    pub rotation_deg: [f64; 3],
    /// The file gives every camera's distortion coefficients as zero.
    pub distortion_left_out: bool,
}

impl Default for RigSettings {
    fn default() -> Self {
        let cam1 = RigCameraSettings {
            intrinsics: [903.0, 902.0, 641.0, 401.5],
            baseline_m: 0.12,
            ..RigCameraSettings::default()
        };
        RigSettings {
            cameras: vec![RigCameraSettings::default(), cam1],
            pixel_sigma_px: 0.3,
            outlier_sigma_px: 5.0,
            miscalibration: Miscalibration::default(),
        }
    }
}

impl Default for RigCameraSettings {
    /// A 1280 × 800 camera with f = 900 px, its principal point at the image's centre and a
    /// residual radial distortion k1 = 0.01, where the rig starts.
    fn default() -> Self {
        RigCameraSettings {
            intrinsics: [900.0, 900.0, 639.5, 399.5],
            distortion_model: DistortionModel::Radtan.name().into(),
            distortion_coeffs: [0.01, 0.0, 0.0, 0.0],
            resolution: [1280, 800],
            baseline_m: 0.0,
            toe_in_deg: 0.0,
            rotation_deg: [0.0; 3],
            pixel_sigma_px: None,
        }
    }
}

impl Default for Miscalibration {
    /// A file that is the truth.
    fn default() -> Self {
        Miscalibration {
            baseline_scale: 1.0,
            focal_scale: Vec::new(),
            principal_point_px: Vec::new(),
            rotation_deg: [0.0; 3],
            distortion_left_out: false,
        }
    }
}

/// `(key, reason)` for a value out of its range, the key under `camera.rig`.
type Problem = (String, String);

fn problem(key: impl Into<String>, reason: impl Into<String>) -> Problem {
    (format!("camera.rig.{}", key.into()), reason.into())
}

/// The distortion model a config names.
fn distortion_model(name: &str) -> Option<DistortionModel> {
    [DistortionModel::Radtan, DistortionModel::Equidistant].into_iter().find(|m| m.name() == name)
}

/// The largest pixel noise a simulated rig takes (px).
const MAX_PIXEL_SIGMA_PX: f64 = 1000.0;

impl RigSettings {
    /// Values serde accepted but that make no rig, as `(key, reason)`, the key in full
    /// (`camera.rig.cameras[1].baseline_m`).
    ///
    /// # Errors
    /// The first value out of its range.
    pub(crate) fn check(&self) -> Result<(), Problem> {
        let n = self.cameras.len();
        if n == 0 || n > MAX_CAMERAS {
            return Err(problem("cameras", format!("a rig has from 1 to {MAX_CAMERAS} cameras (got {n})")));
        }
        // A pixel's noise up to a thousand pixels: far past any camera, short of infinities.
        for (key, value) in [("pixel_sigma_px", self.pixel_sigma_px), ("outlier_sigma_px", self.outlier_sigma_px)] {
            if !(value.is_finite() && (0.0..=MAX_PIXEL_SIGMA_PX).contains(&value)) {
                let got = crate::io::files::number(value);
                return Err(problem(key, format!("`{key}` must be from 0 to {MAX_PIXEL_SIGMA_PX} px (got {got})")));
            }
        }
        for (c, camera) in self.cameras.iter().enumerate() {
            camera.check(c).map_err(|(key, reason)| problem(format!("cameras[{c}].{key}"), reason))?;
        }
        self.miscalibration.check(n)?;
        // The file's lenses must be invertible over their images too (a triangulation unprojects).
        for (c, (truth, file)) in self.true_rig().cameras.iter().zip(&self.file_rig().cameras).enumerate() {
            for lens in [&truth.lens, &file.lens] {
                if let Some((angle, share)) = lens.radial_fold() {
                    let reason = format!(
                        "the {} distortion {:?} folds the image back on itself: its distorted radius stops growing {angle:.1}° off the axis, {:.0} % of the way to the image's farthest corner, which no lens does",
                        lens.distortion_model.name(),
                        lens.distortion,
                        100.0 * share
                    );
                    return Err(problem(format!("cameras[{c}].distortion_coeffs"), reason));
                }
            }
        }
        Ok(())
    }

    /// The true rig: the cameras as they are.
    pub(crate) fn true_rig(&self) -> Rig {
        let cameras = self.cameras.iter().enumerate().map(|(c, s)| s.camera(c)).collect();
        Rig { cameras }
    }

    /// The rig as its file states it: the true rig with [`Miscalibration`]'s errors.
    pub(crate) fn file_rig(&self) -> Rig {
        let mut rig = self.true_rig();
        let m = &self.miscalibration;
        for (c, camera) in rig.cameras.iter_mut().enumerate() {
            let lens = &mut camera.lens;
            let [su, sv] = m.focal_scale.get(c).copied().unwrap_or([1.0, 1.0]);
            let [du, dv] = m.principal_point_px.get(c).copied().unwrap_or([0.0, 0.0]);
            let [fu, fv, pu, pv] = lens.intrinsics;
            lens.intrinsics = [fu * su, fv * sv, pu + du, pv + dv];
            if m.distortion_left_out {
                lens.distortion = [0.0; 4];
            }
            if c == 0 {
                continue;
            }
            let turn = if c == 1 {
                so3::exp(&Vector3::from(m.rotation_deg).map(f64::to_radians))
            } else {
                Rotation3::identity()
            };
            let rotation = turn * camera.from_previous.rotation.to_rotation_matrix();
            // The centre in the previous camera's frame, `c = −Rᵀ t`, scaled.
            let centre = -(camera.from_previous.rotation.inverse() * camera.from_previous.translation.vector);
            camera.from_previous = pose(rotation, &(centre * m.baseline_scale));
        }
        rig
    }
}

/// The isometry `y ↦ R (y − c)`: a camera turned `R` with its centre at `c`.
fn pose(rotation: Rotation3<f64>, centre: &Vector3<f64>) -> Isometry3<f64> {
    let rotation = UnitQuaternion::from_rotation_matrix(&rotation);
    // (+ 0 makes a −0 of a zero coordinate 0, as a file should read.)
    Isometry3::from_parts(Translation3::from(-(rotation * centre) + Vector3::zeros()), rotation)
}

impl RigCameraSettings {
    /// The camera `c` these settings describe (`cam{c}`).
    fn camera(&self, c: usize) -> RigCamera {
        let lens = Lens {
            intrinsics: self.intrinsics,
            distortion_model: distortion_model(&self.distortion_model).unwrap_or(DistortionModel::Radtan),
            distortion: self.distortion_coeffs,
            resolution: self.resolution,
        };
        // Toe-in turns the optical axis towards the previous camera (−x): about y by +toe.
        let toe = so3::exp(&(Vector3::y() * self.toe_in_deg.to_radians()));
        let rotation = so3::exp(&Vector3::from(self.rotation_deg).map(f64::to_radians)) * toe;
        let from_previous = pose(rotation, &Vector3::new(self.baseline_m, 0.0, 0.0));
        RigCamera { name: format!("cam{c}"), lens, from_previous }
    }

    /// `(key under the camera, reason)` for the first value out of its range; camera `c`.
    fn check(&self, c: usize) -> Result<(), Problem> {
        let [fu, fv, pu, pv] = self.intrinsics;
        if !(fu.is_finite() && fv.is_finite() && fu > 0.0 && fv > 0.0 && pu.is_finite() && pv.is_finite()) {
            let reason = format!(
                "`intrinsics` [fu, fv, pu, pv] must be finite with positive focal lengths (got {:?})",
                self.intrinsics
            );
            return Err(("intrinsics".into(), reason));
        }
        if distortion_model(&self.distortion_model).is_none() {
            let reason =
                format!("`distortion_model` must be `radtan` or `equidistant` (got `{}`)", self.distortion_model);
            return Err(("distortion_model".into(), reason));
        }
        if let Some(k) = self.distortion_coeffs.iter().find(|k| !(k.is_finite() && k.abs() <= 1.0)) {
            return Err(("distortion_coeffs".into(), format!("each coefficient must lie within ±1 (got {k})")));
        }
        if self.resolution.contains(&0) {
            return Err(("resolution".into(), "`resolution` [width, height] must be at least one pixel each".into()));
        }
        if let Some(s) = self.pixel_sigma_px.filter(|s| !(s.is_finite() && (0.0..=MAX_PIXEL_SIGMA_PX).contains(s))) {
            let got = crate::io::files::number(s);
            return Err((
                "pixel_sigma_px".into(),
                format!("`pixel_sigma_px` must be from 0 to {MAX_PIXEL_SIGMA_PX} px (got {got})"),
            ));
        }
        let turned = self.toe_in_deg != 0.0 || self.rotation_deg != [0.0; 3];
        if c == 0 && (self.baseline_m != 0.0 || turned) {
            let reason = "the first camera defines the camera frame: its `baseline_m`, `toe_in_deg` and `rotation_deg` must be 0";
            return Err(("baseline_m".into(), reason.into()));
        }
        if c > 0 && !(self.baseline_m.is_finite() && self.baseline_m > 0.0 && self.baseline_m <= 10.0) {
            let reason = format!(
                "`baseline_m` (its centre's distance to the previous camera's, along its x axis) must lie in (0, 10] m (got {})",
                self.baseline_m
            );
            return Err(("baseline_m".into(), reason));
        }
        let angle = Vector3::from(self.rotation_deg).norm();
        if !(self.toe_in_deg.is_finite() && self.toe_in_deg.abs() < 45.0) {
            return Err(("toe_in_deg".into(), format!("`toe_in_deg` must lie within ±45° (got {})", self.toe_in_deg)));
        }
        if !(angle.is_finite() && angle < 45.0) {
            return Err((
                "rotation_deg".into(),
                format!("`rotation_deg` must turn the camera less than 45° (got {angle}°)"),
            ));
        }
        Ok(())
    }
}

impl Miscalibration {
    /// The first value out of its range, for a rig of `n` cameras.
    fn check(&self, n: usize) -> Result<(), Problem> {
        let key = |k: &str| format!("miscalibration.{k}");
        if !(self.baseline_scale.is_finite() && (0.5..=2.0).contains(&self.baseline_scale)) {
            let reason = format!("`baseline_scale` must lie in [0.5, 2] (got {})", self.baseline_scale);
            return Err(problem(key("baseline_scale"), reason));
        }
        for (name, len) in
            [("focal_scale", self.focal_scale.len()), ("principal_point_px", self.principal_point_px.len())]
        {
            if len > n {
                let reason = format!("`{name}` lists {len} cameras, the rig has {n}");
                return Err(problem(key(name), reason));
            }
        }
        for (c, s) in self.focal_scale.iter().enumerate() {
            if let Some(v) = s.iter().find(|v| !(v.is_finite() && (0.5..=2.0).contains(*v))) {
                let reason = format!("each focal scale must lie in [0.5, 2] (got {v})");
                return Err(problem(format!("{}[{c}]", key("focal_scale")), reason));
            }
        }
        for (c, d) in self.principal_point_px.iter().enumerate() {
            if let Some(v) = d.iter().find(|v| !(v.is_finite() && v.abs() <= 1000.0)) {
                let reason = format!("each principal point offset must lie within ±1000 px (got {v})");
                return Err(problem(format!("{}[{c}]", key("principal_point_px")), reason));
            }
        }
        let angle = Vector3::from(self.rotation_deg).norm();
        if !(angle.is_finite() && angle < 45.0) {
            return Err(problem(
                key("rotation_deg"),
                format!("`rotation_deg` must turn cam1 less than 45° (got {angle}°)"),
            ));
        }
        if n < 2 && angle > 0.0 {
            return Err(problem(key("rotation_deg"), "`rotation_deg` turns cam1, and the rig has one camera"));
        }
        Ok(())
    }
}

/// What a simulated rig's cameras do: the true rig images, pixel noise (and, rarely, an outlier)
/// is added, and a pixel outside its image is lost.
#[derive(Debug, Clone)]
pub(crate) struct PixelCameras {
    /// The true rig.
    pub(crate) truth: Rig,
    /// The rig as its file states it.
    pub(crate) file: Rig,
    /// Each camera's pixel noise (px).
    sigma: Vec<f64>,
    /// The probability of an outlier pixel.
    outlier_probability: f64,
    /// An outlier's deviation per coordinate (px).
    outlier_sigma: f64,
}

/// What one camera made of a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Sighting {
    /// A pixel, and whether it was drawn as an outlier.
    Pixel(Vector2<f64>, bool),
    /// Behind the camera or outside its image.
    Lost,
}

impl PixelCameras {
    /// The cameras of `settings` (checked), drawing outliers with probability `outlier_probability`.
    pub(crate) fn new(settings: &RigSettings, outlier_probability: f64) -> Self {
        // As their files will hold them (each rotation in its canonical form): a session read
        // back from its folder is then the session simulated, bit for bit.
        PixelCameras {
            truth: as_written(&settings.true_rig()),
            file: as_written(&settings.file_rig()),
            sigma: settings.cameras.iter().map(|c| c.pixel_sigma_px.unwrap_or(settings.pixel_sigma_px)).collect(),
            outlier_probability,
            outlier_sigma: settings.outlier_sigma_px,
        }
    }

    /// The cameras' centres in cam0's frame (C), where their lines of sight start.
    pub(crate) fn centres(&self) -> Vec<Vector3<f64>> {
        (0..self.truth.cameras.len()).map(|c| self.truth.from_cam0(c).inverse().translation.vector).collect()
    }

    /// Camera `c`'s pixel of the point `y` (C).
    ///
    /// # Panics
    /// If a deviation is not finite (configs are checked when read).
    pub(crate) fn see<R: Rng + ?Sized>(&self, c: usize, y: &Vector3<f64>, rng: &mut R) -> Sighting {
        let Some(projection) = self.truth.project(c, y) else { return Sighting::Lost };
        let gauss = |sigma: f64, rng: &mut R| Normal::new(0.0, sigma).expect("validated deviation").sample(rng);
        let sigma = self.sigma[c];
        let mut pixel = projection.lens.pixel + Vector2::new(gauss(sigma, rng), gauss(sigma, rng));
        let outlier = rng.random_bool(self.outlier_probability);
        if outlier {
            pixel += Vector2::new(gauss(self.outlier_sigma, rng), gauss(self.outlier_sigma, rng));
        }
        let [w, h] = self.truth.cameras[c].lens.resolution.map(|r| f64::from(r) - 0.5);
        let inside = (-0.5..=w).contains(&pixel.x) && (-0.5..=h).contains(&pixel.y);
        if inside { Sighting::Pixel(pixel, outlier) } else { Sighting::Lost }
    }
}
