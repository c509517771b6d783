//! The ranges every number of the model's files must lie in (the parameters file, the URDF's
//! companion), checked at load and reported at the value's own line and key.
//!
//! | value | range | why |
//! |---|---|---|
//! | joint axes `u`, `z`, `v0` | finite; unit length within 1e-6 (`AXIS_TOLERANCE`); `z ⟂ u` within it | printed with 9+ digits, a unit vector is exact to 1e-9; a wrong axis is off by far more |
//! | link angles `alpha1_deg`, `alpha2_deg` | finite, in (0°, 180°) | an angle between two axes |
//! | encoder offsets `delta_deg`, `encoder_offsets_deg` | finite, within ±[`MAX_OFFSET_DEG`] | an angle; a turn either way is already every offset |
//! | positions (`t_cb_m`, marker positions, their standard errors) | finite, within [`MAX_POSITION_M`] of O | a joystick and a camera on a desk; beyond is a unit error |
//! | `r_cb_wxyz` | finite, unit within 1e-6 | as `so3::from_wxyz` accepts |
//! | `latency_s` | finite, within ±[`MAX_LATENCY_S`] | the latency bound a recording is loaded with |
//! | `clock_rate_ppm` | finite, within ±[`MAX_CLOCK_RATE_PPM`] | quartz clocks differ by tens of ppm; a thousand is a broken clock or a wrong unit |

use std::path::Path;

use crate::io::files::FileError;
use crate::io::yaml::KeyLines;

/// Largest distance (m) from the centre of rotation O of any position in the model's files (the
/// camera, the markers) and largest standard error of one: the mechanism is a desk joystick seen by
/// a camera a metre or so away. A position beyond is a unit error (millimetres written as metres:
/// 75 mm as `75` is 75 m), not a device.
pub(crate) const MAX_POSITION_M: f64 = 10.0;

/// Largest encoder offset (deg), either sign: a full turn; every offset is within ±180° modulo one.
pub(crate) const MAX_OFFSET_DEG: f64 = 360.0;

/// Largest camera latency (s), either sign: the bound within which a free-motion recording is
/// searched for it when loaded (`StreamLimits::default().latency_bound_s`); a parameters file
/// with a larger one would drop most frames of any recording.
pub(crate) const MAX_LATENCY_S: f64 = 0.2;

/// Largest rate difference (ppm), either sign, of a camera's clock from the encoders': free-running
/// quartz clocks differ by tens of ppm (±100 ppm is a poor crystal's tolerance); a thousand is a
/// broken clock, or a rate written in another unit.
pub(crate) const MAX_CLOCK_RATE_PPM: f64 = 1000.0;

/// Largest departure of a camera model's term from a perfect camera's (a scale of 1 ± this, a
/// shear of this): a camera whose depths read half again too long is broken, not miscalibrated.
pub(crate) const MAX_CAMERA_TERM: f64 = 0.5;

/// Checks of one YAML file's values, each error at the line of the value's key.
pub(crate) struct Ranges<'a> {
    pub(crate) path: &'a Path,
    pub(crate) keys: &'a KeyLines,
}

impl Ranges<'_> {
    /// An error about the value at `key`, at its line.
    pub(crate) fn error(&self, key: &str, reason: impl Into<String>) -> FileError {
        self.keys.error(self.path, key, reason)
    }

    /// Every component finite; else an error at the first component that is not (`key[k]`).
    pub(crate) fn finite(&self, key: &str, what: &str, values: &[f64]) -> Result<(), FileError> {
        match values.iter().position(|v| !v.is_finite()) {
            Some(k) => Err(self.error(&format!("{key}[{k}]"), format!("{what}: component {k} is {}", values[k]))),
            None => Ok(()),
        }
    }

    /// A finite position within [`MAX_POSITION_M`] of O.
    pub(crate) fn position(&self, key: &str, what: &str, p: &[f64; 3]) -> Result<(), FileError> {
        self.finite(key, &format!("{what} is not finite"), p)?;
        let norm = p.iter().map(|c| c * c).sum::<f64>().sqrt();
        if norm > MAX_POSITION_M {
            let reason = format!("{what} is {norm} m from O; positions are metres, at most {MAX_POSITION_M} m");
            return Err(self.error(key, reason));
        }
        Ok(())
    }

    /// A finite encoder offset (deg) within ±[`MAX_OFFSET_DEG`].
    pub(crate) fn offset_deg(&self, key: &str, what: &str, value: f64) -> Result<(), FileError> {
        if !(value.is_finite() && value.abs() <= MAX_OFFSET_DEG) {
            let reason = format!("{what} = {value}° must be a finite angle within ±{MAX_OFFSET_DEG}°");
            return Err(self.error(key, reason));
        }
        Ok(())
    }
}
