//! The parameters file (`params.yaml`): per-leg geometry, optional camera registration,
//! and a header saying where it came from; a fit adds the markers' positions and a free-motion
//! recording the camera's latency (at the encoders' time 0) and its clock's rate difference. Angles are degrees (`_deg`), lengths metres (`_m`), times
//! seconds (`_s`).
//!
//! ```yaml
//! format: spmcal-parameters/1
//! source: nominal            # nominal | calibrated | truth
//! model: agile_wrist        # a shipped model's name, or the URDF's path relative to this file
//! model_sha256: 9f2c…         # the model's identity (SHA-256 of its URDF and companion)
//! legs:                      # three, in leg order
//!   - u: [0.0, 0.816496580927726, -0.577350269189626]
//!     z: [1.0, 0.0, 0.0]
//!     alpha1_deg: 90.0
//!     alpha2_deg: 90.0
//!     v0: [0.0, 0.816496580927726, 0.577350269189626]
//!     delta_deg: 0.0
//!     scale: 1.004           # joint scale (phi = scale * theta + delta); written when not 1
//!     home_branch: negative  # sign of (u×w)·v at home; optional, negative when absent
//! camera:                    # optional: x_C = R_CB x_B + t_CB, reported at K x_C / (cᵀx_C + 1)
//!   r_cb_wxyz: [1.0, 0.0, 0.0, 0.0]
//!   t_cb_m: [0.0, 0.0, 0.8]
//!   camera_model: depth_scale  # optional: rigid (K = I, when absent) | depth_scale | affine | projective
//!   depth_scale: 1.0198        # the model's terms (see camera.rs), each with an optional
//!   depth_scale_std_error: 0.0011  # `_std_error`; absent terms are a perfect camera's
//! fit: {}                    # optional: statistics of the fit that produced the file
//! ```

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::camera::{CameraModel, CameraModelKind, CameraTerm};
use super::geometry::{GeometryError, HomeBranch, LegGeometry};
use super::limits::{MAX_CAMERA_TERM, MAX_CLOCK_RATE_PPM, MAX_LATENCY_S, Ranges};
use super::spm::{IkError, Spm, SpmError};
use crate::io::files::FileError;
use crate::math::so3;

/// The format tag written at the top of every parameters file.
pub(crate) const PARAMETERS_FORMAT: &str = "spmcal-parameters/1";

/// Where a parameter set came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParameterSource {
    /// The model's nominal geometry.
    Nominal,
    /// The result of a calibration.
    Calibrated,
    /// The true geometry of a simulated session.
    Truth,
}

/// Camera registration `x_C = R_CB x_B + t_CB`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraRegistration {
    /// `R_CB`.
    pub rotation: Rotation3<f64>,
    /// `t_CB` (m).
    pub translation: Vector3<f64>,
}

impl CameraRegistration {
    /// The camera with rotation `R_CB` and its centre at `centre` (in B): `t_CB = −R_CB c`.
    pub fn from_centre(rotation: Rotation3<f64>, centre: &Vector3<f64>) -> Self {
        CameraRegistration { rotation, translation: -(rotation * centre) }
    }

    /// The camera centre in B, `c = −R_CBᵀ t_CB`.
    pub fn centre(&self) -> Vector3<f64> {
        -(self.rotation.inverse() * self.translation)
    }

    /// A point in B seen in the camera frame, `x_C = R_CB x_B + t_CB`.
    pub fn to_camera(&self, point: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * point + self.translation
    }

    /// A point in the camera frame put in B, `x_B = R_CBᵀ (x_C − t_CB)`.
    pub fn to_base(&self, point: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (point - self.translation)
    }
}

/// A complete parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameters {
    /// Where the parameters came from.
    pub source: ParameterSource,
    /// The model the parameters were derived from: a shipped model's name (`agile_wrist`) or the
    /// URDF's path. [`Parameters::read`] resolves a relative path against the file's folder and
    /// [`Parameters::write`] writes it relative to the file's folder again.
    pub model: Option<String>,
    /// The model's identity when the parameters were made (SHA-256 of its URDF's bytes followed
    /// by its companion's): how a copied file finds its model and notices a changed one.
    pub model_sha256: Option<String>,
    /// The geometry of the three legs.
    pub legs: [LegGeometry; 3],
    /// The camera registration, when known.
    pub camera: Option<CameraRegistration>,
    /// How the camera distorts what it sees (written with the registration, so only when that is
    /// known): a perfect camera unless fitted (or simulated).
    pub camera_model: CameraModel,
    /// The markers' positions in P, when a fit estimated them (or a simulation drew them);
    /// empty: the model's companion holds them.
    pub markers: Vec<MarkerPosition>,
    /// The camera's latency behind the encoders (s), when fitted (or simulated) from a
    /// free-motion recording: at the encoders' time 0 when the camera's clock runs at its own rate.
    pub latency_s: Option<f64>,
    /// How much faster the camera's clock runs than the encoders' (ppm), when fitted (or
    /// simulated, or held) with the latency: a capture stamped `t` was taken at
    /// `(t − latency) / (1 + rate·10⁻⁶)` on the encoders' clock. Absent: 0.
    pub clock_rate_ppm: Option<f64>,
    /// How far the platform sags under its weight, degrees per unit of the gravity torque's arm
    /// ([`Spm::sagged`]): 0 for a rigid mechanism (absent from the file).
    pub platform_sag_deg: f64,
    /// Its standard error (degrees per unit of arm), when fitted.
    pub platform_sag_std_error_deg: Option<f64>,
    /// Statistics of the fit that produced the file (informational).
    pub fit: Option<serde_yaml::Value>,
}

/// A marker's position on the MP, as fitted.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerPosition {
    /// Marker name (as in the companion and the sessions).
    pub name: String,
    /// Position in P (m).
    pub position: Vector3<f64>,
    /// Standard errors per axis (m), when fitted.
    pub std_error: Option<Vector3<f64>>,
    /// For a rigid body's frame (its origin is `position`), its orientation on the MP: body
    /// frame → P; `None` for a marker.
    pub rotation: Option<Rotation3<f64>>,
    /// Its standard errors (rad, per axis of a small rotation in P), when fitted.
    pub rotation_std_error: Option<Vector3<f64>>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MarkerRecord {
    name: String,
    position_m: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    std_error_m: Option<[f64; 3]>,
    /// A rigid body's frame: its orientation on the MP (body → P), scalar first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rotation_wxyz: Option<[f64; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rotation_std_error_deg: Option<[f64; 3]>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LegRecord {
    u: [f64; 3],
    z: [f64; 3],
    alpha1_deg: f64,
    alpha2_deg: f64,
    v0: [f64; 3],
    delta_deg: f64,
    /// The joint's scale (`φ = sθ + δ`): written only when it is not 1, read as 1 when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scale: Option<f64>,
    /// Absent in files written before the signs were kept: those were all negative.
    #[serde(default)]
    home_branch: HomeBranch,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraRecord {
    /// Required in a parameters file; absent in a model's companion (which holds only the
    /// camera model an export carries).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    r_cb_wxyz: Option<[f64; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    t_cb_m: Option<[f64; 3]>,
    /// Absent: inferred from the terms given (none: rigid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera_model: Option<CameraModelKind>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    depth_scale: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    depth_scale_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scale_y: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scale_y_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_xy: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_xy_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_xz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_xz_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_yz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shear_yz_std_error: Option<f64>,
    /// The projective model's `c`, per metre (absent in files written before it: 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_x: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_x_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_y: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_y_std_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_z: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    perspective_z_std_error: Option<f64>,
}

impl LegRecord {
    /// The geometry, in radians; unchecked.
    fn geometry(&self) -> LegGeometry {
        LegGeometry {
            u: Vector3::from(self.u),
            z: Vector3::from(self.z),
            alpha1: self.alpha1_deg.to_radians(),
            alpha2: self.alpha2_deg.to_radians(),
            v0: Vector3::from(self.v0),
            delta: self.delta_deg.to_radians(),
            scale: self.scale.unwrap_or(1.0),
            home_branch: self.home_branch,
        }
    }
}

impl CameraRecord {
    /// The registration, every number checked at its key's line.
    fn registration(&self, check: &Ranges) -> Result<CameraRegistration, FileError> {
        let key = "camera.r_cb_wxyz";
        let (Some(wxyz), Some(t)) = (self.r_cb_wxyz, self.t_cb_m) else {
            let missing = if self.r_cb_wxyz.is_none() { "r_cb_wxyz" } else { "t_cb_m" };
            return Err(
                check.error("camera", format!("`camera` needs `r_cb_wxyz` and `t_cb_m`: `{missing}` is missing"))
            );
        };
        check.finite(key, "`r_cb_wxyz` is not a unit quaternion", &wxyz)?;
        let norm = wxyz.iter().map(|c| c * c).sum::<f64>().sqrt();
        let rotation = so3::from_wxyz(wxyz)
            .ok_or_else(|| check.error(key, format!("`r_cb_wxyz` is not a unit quaternion (its norm is {norm})")))?;
        check.position("camera.t_cb_m", "the camera's `t_cb_m`", &t)?;
        Ok(CameraRegistration { rotation, translation: Vector3::from(t) })
    }

    fn term_slots(&self) -> [(CameraTerm, Option<f64>, Option<f64>); CameraTerm::ALL.len()] {
        [
            (CameraTerm::DepthScale, self.depth_scale, self.depth_scale_std_error),
            (CameraTerm::ScaleY, self.scale_y, self.scale_y_std_error),
            (CameraTerm::ShearXy, self.shear_xy, self.shear_xy_std_error),
            (CameraTerm::ShearXz, self.shear_xz, self.shear_xz_std_error),
            (CameraTerm::ShearYz, self.shear_yz, self.shear_yz_std_error),
            (CameraTerm::PerspectiveX, self.perspective_x, self.perspective_x_std_error),
            (CameraTerm::PerspectiveY, self.perspective_y, self.perspective_y_std_error),
            (CameraTerm::PerspectiveZ, self.perspective_z, self.perspective_z_std_error),
        ]
    }

    /// The camera model, every term checked at its key's line: a term of another model, a value
    /// beyond ±`MAX_CAMERA_TERM` of a perfect camera's or a negative standard error is refused.
    pub(super) fn camera_model(&self, check: &Ranges) -> Result<CameraModel, FileError> {
        let slots = self.term_slots();
        let given = |t: CameraTerm| slots.iter().any(|(s, v, e)| *s == t && (v.is_some() || e.is_some()));
        let kind = self.camera_model.unwrap_or_else(|| CameraModelKind::smallest(given));
        let mut model = CameraModel::perfect(kind);
        for (term, value, std_error) in slots {
            let key = format!("camera.{}", term.name());
            if !kind.terms().contains(&term) {
                if value.is_some() || std_error.is_some() {
                    let reason = format!("`{}` is not a term of the `{}` camera model", term.name(), kind.name());
                    return Err(check.error(&key, reason));
                }
                continue;
            }
            let v = value.unwrap_or(term.perfect());
            if !(v.is_finite() && (v - term.perfect()).abs() <= MAX_CAMERA_TERM) {
                let hint = if term.perfect() == 1.0 { " (a scale is a ratio: 1.02 for 2% long)" } else { "" };
                let reason = format!(
                    "`{}` = {v} is not within ±{MAX_CAMERA_TERM} of a perfect camera's {}{hint}",
                    term.name(),
                    term.perfect()
                );
                return Err(check.error(&key, reason));
            }
            // A standard error says how well the session determined the term: a poorly determined
            // one may exceed any bound on the value itself, and the file must still read back.
            if let Some(e) = std_error.filter(|e| !(e.is_finite() && *e >= 0.0)) {
                let reason = format!("`{}_std_error` = {e} must be finite and not negative", term.name());
                return Err(check.error(&format!("{key}_std_error"), reason));
            }
            model = model.with(term, v, std_error);
        }
        if let Some(reason) = model.defect() {
            return Err(check.error("camera.camera_model", reason));
        }
        Ok(model)
    }

    /// Whether it holds a registration (a model's companion may not).
    #[cfg(feature = "full")]
    pub(super) fn has_registration(&self) -> bool {
        self.r_cb_wxyz.is_some() || self.t_cb_m.is_some()
    }

    /// The record of `model` with `registration`, when given.
    pub(super) fn of(registration: Option<&CameraRegistration>, model: &CameraModel) -> Self {
        let term = |t: CameraTerm| model.kind.terms().contains(&t).then(|| model.value(t));
        let error = |t: CameraTerm| model.kind.terms().contains(&t).then(|| model.std_error(t)).flatten();
        CameraRecord {
            r_cb_wxyz: registration.map(|r| so3::to_wxyz(&r.rotation)),
            t_cb_m: registration.map(|r| r.translation.into()),
            camera_model: (model.kind != CameraModelKind::Rigid).then_some(model.kind),
            depth_scale: term(CameraTerm::DepthScale),
            depth_scale_std_error: error(CameraTerm::DepthScale),
            scale_y: term(CameraTerm::ScaleY),
            scale_y_std_error: error(CameraTerm::ScaleY),
            shear_xy: term(CameraTerm::ShearXy),
            shear_xy_std_error: error(CameraTerm::ShearXy),
            shear_xz: term(CameraTerm::ShearXz),
            shear_xz_std_error: error(CameraTerm::ShearXz),
            shear_yz: term(CameraTerm::ShearYz),
            shear_yz_std_error: error(CameraTerm::ShearYz),
            perspective_x: term(CameraTerm::PerspectiveX),
            perspective_x_std_error: error(CameraTerm::PerspectiveX),
            perspective_y: term(CameraTerm::PerspectiveY),
            perspective_y_std_error: error(CameraTerm::PerspectiveY),
            perspective_z: term(CameraTerm::PerspectiveZ),
            perspective_z_std_error: error(CameraTerm::PerspectiveZ),
        }
    }
}

/// The key of the value a leg's geometry error is about: `legs[i].alpha1_deg`, `legs[i].u`, or
/// the first non-finite component `legs[i].v0[2]`.
fn leg_key(e: &GeometryError, leg: &LegGeometry) -> String {
    let i = e.leg();
    let axis = |what: &str| match what {
        "u" => Some(leg.u),
        "z" => Some(leg.z),
        "v0" => Some(leg.v0),
        _ => None,
    };
    match e {
        GeometryError::NotFinite { what, .. } => match axis(what) {
            Some(v) => match v.iter().position(|c| !c.is_finite()) {
                Some(k) => format!("legs[{i}].{what}[{k}]"),
                None => format!("legs[{i}].{what}"),
            },
            None if *what == "scale" => format!("legs[{i}].scale"),
            None => format!("legs[{i}].{what}_deg"),
        },
        GeometryError::NotUnit { what, .. } => format!("legs[{i}].{what}"),
        GeometryError::ZeroDirectionNotOrthogonal { .. } => format!("legs[{i}].z"),
        GeometryError::LinkAngleOutOfRange { what, .. } => format!("legs[{i}].{what}_deg"),
        GeometryError::ScaleOutOfRange { .. } => format!("legs[{i}].scale"),
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParametersRecord {
    format: String,
    source: ParameterSource,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model_sha256: Option<String>,
    legs: Vec<LegRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera: Option<CameraRecord>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    markers: Vec<MarkerRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    latency_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    clock_rate_ppm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    platform_sag_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    platform_sag_std_error_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fit: Option<serde_yaml::Value>,
}

impl Parameters {
    /// Nominal parameters of a manipulator, without camera registration.
    pub fn nominal(spm: &Spm, model: Option<String>) -> Self {
        Parameters {
            source: ParameterSource::Nominal,
            model,
            model_sha256: None,
            legs: *spm.geometry(),
            camera: None,
            camera_model: CameraModel::rigid(),
            markers: Vec::new(),
            latency_s: None,
            clock_rate_ppm: None,
            platform_sag_deg: spm.platform_sag().to_degrees(),
            platform_sag_std_error_deg: None,
            fit: None,
        }
    }

    /// The fitted position in P of the marker `name`, when the file has it. One look-up scans the
    /// markers: for many names use [`Parameters::marker_positions`].
    pub fn marker(&self, name: &str) -> Option<Vector3<f64>> {
        self.markers.iter().find(|m| m.name == name).map(|m| m.position)
    }

    /// The fitted positions in P of the markers `names`, in their order (`None` for one the file
    /// does not have), in time linear in the two counts.
    pub fn marker_positions<'a>(&self, names: impl IntoIterator<Item = &'a str>) -> Vec<Option<Vector3<f64>>> {
        let by_name: HashMap<&str, Vector3<f64>> = self.markers.iter().map(|m| (m.name.as_str(), m.position)).collect();
        names.into_iter().map(|name| by_name.get(name).copied()).collect()
    }

    /// The manipulator these parameters describe (validated).
    ///
    /// # Errors
    /// An [`SpmError`](super::SpmError) when the legs (or the sag) do not make a usable manipulator.
    pub fn spm(&self) -> Result<Spm, super::SpmError> {
        Spm::new(self.legs)?.with_platform_sag(self.platform_sag_deg.to_radians())
    }

    /// Read and validate a parameters file. Every number is checked against its range (see
    /// `limits.rs`) and an error is reported at the line and key of the value itself
    /// (`legs[1].alpha2_deg`, `markers[3].position_m[2]`), not at its leg or marker.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and key of the first problem.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let (record, keys) = crate::io::yaml::read::<ParametersRecord>(path)?;
        let check = Ranges { path, keys: &keys };
        if record.format != PARAMETERS_FORMAT {
            let reason = format!("format is `{}`, expected `{PARAMETERS_FORMAT}`", record.format);
            return Err(check.error("format", reason));
        }
        let legs: [LegRecord; 3] = record
            .legs
            .try_into()
            .map_err(|v: Vec<LegRecord>| check.error("legs", format!("`legs` has {} entries, expected 3", v.len())))?;
        for (i, record) in legs.iter().enumerate() {
            if let Some(scale) = record.scale {
                check.joint_scale(&format!("legs[{i}].scale"), &format!("leg {}: scale", i + 1), scale)?;
            }
            let leg = record.geometry();
            leg.validated(i).map_err(|e| check.error(&leg_key(&e, &leg), e.to_string()))?;
            let delta = format!("legs[{i}].delta_deg");
            check.offset_deg(&delta, &format!("leg {}: delta_deg", i + 1), record.delta_deg)?;
        }
        let legs = legs.map(|l| l.geometry());
        Spm::new(legs).map_err(|e| {
            // Locate what the error is about (a leg's 0-based index is the file's `legs[k]`).
            let key = match &e {
                SpmError::Geometry(g) => leg_key(g, &legs[g.leg()]),
                SpmError::ParallelPlatformAxes(_, j) => format!("legs[{j}].v0"),
                SpmError::NoHomeClosure(
                    IkError::OutsideWorkspace { leg, .. } | IkError::SerialSingularity { leg, .. },
                ) => format!("legs[{leg}]"),
                _ => "legs".to_string(),
            };
            check.error(&key, e.to_string())
        })?;
        let (camera, camera_model) = match record.camera {
            None => (None, CameraModel::rigid()),
            Some(c) => (Some(c.registration(&check)?), c.camera_model(&check)?),
        };
        let mut markers = Vec::with_capacity(record.markers.len());
        // Each name with its entry: a repeated name is found in one pass, whatever the count.
        let mut seen: HashMap<String, usize> = HashMap::with_capacity(record.markers.len());
        for (k, m) in record.markers.into_iter().enumerate() {
            let key = format!("markers[{k}]");
            if m.name.trim().is_empty() {
                return Err(check.error(&format!("{key}.name"), "a marker name is empty"));
            }
            if let Some(first) = seen.insert(m.name.clone(), k) {
                let at = keys.line(&format!("markers[{first}]")).map_or(String::new(), |l| format!(", line {l}"));
                let reason = format!("marker `{}` is listed twice (first as `markers[{first}]`{at})", m.name);
                return Err(check.error(&format!("{key}.name"), reason));
            }
            check.position(&format!("{key}.position_m"), &format!("marker `{}`'s position", m.name), &m.position_m)?;
            if let Some(e) = &m.std_error_m {
                let se = format!("{key}.std_error_m");
                check.finite(&se, &format!("marker `{}`'s standard error is not finite", m.name), e)?;
                // However poorly determined (a marker seen at few poses), not bounded like a position.
                if let Some(axis) = e.iter().position(|x| *x < 0.0) {
                    let reason = format!("marker `{}`'s standard error {} m must not be negative", m.name, e[axis]);
                    return Err(check.error(&format!("{se}[{axis}]"), reason));
                }
            }
            if let Some(e) = &m.rotation_std_error_deg {
                let se = format!("{key}.rotation_std_error_deg");
                check.finite(&se, &format!("body `{}`'s rotation standard error is not finite", m.name), e)?;
                if let Some(axis) = e.iter().position(|x| *x < 0.0) {
                    let reason =
                        format!("body `{}`'s rotation standard error {}° must not be negative", m.name, e[axis]);
                    return Err(check.error(&format!("{se}[{axis}]"), reason));
                }
            }
            let rotation = match m.rotation_wxyz {
                Some(q) => Some(so3::from_wxyz(q).ok_or_else(|| {
                    let reason =
                        format!("body `{}`'s rotation {q:?} is not a unit quaternion (qw, qx, qy, qz)", m.name);
                    check.error(&format!("{key}.rotation_wxyz"), reason)
                })?),
                None => None,
            };
            markers.push(MarkerPosition {
                name: m.name,
                position: Vector3::from(m.position_m),
                std_error: m.std_error_m.map(Vector3::from),
                rotation,
                rotation_std_error: m.rotation_std_error_deg.map(|e| Vector3::from(e).map(f64::to_radians)),
            });
        }
        if let Some(latency) = record.latency_s
            && !(latency.is_finite() && latency.abs() <= MAX_LATENCY_S)
        {
            let reason = if latency.is_finite() {
                format!(
                    "`latency_s` = {latency} s is outside ±{MAX_LATENCY_S} s, the bound within which a recording's \
                     camera latency is searched: at this latency frames of a recording would be left out"
                )
            } else {
                format!("`latency_s` is {latency}: a latency must be a finite time within ±{MAX_LATENCY_S} s")
            };
            return Err(check.error("latency_s", reason));
        }
        if let Some(hash) = &record.model_sha256
            && !(hash.len() == 64 && hash.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)))
        {
            let reason = format!("`model_sha256` is `{hash}`; a model's identity is 64 lowercase hexadecimal digits");
            return Err(check.error("model_sha256", reason));
        }
        if let Some(rate) = record.clock_rate_ppm
            && !(rate.is_finite() && rate.abs() <= MAX_CLOCK_RATE_PPM)
        {
            let reason = format!(
                "`clock_rate_ppm` = {rate}: a camera clock's rate difference must be a finite number within ±{MAX_CLOCK_RATE_PPM} ppm (quartz clocks differ by tens of ppm)"
            );
            return Err(check.error("clock_rate_ppm", reason));
        }
        let platform_sag_deg = record.platform_sag_deg.unwrap_or(0.0);
        if !(platform_sag_deg.is_finite() && platform_sag_deg.to_radians().abs() <= super::spm::MAX_PLATFORM_SAG) {
            let reason = format!(
                "`platform_sag_deg` = {platform_sag_deg}: a platform's sag must be a finite number of degrees per \
                 unit of arm within ±10 (a rigid mechanism's is 0)"
            );
            return Err(check.error("platform_sag_deg", reason));
        }
        if let Some(se) = record.platform_sag_std_error_deg
            && !(se.is_finite() && se >= 0.0)
        {
            let reason =
                format!("`platform_sag_std_error_deg` = {se}: a standard error must be finite and not negative");
            return Err(check.error("platform_sag_std_error_deg", reason));
        }
        Ok(Parameters {
            source: record.source,
            model: record.model.map(|m| {
                let folder = path.parent().unwrap_or(Path::new(""));
                crate::io::files::resolve_reference(folder, Path::new(&m)).display().to_string()
            }),
            model_sha256: record.model_sha256,
            legs,
            camera,
            camera_model,
            markers,
            latency_s: record.latency_s,
            clock_rate_ppm: record.clock_rate_ppm,
            platform_sag_deg,
            platform_sag_std_error_deg: record.platform_sag_std_error_deg,
            fit: record.fit,
        })
    }

    /// The file text, with a comment header.
    ///
    /// # Panics
    /// Never in practice: serialising the parameters cannot fail.
    pub fn to_yaml(&self) -> String {
        let record = ParametersRecord {
            format: PARAMETERS_FORMAT.to_string(),
            source: self.source,
            model: self.model.clone(),
            model_sha256: self.model_sha256.clone(),
            legs: self
                .legs
                .iter()
                .map(|g| LegRecord {
                    u: g.u.into(),
                    z: g.z.into(),
                    alpha1_deg: g.alpha1.to_degrees(),
                    alpha2_deg: g.alpha2.to_degrees(),
                    v0: g.v0.into(),
                    delta_deg: g.delta.to_degrees(),
                    scale: (g.scale != 1.0).then_some(g.scale),
                    home_branch: g.home_branch,
                })
                .collect(),
            camera: self.camera.map(|c| CameraRecord::of(Some(&c), &self.camera_model)),
            markers: self
                .markers
                .iter()
                .map(|m| MarkerRecord {
                    name: m.name.clone(),
                    position_m: m.position.into(),
                    std_error_m: m.std_error.map(Into::into),
                    rotation_wxyz: m.rotation.as_ref().map(so3::to_wxyz),
                    rotation_std_error_deg: m.rotation_std_error.map(|e| e.map(f64::to_degrees).into()),
                })
                .collect(),
            latency_s: self.latency_s,
            clock_rate_ppm: self.clock_rate_ppm,
            platform_sag_deg: (self.platform_sag_deg != 0.0).then_some(self.platform_sag_deg),
            platform_sag_std_error_deg: self.platform_sag_std_error_deg,
            fit: self.fit.clone(),
        };
        let body = serde_yaml::to_string(&record).expect("parameters serialise to YAML");
        let sag = match self.platform_sag_deg != 0.0 {
            true => {
                "# platform_sag_deg: the platform's turn under its weight, degrees per unit of the arm\n\
                     # n x (-z) (n its axis, z the base's up), after the rigid mechanism's orientation.\n"
            }
            false => "",
        };
        format!(
            "# spmcal parameters of a spherical parallel manipulator (conventions: docs/conventions.md).\n\
             # Per leg: actuated axis u and zero direction z in B, link angles alpha1/alpha2, platform\n\
             # axis v0 in P, encoder offset delta and scale (phi = scale * theta + delta; scale 1 when\n\
             # absent), home_branch (the sign of (u x w).v at home, which the working mode keeps).\n\
             # Camera: x_C = R_CB x_B + t_CB.\n\
             # Markers (when fitted): positions in P, metres.\n{sag}{body}"
        )
    }
}
