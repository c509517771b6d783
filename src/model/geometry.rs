//! SPM geometry: the per-leg parameters of docs/conventions.md and the validated, cached form
//! that the kinematics evaluate.
//!
//! Leg i (conventions of docs/conventions.md): actuated axis `u`, joint zero direction `z ⟂ u`,
//! intermediate axis `w(θ) = cos α1 u + sin α1 (cos φ z + sin φ (u × z))` with `φ = sθ + δ`
//! (`s` the joint's scale, nominal 1),
//! platform axis `v = R v0`, and the loop closure `w(θ) · R v0 = cos α2`. Each leg closes the
//! loop on two branches, told apart by the sign of `(u × w) · v`; the working mode is the one
//! that contains home (`R = I`), so each leg carries the sign it has there.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Geometry of one leg: the parameters a calibration identifies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LegGeometry {
    /// Actuated (base) joint axis, in B.
    pub u: Vector3<f64>,
    /// Joint zero direction, in B, orthogonal to `u`.
    pub z: Vector3<f64>,
    /// Angle between `u` and the intermediate axis `w` (proximal link angle), radians.
    pub alpha1: f64,
    /// Angle between `w` and the platform axis `v` (distal link angle), radians.
    pub alpha2: f64,
    /// Platform joint axis, in P.
    pub v0: Vector3<f64>,
    /// Encoder zero offset: `φ = sθ + δ`, radians.
    pub delta: f64,
    /// The joint's scale `s` (`φ = sθ + δ`): how far the joint turns per radian of its reading —
    /// a transmission ratio's error, a capstan's effective radius. Nominal 1.
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// The leg's branch at home, which the working mode keeps.
    #[serde(default)]
    pub home_branch: HomeBranch,
}

/// A joint scale of 1 (what files written before scales existed mean).
fn unit_scale() -> f64 {
    1.0
}

/// The sign of `(u × w) · v` of a leg at home (`R = I`): which of its two inverse-kinematics
/// branches the working mode uses. Neither is special: the Agile Wrist's legs are negative,
/// Orbita3d's (as its makers define it) positive. A model's loader reads it from the model's
/// zero configuration; parameters files written before it existed read as negative.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HomeBranch {
    /// `(u × w) · v < 0` at home (the Agile Wrist's legs).
    #[default]
    Negative,
    /// `(u × w) · v > 0` at home (Orbita3d's legs).
    Positive,
}

impl HomeBranch {
    /// The branch on which `(u × w) · v` has the sign of `value` (zero counts as positive; a
    /// model refuses a home that close to a serial singularity anyway).
    pub fn of(value: f64) -> Self {
        if value < 0.0 { HomeBranch::Negative } else { HomeBranch::Positive }
    }

    /// `−1.0` or `+1.0`.
    pub fn sign(self) -> f64 {
        match self {
            HomeBranch::Negative => -1.0,
            HomeBranch::Positive => 1.0,
        }
    }
}

/// Why a geometry cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    #[error("leg {leg_number}: {what} is not finite", leg_number = .leg + 1)]
    /// A number is NaN or infinite.
    NotFinite {
        /// Leg index (0-based).
        leg: usize,
        /// Which quantity.
        what: &'static str,
    },
    #[error("leg {leg_number}: axis {what} has length {norm:.3e}; a joint axis must be a unit vector", leg_number = .leg + 1)]
    /// A joint axis is not a unit vector.
    NotUnit {
        /// Leg index (0-based).
        leg: usize,
        /// Which axis (`u`, `z`, `v0`).
        what: &'static str,
        /// Its length.
        norm: f64,
    },
    #[error("leg {leg_number}: zero direction z is not orthogonal to u (u·z = {dot:.3e})", leg_number = .leg + 1)]
    /// The zero direction is not orthogonal to the actuated axis.
    ZeroDirectionNotOrthogonal {
        /// Leg index (0-based).
        leg: usize,
        /// `u · z`.
        dot: f64,
    },
    #[error("leg {leg_number}: joint scale {value} is outside [{MIN_JOINT_SCALE}, {MAX_JOINT_SCALE}] (a scale is a ratio: 1.004 for a joint that turns 0.4 % further than its reading)", leg_number = .leg + 1)]
    /// A joint scale is outside the range a transmission error can make.
    ScaleOutOfRange {
        /// Leg index (0-based).
        leg: usize,
        /// The scale.
        value: f64,
    },
    #[error("leg {leg_number}: {what} = {value_deg:.4}° is outside (0°, 180°)", leg_number = .leg + 1)]
    /// A link angle is outside (0°, 180°).
    LinkAngleOutOfRange {
        /// Leg index (0-based).
        leg: usize,
        /// `alpha1` or `alpha2`.
        what: &'static str,
        /// Its value, degrees.
        value_deg: f64,
    },
}

/// Tolerance on unit length and orthogonality of axes read from files: loose enough for
/// axes printed with 9 significant digits, tight enough to catch a wrong axis.
pub(crate) const AXIS_TOLERANCE: f64 = 1e-6;

/// The smallest and largest joint scale a leg may have: a transmission ratio wrong by half is a
/// wrong gear or a wrong unit, not a calibration error (real ones are 0.1–1 %).
pub(crate) const MIN_JOINT_SCALE: f64 = 0.5;
/// See [`MIN_JOINT_SCALE`].
pub(crate) const MAX_JOINT_SCALE: f64 = 1.5;

impl GeometryError {
    /// The leg the error is about (0-based index; messages print it 1-based).
    pub fn leg(&self) -> usize {
        match self {
            GeometryError::NotFinite { leg, .. }
            | GeometryError::NotUnit { leg, .. }
            | GeometryError::ZeroDirectionNotOrthogonal { leg, .. }
            | GeometryError::LinkAngleOutOfRange { leg, .. }
            | GeometryError::ScaleOutOfRange { leg, .. } => *leg,
        }
    }
}

impl LegGeometry {
    /// The nominal leg `i` (0-based) of docs/conventions.md for cone angles `b`, `p` and link angles `α1`, `α2`.
    pub fn nominal(i: usize, base_cone: f64, platform_cone: f64, alpha1: f64, alpha2: f64) -> Self {
        let eta = 2.0 * std::f64::consts::PI * i as f64 / 3.0;
        let (se, ce) = eta.sin_cos();
        LegGeometry {
            u: Vector3::new(-se * base_cone.sin(), ce * base_cone.sin(), -base_cone.cos()),
            z: Vector3::new(ce, se, 0.0),
            alpha1,
            alpha2,
            v0: Vector3::new(-se * platform_cone.sin(), ce * platform_cone.sin(), platform_cone.cos()),
            delta: 0.0,
            scale: 1.0,
            home_branch: HomeBranch::Negative,
        }
    }

    /// Where the intermediate axis leans at reading 0, projected off `u`: `cos δ z + sin δ (u × z)`.
    pub fn zero_direction(&self) -> Vector3<f64> {
        self.z * self.delta.cos() + self.u.cross(&self.z) * self.delta.sin()
    }

    /// Check leg `leg` (0-based index) and normalise its axes.
    ///
    /// # Errors
    /// A [`GeometryError`] for a non-finite value, a non-unit axis, a zero direction not orthogonal to `u`, or a link angle outside (0°, 180°).
    pub fn validated(mut self, leg: usize) -> Result<Self, GeometryError> {
        for (what, v) in [("u", self.u), ("z", self.z), ("v0", self.v0)] {
            if !v.iter().all(|c| c.is_finite()) {
                return Err(GeometryError::NotFinite { leg, what });
            }
            let norm = v.norm();
            if (norm - 1.0).abs() > AXIS_TOLERANCE {
                return Err(GeometryError::NotUnit { leg, what, norm });
            }
        }
        for (what, value) in
            [("alpha1", self.alpha1), ("alpha2", self.alpha2), ("delta", self.delta), ("scale", self.scale)]
        {
            if !value.is_finite() {
                return Err(GeometryError::NotFinite { leg, what });
            }
        }
        if !(MIN_JOINT_SCALE..=MAX_JOINT_SCALE).contains(&self.scale) {
            return Err(GeometryError::ScaleOutOfRange { leg, value: self.scale });
        }
        for (what, value) in [("alpha1", self.alpha1), ("alpha2", self.alpha2)] {
            if value <= 0.0 || value >= std::f64::consts::PI {
                return Err(GeometryError::LinkAngleOutOfRange { leg, what, value_deg: value.to_degrees() });
            }
        }
        self.u.normalize_mut();
        self.v0.normalize_mut();
        let dot = self.u.dot(&self.z);
        if dot.abs() > AXIS_TOLERANCE {
            return Err(GeometryError::ZeroDirectionNotOrthogonal { leg, dot });
        }
        // Remove the tolerated residue exactly, so that the kinematics see an orthonormal pair.
        self.z = (self.z - self.u * dot).normalize();
        Ok(self)
    }
}

impl std::fmt::Display for HomeBranch {
    /// As the parameters file writes it: `negative` or `positive`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            HomeBranch::Negative => "negative",
            HomeBranch::Positive => "positive",
        })
    }
}

/// A leg prepared for fast evaluation (all trigonometry of the constants done once).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Leg {
    pub u: Vector3<f64>,
    pub z: Vector3<f64>,
    /// `u × z`, the direction of `dw/dφ` at `φ = 0`.
    pub y: Vector3<f64>,
    pub cos_a1: f64,
    pub sin_a1: f64,
    pub cos_a2: f64,
    pub sin_a2: f64,
    pub v0: Vector3<f64>,
    pub delta: f64,
    /// The joint's scale `s`: `φ = sθ + δ`.
    pub scale: f64,
    /// `−1` or `+1`: the sign of `(u × w) · v` in the working mode.
    pub sign: f64,
}

impl Leg {
    pub(crate) fn new(g: &LegGeometry) -> Self {
        Leg {
            u: g.u,
            z: g.z,
            y: g.u.cross(&g.z),
            cos_a1: g.alpha1.cos(),
            sin_a1: g.alpha1.sin(),
            cos_a2: g.alpha2.cos(),
            sin_a2: g.alpha2.sin(),
            v0: g.v0,
            delta: g.delta,
            scale: g.scale,
            sign: g.home_branch.sign(),
        }
    }

    /// The joint's angle `φ = sθ + δ` at reading `θ`.
    #[inline]
    pub(crate) fn phi(&self, theta: f64) -> f64 {
        self.scale * theta + self.delta
    }

    /// The reading `θ = (φ − δ) / s` at which the joint's angle is `φ` (taken in `(−π, π]` from
    /// the offset before the scale divides it).
    #[inline]
    pub(crate) fn reading(&self, phi: f64) -> f64 {
        crate::math::so3::wrap_angle(phi - self.delta) / self.scale
    }

    /// Intermediate axis `w(θ)` in B.
    #[inline]
    pub(crate) fn w(&self, theta: f64) -> Vector3<f64> {
        let (s, c) = self.phi(theta).sin_cos();
        self.u * self.cos_a1 + (self.z * c + self.y * s) * self.sin_a1
    }
}
