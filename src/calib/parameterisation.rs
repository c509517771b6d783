//! The parameter vector of the fit and its gauge.
//!
//! Orientation data cannot tell a rotation of the base frame B (carried by `R_CB`) nor a rotation
//! of the platform frame P (carried by every `v0_i`, and by the reference rotation `A`) from the
//! mechanism: 6 directions that any parameterisation must fix. spmcal fixes them by defining B and
//! P through the first two legs: `u_1` and `v0_1` are held at their nominal values, and `u_2`,
//! `v0_2` may only turn within the plane they span with `u_1`, `v0_1` (one tilt each). `u_3` and
//! `v0_3` tilt freely (two each). When `u_1` and `u_2` (nearly) coincide — a coaxial SPM such as
//! Orbita3d — their plane is undefined and cannot fix B's turn about `u_1`; that turn then moves
//! with the encoder offsets (it turns every zero direction), so leg 1's offset `δ_1` is held at
//! its initial value instead and `u_2` tilts freely. The identifiability analysis confirms that no
//! null direction is left, for either geometry (tests/calibration.rs, tests/general_spm.rs).
//!
//! Every parameter is measured from its initial value, so that bounds are boxes. Angles (radians):
//! per leg the axis tilts (tangent coordinates of the rotation vector that carries the nominal
//! axis), `α1`, `α2`, `δ`, and the joint scale `s` (dimensionless); the platform's sag (radians
//! per unit of the gravity torque's arm, `Spm::sagged`); then the camera rotation `R_CB = exp(c) R_CB⁰` and, at the orientation
//! level, the reference rotation `A = exp(a) A⁰` (see `orientation_residuals.rs`). The marker level
//! has instead of `A` the camera translation `t_CB` and the markers' positions in P (metres), and
//! for a free-motion recording the camera's latency (seconds) and its clock's rate difference
//! (a fraction).

use nalgebra::{DVector, Rotation3, Vector3};

use super::config::{Bounds, Group};
use crate::math::so3;
use crate::model::{CameraModel, CameraTerm, LegGeometry, Rig, RigTerm};

/// What one entry of the parameter vector is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Tilt `k` of the actuated axis of a leg (0-based legs).
    ActuatedTilt {
        /// Leg index (0-based).
        leg: usize,
        /// Which of the two tangent directions (0 or 1).
        k: usize,
    },
    /// Proximal link angle α1 of a leg.
    Alpha1 {
        /// Leg index (0-based).
        leg: usize,
    },
    /// Distal link angle α2 of a leg.
    Alpha2 {
        /// Leg index (0-based).
        leg: usize,
    },
    /// Encoder offset δ of a leg.
    Offset {
        /// Leg index (0-based).
        leg: usize,
    },
    /// Joint scale `s` of a leg (`φ = sθ + δ`), from its start (dimensionless).
    Scale {
        /// Leg index (0-based).
        leg: usize,
    },
    /// The platform's sag under its weight, radians per unit of the gravity torque's arm, from
    /// its start ([`crate::model::Spm::sagged`]).
    PlatformSag,
    /// Tilt `k` of the platform axis `v0` of a leg.
    PlatformTilt {
        /// Leg index (0-based).
        leg: usize,
        /// Which of the two tangent directions (0 or 1).
        k: usize,
    },
    /// Component `k` of the camera rotation `R_CB` (rotation vector).
    Camera {
        /// Axis 0, 1 or 2.
        k: usize,
    },
    /// Component `k` of the reference-pose orientation (rotation vector).
    Reference {
        /// Axis 0, 1 or 2.
        k: usize,
    },
    /// Component `k` of the camera translation `t_CB` (m).
    Translation {
        /// Axis 0, 1 or 2.
        k: usize,
    },
    /// The camera's latency behind the encoders, `τ − τ⁰` (s; free-motion recordings): at the
    /// encoders' time 0 when the clock rate is a parameter too.
    Latency,
    /// The camera clock's rate difference as the drift it makes over the recording,
    /// `ρ·10⁻⁶·T` (s; `T` = [`Parameterisation::clock_rate_span_s`]; free-motion recordings): a
    /// capture stamped `t` was taken at `(t − τ) / (1 + ρ·10⁻⁶)` on the encoders' clock.
    ClockRate,
    /// A term of the camera model, from its start (dimensionless).
    CameraTerm {
        /// Which term.
        term: CameraTerm,
    },
    /// A term of a pixel session's camera rig, from the file's value.
    Rig {
        /// Which term.
        term: RigTerm,
    },
    /// Component `k` of marker `marker`'s position in P (m).
    Marker {
        /// Marker index (as in the session's `markers`).
        marker: usize,
        /// Axis 0, 1 or 2.
        k: usize,
    },
}

impl Kind {
    /// The config group that freezes this parameter.
    pub fn group(self) -> Group {
        match self {
            Kind::ActuatedTilt { .. } => Group::ActuatedAxes,
            Kind::Alpha1 { .. } => Group::ProximalAngles,
            Kind::Alpha2 { .. } => Group::DistalAngles,
            Kind::Offset { .. } => Group::JointOffsets,
            Kind::Scale { .. } => Group::JointScales,
            Kind::PlatformSag => Group::PlatformSag,
            Kind::PlatformTilt { .. } => Group::PlatformAxes,
            Kind::Camera { .. } => Group::CameraRotation,
            Kind::Reference { .. } => Group::ReferenceRotation,
            Kind::Translation { .. } => Group::CameraTranslation,
            Kind::Marker { .. } => Group::MarkerPositions,
            Kind::Latency => Group::Latency,
            Kind::ClockRate => Group::ClockRate,
            Kind::CameraTerm { .. } => Group::CameraModel,
            Kind::Rig { .. } => Group::CameraRig,
        }
    }

    /// The leg a mechanism parameter belongs to.
    pub fn leg(self) -> Option<usize> {
        match self {
            Kind::ActuatedTilt { leg, .. }
            | Kind::Alpha1 { leg }
            | Kind::Alpha2 { leg }
            | Kind::Offset { leg }
            | Kind::Scale { leg }
            | Kind::PlatformTilt { leg, .. } => Some(leg),
            Kind::PlatformSag
            | Kind::Camera { .. }
            | Kind::Reference { .. }
            | Kind::Translation { .. }
            | Kind::Marker { .. }
            | Kind::CameraTerm { .. }
            | Kind::Rig { .. }
            | Kind::Latency
            | Kind::ClockRate => None,
        }
    }

    /// A parameter of the mechanism: it moves the platform at given joint readings (a leg's, or
    /// the platform's sag).
    pub(crate) fn moves_platform(self) -> bool {
        self.leg().is_some() || self == Kind::PlatformSag
    }
}

/// One parameter: what it is, its name, and its physical bound (|value| ≤ bound, in the
/// parameter's unit).
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// What the entry is.
    pub kind: Kind,
    /// Its name in reports, e.g. `leg3.u_tilt1`.
    pub name: String,
    /// Its physical bound: radians, metres for a marker position, seconds for the latency.
    pub bound: Option<f64>,
}

/// The parameterisation around an initial geometry and registration.
#[derive(Debug, Clone)]
pub struct Parameterisation {
    /// The geometry at `x = 0`.
    pub initial: [LegGeometry; 3],
    /// The platform's sag at `x = 0` (radians per unit of arm).
    pub sag0: f64,
    /// Camera rotation at `x = 0`.
    pub camera0: Rotation3<f64>,
    /// Reference-pose orientation at `x = 0`.
    pub reference0: Rotation3<f64>,
    /// Rotation directions that tilt `u_i` (0, 1 or 2 of them).
    pub actuated_dirs: [Vec<Vector3<f64>>; 3],
    /// Rotation directions that tilt `v0_i` (0, 1 or 2 of them).
    pub platform_dirs: [Vec<Vector3<f64>>; 3],
    /// Camera translation `t_CB` at `x = 0` (marker level; zero otherwise).
    pub translation0: Vector3<f64>,
    /// Marker positions in P at `x = 0` (marker level; empty otherwise).
    pub markers0: Vec<Vector3<f64>>,
    /// Camera latency at `x = 0` (s; free-motion recordings): always 0, the latency entry is the
    /// latency itself, so that its bound is `±latency_bound_s` whatever the start.
    pub latency0: f64,
    /// Where the fit starts the latency (s): the config's `latency_s`.
    pub latency_start: f64,
    /// Where the fit starts (or holds) the camera clock's rate difference (ppm): the config's
    /// `clock_rate_ppm`.
    pub clock_rate_start_ppm: f64,
    /// The span `T` (s) over which the clock-rate entry is the drift: the entry is `ρ·10⁻⁶·T`, so
    /// that its standard error is of the latency's size (a fraction's would be a thousand times
    /// smaller than any other parameter's, and the trust region, in the parameters' own units,
    /// would let it roam over many standard errors where the cost is rough).
    pub clock_rate_span_s: f64,
    /// The camera model at `x = 0` (marker level; a perfect camera otherwise): its kind is the
    /// model fitted, its values where the fit starts.
    pub camera_model0: CameraModel,
    /// A pixel session's rig at `x = 0` (`cameras.yaml`): observations are pixels, predicted
    /// through the rig at `x` (`rig_terms.rs`).
    pub rig0: Option<std::sync::Arc<Rig>>,
    /// One entry per parameter.
    pub entries: Vec<Entry>,
}

/// Below this sine of the angle between `u_1` and `u_2` (5.7°) their plane fixes B's turn about
/// `u_1` poorly (a turn ε moves `u_2` by only ε·sine), and exactly not at all for a coaxial SPM:
/// leg 1's encoder offset, which that turn moves one for one, fixes it instead.
const COAXIAL_SINE: f64 = 0.1;

/// Two unit vectors orthogonal to `a` and to each other.
fn tangent_basis(a: &Vector3<f64>, hint: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let e1 = (hint - a * a.dot(hint)).normalize();
    [e1, a.cross(&e1)]
}

impl Parameterisation {
    /// The parameterisation around `initial` geometry, camera and reference rotations, with the config's bounds.
    pub fn new(
        initial: [LegGeometry; 3],
        camera0: Rotation3<f64>,
        reference0: Rotation3<f64>,
        bounds: &Bounds,
    ) -> Self {
        let g = &initial;
        let in_plane = |a: &Vector3<f64>, b: &Vector3<f64>| vec![a.cross(b).normalize()];
        let coaxial = g[0].u.cross(&g[1].u).norm() < COAXIAL_SINE;
        let second = if coaxial { tangent_basis(&g[1].u, &g[1].z).to_vec() } else { in_plane(&g[0].u, &g[1].u) };
        let actuated_dirs = [Vec::new(), second, tangent_basis(&g[2].u, &g[2].z).to_vec()];
        let platform_dirs = [Vec::new(), in_plane(&g[0].v0, &g[1].v0), tangent_basis(&g[2].v0, &g[0].v0).to_vec()];
        let (tilt, angle, offset) = (
            bounds.axis_tilt_deg.to_radians(),
            bounds.link_angle_deg.to_radians(),
            bounds.joint_offset_deg.to_radians(),
        );
        let mut entries = Vec::new();
        let mut push = |kind, name: String, bound| entries.push(Entry { kind, name, bound });
        for leg in 0..3 {
            let n = leg + 1;
            let tilt_names = |axis: &str, count: usize| -> Vec<String> {
                match count {
                    1 => vec![format!("leg{n}.{axis}_tilt")],
                    _ => (1..=count).map(|k| format!("leg{n}.{axis}_tilt{k}")).collect(),
                }
            };
            for (k, name) in tilt_names("u", actuated_dirs[leg].len()).into_iter().enumerate() {
                push(Kind::ActuatedTilt { leg, k }, name, Some(tilt));
            }
            push(Kind::Alpha1 { leg }, format!("leg{n}.alpha1"), Some(angle));
            push(Kind::Alpha2 { leg }, format!("leg{n}.alpha2"), Some(angle));
            if !(coaxial && leg == 0) {
                push(Kind::Offset { leg }, format!("leg{n}.delta"), Some(offset));
            }
            push(Kind::Scale { leg }, format!("leg{n}.scale"), Some(bounds.joint_scale));
            for (k, name) in tilt_names("v0", platform_dirs[leg].len()).into_iter().enumerate() {
                push(Kind::PlatformTilt { leg, k }, name, Some(tilt));
            }
        }
        push(Kind::PlatformSag, "platform.sag".into(), Some(crate::model::MAX_PLATFORM_SAG));
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            push(Kind::Camera { k }, format!("camera.rotation_{axis}"), None);
        }
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            push(Kind::Reference { k }, format!("reference.rotation_{axis}"), None);
        }
        Parameterisation {
            initial,
            sag0: 0.0,
            camera0,
            reference0,
            actuated_dirs,
            platform_dirs,
            translation0: Vector3::zeros(),
            markers0: Vec::new(),
            latency0: 0.0,
            latency_start: 0.0,
            clock_rate_start_ppm: 0.0,
            clock_rate_span_s: 1.0,
            camera_model0: CameraModel::rigid(),
            rig0: None,
            entries,
        }
    }

    /// The marker-level parameterisation: the mechanism (gauge-fixed as in [`Self::new`]), the
    /// camera registration `R_CB = exp(c) R_CB⁰`, `t_CB = t⁰ + Δt`, and every marker's position
    /// `p_k = p_k⁰ + Δp_k` in P (named after `names`), and the terms of `camera_model` (its kind's,
    /// starting at its values, within `bounds.camera_term`; none for a rigid camera). No reference
    /// rotation: every observation is compared with the model directly. The one constructor of
    /// the marker-level problem (the fit, `compare`, `plan` and the nominal poses all use it).
    pub fn for_markers(
        initial: [LegGeometry; 3],
        camera0: &crate::model::CameraRegistration,
        markers0: &[Vector3<f64>],
        names: &[String],
        camera_model: CameraModel,
        bounds: &Bounds,
    ) -> Self {
        let mut p = Parameterisation::new(initial, camera0.rotation, Rotation3::identity(), bounds);
        p.entries.retain(|e| !matches!(e.kind, Kind::Reference { .. }));
        p.translation0 = camera0.translation;
        p.markers0 = markers0.to_vec();
        let bound = Some(bounds.marker_position_m);
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            p.entries.push(Entry { kind: Kind::Translation { k }, name: format!("camera.t_{axis}"), bound: None });
        }
        for (marker, name) in names.iter().enumerate() {
            for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                let entry = Entry { kind: Kind::Marker { marker, k }, name: format!("{name}.{axis}"), bound };
                p.entries.push(entry);
            }
        }
        p.with_camera_model(camera_model, bounds.camera_term)
    }

    /// The same parameterisation with a rigid body's frame (named `body`) as parameters: its
    /// rotation `A = exp(a) A⁰` (P → body frame) stands in the reference rotation's entries, its
    /// origin is the marker-level's marker 0.
    pub(crate) fn with_body_frame(mut self, a0: Rotation3<f64>, body: &str) -> Self {
        self.reference0 = a0;
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let entry = Entry { kind: Kind::Reference { k }, name: format!("{body}.rotation_{axis}"), bound: None };
            self.entries.push(entry);
        }
        self
    }

    /// The same parameterisation with the camera latency as a parameter, started at `start` and
    /// bounded by `bound` either side of zero (s).
    pub fn with_latency(mut self, start: f64, bound: f64) -> Self {
        self.latency_start = start;
        self.entries.push(Entry { kind: Kind::Latency, name: "camera.latency".into(), bound: Some(bound) });
        self
    }

    /// The same parameterisation with the camera clock's rate difference as a parameter, started
    /// at `start_ppm` and bounded by `bound_ppm` either side of zero; the entry is the drift over
    /// `span_s` (the recording's span, at least 1 s), `ρ·10⁻⁶·T`.
    pub(crate) fn with_clock_rate(mut self, start_ppm: f64, bound_ppm: f64, span_s: f64) -> Self {
        self.clock_rate_start_ppm = start_ppm;
        self.clock_rate_span_s = span_s.max(1.0);
        let bound = Some(bound_ppm * 1e-6 * self.clock_rate_span_s);
        let entry = Entry { kind: Kind::ClockRate, name: "camera.clock_rate".into(), bound };
        self.entries.push(entry);
        self
    }

    /// The same parameterisation with the terms of `start`'s camera model as parameters, started
    /// at its values and bounded by `bound` either side of them.
    fn with_camera_model(mut self, start: CameraModel, bound: f64) -> Self {
        self.camera_model0 = start;
        for term in start.kind.terms() {
            let entry = Entry {
                kind: Kind::CameraTerm { term: *term },
                name: format!("camera.{}", term.name()),
                bound: Some(bound),
            };
            self.entries.push(entry);
        }
        self
    }

    /// The camera model at `x`.
    pub fn camera_model(&self, x: &DVector<f64>) -> CameraModel {
        self.entries.iter().enumerate().fold(self.camera_model0, |m, (i, e)| match e.kind {
            Kind::CameraTerm { term } => m.with(term, self.camera_model0.value(term) + x[i], None),
            _ => m,
        })
    }

    /// Whether parameter `i` sits at its bound at `x` (within a millionth of it): the data want it
    /// further, so it has no standard error.
    pub(crate) fn at_bound(&self, x: &DVector<f64>, i: usize) -> bool {
        self.entries[i].bound.is_some_and(|b| x[i].abs() >= b * (1.0 - 1e-6))
    }

    /// The start of the fit: every parameter at its initial value, the latency at its start.
    pub fn start(&self) -> DVector<f64> {
        let mut x = DVector::zeros(self.len());
        if let Some(i) = self.entries.iter().position(|e| e.kind == Kind::Latency) {
            x[i] = self.latency_start;
        }
        if let Some(i) = self.entries.iter().position(|e| e.kind == Kind::ClockRate) {
            x[i] = self.clock_rate_start_ppm * 1e-6 * self.clock_rate_span_s;
        }
        x
    }

    /// The camera clock's rate difference at `x` (ppm; the start without the parameter).
    pub fn clock_rate_ppm(&self, x: &DVector<f64>) -> f64 {
        match self.entries.iter().position(|e| e.kind == Kind::ClockRate) {
            Some(i) => x[i] / self.clock_rate_span_s * 1e6,
            None => self.clock_rate_start_ppm,
        }
    }

    /// The camera clock at `x`: the latency at the encoders' time 0 (s) and the rate difference (ppm).
    pub(crate) fn clock(&self, x: &DVector<f64>) -> crate::dataset::Clock {
        crate::dataset::Clock { latency_s: self.latency(x), rate_ppm: self.clock_rate_ppm(x) }
    }

    /// The camera latency at `x` (s).
    pub fn latency(&self, x: &DVector<f64>) -> f64 {
        self.latency0 + self.value(x, Kind::Latency)
    }

    /// `t_CB` at `x`.
    pub fn translation(&self, x: &DVector<f64>) -> Vector3<f64> {
        self.translation0 + Vector3::from_fn(|k, _| self.value(x, Kind::Translation { k }))
    }

    /// The position of marker `marker` in P at `x`.
    pub fn marker(&self, x: &DVector<f64>, marker: usize) -> Vector3<f64> {
        self.markers0[marker] + Vector3::from_fn(|k, _| self.value(x, Kind::Marker { marker, k }))
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// No parameters at all.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Whether leg 1's encoder offset, not the plane of `u_1` and `u_2`, fixes B's turn about
    /// `u_1` (a coaxial SPM: `u_2` then tilts freely).
    fn offset_fixes_base_turn(&self) -> bool {
        self.actuated_dirs[1].len() == 2
    }

    /// The second direction that, with `u_1`, defines B in this gauge: `u_2`, or for a coaxial
    /// SPM leg 1's zero direction (where `w_1` points at reading 0).
    fn base_pair(&self, legs: &[LegGeometry; 3]) -> (Vector3<f64>, Vector3<f64>) {
        let g = &legs[0];
        match self.offset_fixes_base_turn() {
            true => (g.u, g.zero_direction()),
            false => (g.u, legs[1].u),
        }
    }

    /// Rotation vector of the tilt of an axis from its parameters.
    fn tilt_vector(
        &self,
        x: &DVector<f64>,
        dirs: &[Vector3<f64>],
        matches: impl Fn(Kind) -> Option<usize>,
    ) -> Vector3<f64> {
        self.entries.iter().enumerate().filter_map(|(i, e)| matches(e.kind).map(|k| dirs[k] * x[i])).sum()
    }

    /// Rotation vectors `(φ_u, φ_v0)` of leg `leg`'s axis tilts.
    pub fn tilts(&self, x: &DVector<f64>, leg: usize) -> (Vector3<f64>, Vector3<f64>) {
        let u = self.tilt_vector(x, &self.actuated_dirs[leg], |kind| match kind {
            Kind::ActuatedTilt { leg: l, k } if l == leg => Some(k),
            _ => None,
        });
        let v = self.tilt_vector(x, &self.platform_dirs[leg], |kind| match kind {
            Kind::PlatformTilt { leg: l, k } if l == leg => Some(k),
            _ => None,
        });
        (u, v)
    }

    /// Where the fit starts the platform's sag (radians per unit of arm): a parameters file's.
    pub(crate) fn with_platform_sag(mut self, sag0: f64) -> Self {
        self.sag0 = sag0;
        self
    }

    /// The platform's sag at `x` (radians per unit of arm).
    pub fn platform_sag(&self, x: &DVector<f64>) -> f64 {
        self.sag0 + self.value(x, Kind::PlatformSag)
    }

    /// The mechanism at `x`: its legs ([`Self::legs`]) and its platform's sag.
    ///
    /// # Errors
    /// The [`SpmError`](crate::model::SpmError) of a geometry or a sag the mechanism cannot have.
    pub fn spm(&self, x: &DVector<f64>) -> Result<crate::model::Spm, crate::model::SpmError> {
        crate::model::Spm::new(self.legs(x))?.with_platform_sag(self.platform_sag(x))
    }

    fn value(&self, x: &DVector<f64>, kind: Kind) -> f64 {
        self.entries.iter().position(|e| e.kind == kind).map_or(0.0, |i| x[i])
    }

    /// The leg geometry at `x`: tilted axes, `z` re-orthogonalised against the moved `u`.
    pub fn legs(&self, x: &DVector<f64>) -> [LegGeometry; 3] {
        std::array::from_fn(|leg| {
            let g = &self.initial[leg];
            let (phi_u, phi_v) = self.tilts(x, leg);
            let u = so3::exp(&phi_u) * g.u;
            LegGeometry {
                u,
                z: (g.z - u * g.z.dot(&u)).normalize(),
                alpha1: g.alpha1 + self.value(x, Kind::Alpha1 { leg }),
                alpha2: g.alpha2 + self.value(x, Kind::Alpha2 { leg }),
                v0: so3::exp(&phi_v) * g.v0,
                delta: g.delta + self.value(x, Kind::Offset { leg }),
                scale: g.scale + self.value(x, Kind::Scale { leg }),
                home_branch: g.home_branch,
            }
        })
    }

    /// Rotation vectors of the camera and reference rotations.
    pub fn registration_vectors(&self, x: &DVector<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let c = Vector3::from_fn(|k, _| self.value(x, Kind::Camera { k }));
        let a = Vector3::from_fn(|k, _| self.value(x, Kind::Reference { k }));
        (c, a)
    }

    /// `R_CB` at `x`.
    pub fn camera(&self, x: &DVector<f64>) -> Rotation3<f64> {
        so3::exp(&self.registration_vectors(x).0) * self.camera0
    }

    /// `A` at `x`.
    pub fn reference(&self, x: &DVector<f64>) -> Rotation3<f64> {
        so3::exp(&self.registration_vectors(x).1) * self.reference0
    }

    /// The parameter vector that reproduces `legs` (already in this gauge) and the rotations:
    /// used to express a known truth in the fit's coordinates.
    pub fn coordinates(
        &self,
        legs: &[LegGeometry; 3],
        camera: &Rotation3<f64>,
        reference: &Rotation3<f64>,
    ) -> DVector<f64> {
        let mut x = DVector::zeros(self.len());
        let (c, a) = (so3::log(&(camera * self.camera0.inverse())), so3::log(&(reference * self.reference0.inverse())));
        for (i, e) in self.entries.iter().enumerate() {
            x[i] = match e.kind {
                Kind::ActuatedTilt { leg, k } => {
                    tilt_between(&self.initial[leg].u, &legs[leg].u).dot(&self.actuated_dirs[leg][k])
                }
                Kind::PlatformTilt { leg, k } => {
                    tilt_between(&self.initial[leg].v0, &legs[leg].v0).dot(&self.platform_dirs[leg][k])
                }
                Kind::Alpha1 { leg } => legs[leg].alpha1 - self.initial[leg].alpha1,
                Kind::Alpha2 { leg } => legs[leg].alpha2 - self.initial[leg].alpha2,
                Kind::Offset { leg } => {
                    // The offset is measured from this parameterisation's own z (re-orthogonalised
                    // nominal z), so compare the zero directions `cos δ z + sin δ (u × z)` themselves.
                    let g = &legs[leg];
                    let zero = g.zero_direction();
                    let z = (self.initial[leg].z - g.u * self.initial[leg].z.dot(&g.u)).normalize();
                    let y = g.u.cross(&z);
                    zero.dot(&y).atan2(zero.dot(&z)) - self.initial[leg].delta
                }
                Kind::Scale { leg } => legs[leg].scale - self.initial[leg].scale,
                // The sag is set by the caller that knows it (a simulator's truth).
                Kind::PlatformSag => 0.0,
                Kind::Camera { k } => c[k],
                Kind::Reference { k } => a[k],
                // `t_CB` and the markers are set by `TruthInGauge::for_markers`; the latency stays 0.
                Kind::Translation { .. }
                | Kind::Marker { .. }
                | Kind::Latency
                | Kind::ClockRate
                | Kind::CameraTerm { .. }
                | Kind::Rig { .. } => 0.0,
            };
        }
        x
    }
}

/// The rotation vector of the shortest rotation carrying unit vector `a` onto `b`.
fn tilt_between(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let axis = a.cross(b);
    let s = axis.norm();
    if s < 1e-300 {
        return Vector3::zeros();
    }
    axis * (s.atan2(a.dot(b)) / s)
}

/// A true parameter set moved into the gauge of `p`: the base frame rotated by `G` so that `u_1`
/// and the plane of `u_1, u_2` (for a coaxial SPM: leg 1's zero direction) are nominal, the
/// platform frame by `H` likewise for `v0_1, v0_2`.
#[derive(Debug, Clone)]
pub struct TruthInGauge {
    /// The true parameters in the fit's coordinates (camera rotation included).
    pub x: DVector<f64>,
    /// Base-frame change `G` (true B → fit's B).
    pub base: Rotation3<f64>,
    /// Platform-frame change `H` (true P → fit's P).
    pub platform: Rotation3<f64>,
}

impl TruthInGauge {
    /// `legs`, `camera` (`R_CB`) and the true orientation of the reference pose, expressed in `p`'s gauge.
    pub fn new(
        p: &Parameterisation,
        legs: &[LegGeometry; 3],
        camera: &Rotation3<f64>,
        reference_pose: &Rotation3<f64>,
    ) -> Self {
        let n = &p.initial;
        let ((a, b), (c, d)) = (p.base_pair(legs), p.base_pair(n));
        let base = so3::carry(&a, &b, &c, &d);
        let platform = so3::carry(&legs[0].v0, &legs[1].v0, &n[0].v0, &n[1].v0);
        let moved = legs.map(|g| LegGeometry { u: base * g.u, z: base * g.z, v0: platform * g.v0, ..g });
        let camera = camera * base.inverse();
        // A = R_CB R_0 (P → C at the reference pose); in the new frames R_0' = G R_0 Hᵀ.
        let reference = camera * (base * reference_pose * platform.inverse());
        TruthInGauge { x: p.coordinates(&moved, &camera, &reference), base, platform }
    }

    /// A true marker-level parameter set (legs, camera registration and model, marker positions in
    /// the true P) expressed in `p`'s gauge (a [`Parameterisation::for_markers`]): `R_CB Gᵀ`,
    /// `t_CB`, `H p_k`, the camera model's terms as they are (a simulated camera's `K` is in the
    /// fit's gauge: symmetric, lateral x scale 1).
    pub fn for_markers(
        p: &Parameterisation,
        legs: &[LegGeometry; 3],
        camera: &crate::model::CameraRegistration,
        camera_model: &CameraModel,
        markers: &[Vector3<f64>],
    ) -> Self {
        let mut truth = TruthInGauge::new(p, legs, &camera.rotation, &Rotation3::identity());
        for (i, e) in p.entries.iter().enumerate() {
            match e.kind {
                Kind::Translation { k } => truth.x[i] = camera.translation[k] - p.translation0[k],
                Kind::Marker { marker, k } => {
                    truth.x[i] = (truth.platform * markers[marker])[k] - p.markers0[marker][k]
                }
                Kind::CameraTerm { term } => truth.x[i] = camera_model.value(term) - p.camera_model0.value(term),
                _ => {}
            }
        }
        truth
    }

    /// A true orientation `R` (true P → true B) in the fit's frames: `G R Hᵀ`.
    pub fn orientation(&self, r: &Rotation3<f64>) -> Rotation3<f64> {
        self.base * r * self.platform.inverse()
    }
}
