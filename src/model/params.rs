//! The parameters file (`params.yaml`): per-leg geometry, optional camera registration,
//! and a header saying where it came from; a fit adds the markers' positions and a free-motion
//! recording the camera's latency. Angles are degrees (`_deg`), lengths metres (`_m`), times
//! seconds (`_s`).
//!
//! ```yaml
//! format: spmcal-parameters/1
//! source: nominal            # nominal | calibrated | truth
//! model: models/agile_wrist.urdf
//! legs:                      # three, in leg order
//!   - u: [0.0, 0.816496580927726, -0.577350269189626]
//!     z: [1.0, 0.0, 0.0]
//!     alpha1_deg: 90.0
//!     alpha2_deg: 90.0
//!     v0: [0.0, 0.816496580927726, 0.577350269189626]
//!     delta_deg: 0.0
//! camera:                    # optional: x_C = R_CB x_B + t_CB
//!   r_cb_wxyz: [1.0, 0.0, 0.0, 0.0]
//!   t_cb_m: [0.0, 0.0, 0.8]
//! fit: {}                    # optional: statistics of the fit that produced the file
//! ```

use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use super::geometry::LegGeometry;
use super::spm::Spm;
use crate::io::files::FileError;
#[cfg(feature = "full")]
use crate::io::files::write_atomic;
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
    /// The model the parameters were derived from, as written in the file.
    pub model: Option<String>,
    /// The geometry of the three legs.
    pub legs: [LegGeometry; 3],
    /// The camera registration, when known.
    pub camera: Option<CameraRegistration>,
    /// The markers' positions in P, when a fit estimated them (or a simulation drew them);
    /// empty: the model's companion holds them.
    pub markers: Vec<MarkerPosition>,
    /// The camera's latency behind the encoders (s), when fitted (or simulated) from a
    /// free-motion recording.
    pub latency_s: Option<f64>,
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
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MarkerRecord {
    name: String,
    position_m: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    std_error_m: Option<[f64; 3]>,
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
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraRecord {
    r_cb_wxyz: [f64; 4],
    t_cb_m: [f64; 3],
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParametersRecord {
    format: String,
    source: ParameterSource,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<String>,
    legs: Vec<LegRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera: Option<CameraRecord>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    markers: Vec<MarkerRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    latency_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fit: Option<serde_yaml::Value>,
}

impl Parameters {
    /// Nominal parameters of a manipulator, without camera registration.
    pub fn nominal(spm: &Spm, model: Option<String>) -> Self {
        Parameters {
            source: ParameterSource::Nominal,
            model,
            legs: *spm.geometry(),
            camera: None,
            markers: Vec::new(),
            latency_s: None,
            fit: None,
        }
    }

    /// The fitted position in P of the marker `name`, when the file has it.
    pub fn marker(&self, name: &str) -> Option<Vector3<f64>> {
        self.markers.iter().find(|m| m.name == name).map(|m| m.position)
    }

    /// The manipulator these parameters describe (validated).
    ///
    /// # Errors
    /// An [`SpmError`](super::SpmError) when the legs do not make a usable manipulator.
    pub fn spm(&self) -> Result<Spm, super::SpmError> {
        Spm::new(self.legs)
    }

    /// Read and validate a parameters file.
    ///
    /// # Errors
    /// A [`FileError`] naming the line and key of the first problem.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let (record, keys) = crate::io::yaml::read::<ParametersRecord>(path)?;
        if record.format != PARAMETERS_FORMAT {
            let reason = format!("format is `{}`, expected `{PARAMETERS_FORMAT}`", record.format);
            return Err(keys.error(path, "format", reason));
        }
        let legs: [LegRecord; 3] = record.legs.try_into().map_err(|v: Vec<LegRecord>| {
            keys.error(path, "legs", format!("`legs` has {} entries, expected 3", v.len()))
        })?;
        let legs = legs.map(|l| LegGeometry {
            u: Vector3::from(l.u),
            z: Vector3::from(l.z),
            alpha1: l.alpha1_deg.to_radians(),
            alpha2: l.alpha2_deg.to_radians(),
            v0: Vector3::from(l.v0),
            delta: l.delta_deg.to_radians(),
        });
        Spm::new(legs).map_err(|e| {
            // Locate the leg the error is about (its 0-based index is the file's `legs[k]`).
            let key = match &e {
                super::SpmError::Geometry(g) => format!("legs[{}]", g.leg()),
                _ => "legs".to_string(),
            };
            keys.error(path, &key, e.to_string())
        })?;
        let camera = match record.camera {
            None => None,
            Some(c) => {
                let rotation = so3::from_wxyz(c.r_cb_wxyz)
                    .ok_or_else(|| keys.error(path, "camera.r_cb_wxyz", "`r_cb_wxyz` is not a unit quaternion"))?;
                if !c.t_cb_m.iter().all(|x| x.is_finite()) {
                    return Err(keys.error(path, "camera.t_cb_m", "`t_cb_m` is not finite"));
                }
                Some(CameraRegistration { rotation, translation: Vector3::from(c.t_cb_m) })
            }
        };
        let mut markers = Vec::with_capacity(record.markers.len());
        for (k, m) in record.markers.into_iter().enumerate() {
            let finite = m.position_m.iter().chain(m.std_error_m.iter().flatten()).all(|x| x.is_finite());
            if !finite {
                return Err(keys.error(path, &format!("markers[{k}]"), "marker position or its error is not finite"));
            }
            if m.name.is_empty() || markers.iter().any(|o: &MarkerPosition| o.name == m.name) {
                return Err(keys.error(
                    path,
                    &format!("markers[{k}]"),
                    format!("marker name `{}` is empty or repeated", m.name),
                ));
            }
            markers.push(MarkerPosition {
                name: m.name,
                position: Vector3::from(m.position_m),
                std_error: m.std_error_m.map(Vector3::from),
            });
        }
        if record.latency_s.is_some_and(|l| !l.is_finite()) {
            return Err(keys.error(path, "latency_s", "`latency_s` is not finite"));
        }
        Ok(Parameters {
            source: record.source,
            model: record.model,
            legs,
            camera,
            markers,
            latency_s: record.latency_s,
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
                })
                .collect(),
            camera: self
                .camera
                .map(|c| CameraRecord { r_cb_wxyz: so3::to_wxyz(&c.rotation), t_cb_m: c.translation.into() }),
            markers: self
                .markers
                .iter()
                .map(|m| MarkerRecord {
                    name: m.name.clone(),
                    position_m: m.position.into(),
                    std_error_m: m.std_error.map(Into::into),
                })
                .collect(),
            latency_s: self.latency_s,
            fit: self.fit.clone(),
        };
        let body = serde_yaml::to_string(&record).expect("parameters serialise to YAML");
        format!(
            "# spmcal parameters of a spherical parallel manipulator (conventions: shared/DESIGN.md).\n\
             # Per leg: actuated axis u and zero direction z in B, link angles alpha1/alpha2, platform\n\
             # axis v0 in P, encoder offset delta (phi = theta + delta). Camera: x_C = R_CB x_B + t_CB.\n\
             # Markers (when fitted): positions in P, metres.\n{body}"
        )
    }

    /// Write the file atomically.
    ///
    /// # Errors
    /// A [`FileError`] when the file cannot be written; an existing file is then left unchanged.
    #[cfg(feature = "full")]
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        write_atomic(path, self.to_yaml().as_bytes())
    }
}
