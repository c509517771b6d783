//! The spherical parallel manipulator: inverse kinematics (closed form per leg),
//! forward displacement analysis by Newton tracking and by continuation from home,
//! Jacobians and singularity measures.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::geometry::{GeometryError, HomeBranch, Leg, LegGeometry};
use crate::math::so3;

/// Which of the two inverse-kinematics solutions of a leg, relative to its home branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Branch {
    /// The branch the leg has at home (`(u × w) · v` of its [`HomeBranch`] sign): the working mode.
    Working,
    /// The leg folded the other way.
    Other,
}

impl Branch {
    /// The sign of `(u × w) · v` on this branch of a leg whose home branch is `home`: `-` or `+`.
    pub fn sign_char(self, home: HomeBranch) -> char {
        match (self == Branch::Working) == (home == HomeBranch::Negative) {
            true => '-',
            false => '+',
        }
    }
}

/// Numerical settings of the forward displacement analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FdaSettings {
    /// Newton stops when every closure residual `|w·v − cos α2|` is below this.
    pub tolerance: f64,
    /// Newton iterations allowed per solve.
    pub max_iterations: u32,
    /// Smallest accepted conditioning index `1/κ_F` of the closure Jacobian (parallel singularity).
    pub min_conditioning: f64,
    /// Smallest accepted `|(u×w)·v| / sin α1` of any leg (serial singularity, branch ambiguity).
    pub min_branch_margin: f64,
    /// `track` refuses a solution farther than this (rad) from the previous orientation:
    /// a larger jump means the start was not in the basin of the tracked mode.
    pub max_track_jump: f64,
    /// Largest joint increment of one continuation step in `forward` (rad); the platform's
    /// predicted turn in one step is held below it times the conditioning index.
    pub continuation_step: f64,
}

impl Default for FdaSettings {
    fn default() -> Self {
        FdaSettings {
            // A few ulps of the cosines; Newton's quadratic convergence gets there in one more step.
            tolerance: 1e-14,
            max_iterations: 20,
            min_conditioning: 0.02,
            min_branch_margin: 0.02,
            max_track_jump: 0.35,
            continuation_step: 0.25,
        }
    }
}

/// Why an orientation has no working-mode joint solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IkError {
    #[error("orientation outside the workspace: leg {leg_number} cannot reach it (needs |cos| = {ratio:.6} > 1)", leg_number = .leg + 1)]
    /// A leg cannot reach the orientation.
    OutsideWorkspace {
        /// Leg index (0-based).
        leg: usize,
        /// |cos| the leg would need (> 1).
        ratio: f64,
    },
    #[error("orientation is not finite")]
    /// The orientation has non-finite entries.
    NotFinite,
    #[error(
        "leg {leg_number} is at a serial singularity: its platform axis lies {angle_deg:.2e}° from its actuated axis, so the joint angle is undetermined"
    , leg_number = .leg + 1)]
    /// A leg's platform axis lines up with its actuated axis.
    SerialSingularity {
        /// Leg index (0-based).
        leg: usize,
        /// Angle between the axes, degrees.
        angle_deg: f64,
    },
}

/// Below this sine of the angle between a leg's platform axis and its actuated axis, IK refuses:
/// the joint angle's sensitivity to the orientation is 1/sine, and rounding alone (1e-16) would
/// move it by more than 1e-10 rad.
pub(crate) const IK_SINGULAR_SINE: f64 = 1e-6;

/// Why the forward displacement analysis gave no trustworthy working-mode orientation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FdaError {
    #[error("joint readings are not finite")]
    /// A joint reading is NaN or infinite.
    NotFinite,
    #[error("Newton did not converge in {iterations} iterations (closure residual {residual:.3e})")]
    /// Newton did not converge.
    NotConverged {
        /// Iterations done.
        iterations: u32,
        /// Closure residual at the end.
        residual: f64,
    },
    #[error("pose at or near a parallel singularity (conditioning index {conditioning:.3e})")]
    /// The pose is at or near a parallel singularity.
    NearSingular {
        /// Conditioning index of `A` (0 = singular).
        conditioning: f64,
    },
    #[error(
        "leg {leg_number} is off its working branch (branch margin {margin:.3e}, below the working mode's minimum): at a serial singularity or beyond it"
    , leg_number = .leg + 1)]
    /// The solution left the working mode.
    LeftWorkingMode {
        /// Leg index (0-based).
        leg: usize,
        /// Its branch margin.
        margin: f64,
    },
    #[error("tracking jumped {jump_deg:.2}° from the previous orientation: start too far from the solution")]
    /// Tracking jumped further than a step can.
    JumpTooLarge {
        /// Angle of the jump, degrees.
        jump_deg: f64,
    },
}

/// Velocity relation `A ω = B θ̇` at a pose: `A` rows `(w_i × v_i)ᵀ`, `B = diag(s_i (u_i × w_i) · v_i)`
/// (`θ̇` the readings' rates, `s_i` the joints' scales).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jacobians {
    /// `A`, rows `(w_i × v_i)ᵀ`.
    pub a: Matrix3<f64>,
    /// `B = diag(s_i (u_i × w_i) · v_i)`.
    pub b: Matrix3<f64>,
}

impl Jacobians {
    /// `J = A⁻¹ B`, mapping joint rates to the MP angular velocity; `None` at a parallel singularity.
    pub fn forward(&self) -> Option<Matrix3<f64>> {
        self.a.try_inverse().map(|ai| ai * self.b)
    }

    /// Conditioning index `1/κ_F(A) = 3 / (‖A‖_F ‖A⁻¹‖_F)` in `[0, 1]`: 1 for a multiple of an
    /// orthogonal matrix, 0 at a parallel singularity (Angeles' dexterity measure).
    pub fn conditioning(&self) -> f64 {
        conditioning_index(&self.a)
    }
}

/// Conditioning index `1/κ_F(M) = 3 / (‖M‖_F ‖M⁻¹‖_F)` in `[0, 1]`: 1 for a multiple of an
/// orthogonal matrix, 0 when singular. The Frobenius condition number is Angeles' choice for
/// manipulator dexterity and costs one 3×3 inverse, which the haptic path computes anyway.
pub(crate) fn conditioning_index(m: &Matrix3<f64>) -> f64 {
    match m.try_inverse() {
        Some(inv) => (3.0 / (m.norm() * inv.norm())).min(1.0),
        None => 0.0,
    }
}

/// A spherical parallel manipulator with validated geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Spm {
    geometry: [LegGeometry; 3],
    pub(crate) legs: [Leg; 3],
    /// Joint readings at the home orientation `R = I` (working mode).
    home_joints: Vector3<f64>,
    /// Settings of the forward displacement analysis.
    pub settings: FdaSettings,
    /// The platform's sag under its weight, radians per unit of the gravity torque's arm (see
    /// [`Spm::sagged`]); 0 for a rigid mechanism.
    platform_sag: f64,
}

/// The largest platform sag a mechanism may have, radians per unit of arm (10°): beyond it the
/// platform is no longer the rigid mechanism's plus a small bend, and [`Spm::rigid`]'s fixed point
/// would contract slowly.
pub(crate) const MAX_PLATFORM_SAG: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// Why a geometry does not make a usable manipulator.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SpmError {
    #[error(transparent)]
    /// A leg's geometry is invalid.
    Geometry(#[from] GeometryError),
    #[error("the loop closure has no solution at home (R = I): {0}")]
    /// The mechanism cannot be assembled at home.
    NoHomeClosure(IkError),
    #[error(
        "the home pose (R = I) is near a parallel singularity: the conditioning index of the closure Jacobian is {conditioning:.3e}, below {minimum}; the platform could move with the actuators locked"
    )]
    /// The home pose is near a parallel singularity.
    HomeNearParallelSingularity {
        /// Conditioning index of `A` at home.
        conditioning: f64,
        /// The smallest accepted ([`FdaSettings::min_conditioning`]).
        minimum: f64,
    },
    #[error(
        "leg {leg_number} is near a serial singularity at home (R = I): |(u×w)·v| / sin α1 = {margin:.3e}, below {minimum}; its platform axis is nearly in the plane of its actuated and intermediate axes, so which branch is home is ambiguous"
    , leg_number = .leg + 1)]
    /// A leg is near a serial singularity at home: its home branch is ambiguous.
    HomeNearSerialSingularity {
        /// Leg index (0-based).
        leg: usize,
        /// `|(u×w)·v| / sin α1` at home.
        margin: f64,
        /// The smallest accepted ([`FdaSettings::min_branch_margin`]).
        minimum: f64,
    },
    #[error("platform axes v0 of legs {} and {} are parallel", .0 + 1, .1 + 1)]
    /// Two platform axes are parallel (leg indices, 0-based).
    ParallelPlatformAxes(usize, usize),
    #[error("the platform's sag must be finite and within ±10° per unit of arm (got {value_deg}°)")]
    /// The platform's sag is not finite or beyond 10° per unit of arm.
    PlatformSag {
        /// The sag given, degrees per unit of arm.
        value_deg: f64,
    },
}

impl Spm {
    /// Validate the three legs and prepare them; the home pose must be assemblable and regular.
    ///
    /// # Errors
    /// An [`SpmError`] for an invalid leg, parallel platform axes, or a home pose that cannot be assembled or is singular.
    pub fn new(geometry: [LegGeometry; 3]) -> Result<Self, SpmError> {
        let mut checked = geometry;
        for (i, g) in checked.iter_mut().enumerate() {
            *g = g.validated(i)?;
        }
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            if checked[i].v0.cross(&checked[j].v0).norm() < 1e-6 {
                return Err(SpmError::ParallelPlatformAxes(i, j));
            }
        }
        let mut spm = Spm {
            geometry: checked,
            legs: checked.map(|g| Leg::new(&g)),
            home_joints: Vector3::zeros(),
            settings: FdaSettings::default(),
            platform_sag: 0.0,
        };
        let home = Rotation3::identity();
        spm.home_joints = spm.ik_rigid(&home).map_err(SpmError::NoHomeClosure)?;
        spm.check_home()?;
        Ok(spm)
    }

    /// A home near a singularity cannot define the working mode: refuse it, naming the cause.
    fn check_home(&self) -> Result<(), SpmError> {
        let home = Rotation3::identity();
        let minimum = self.settings.min_branch_margin;
        let margins = self.branch_margins(&self.home_joints, &home);
        if let Some(leg) = (0..3).find(|&i| margins[i].abs() < minimum) {
            return Err(SpmError::HomeNearSerialSingularity { leg, margin: margins[leg].abs(), minimum });
        }
        let conditioning = self.jacobians(&self.home_joints, &home).conditioning();
        let minimum = self.settings.min_conditioning;
        if conditioning < minimum {
            return Err(SpmError::HomeNearParallelSingularity { conditioning, minimum });
        }
        Ok(())
    }

    /// The nominal Agile Wrist of docs/conventions.md: α1 = α2 = 90°, b = p = arctan √2.
    ///
    /// # Panics
    /// Never: the nominal geometry is valid (a test checks it).
    pub fn agile_wrist_nominal() -> Self {
        let cone = 2f64.sqrt().atan();
        let right = std::f64::consts::FRAC_PI_2;
        Spm::new([0, 1, 2].map(|i| LegGeometry::nominal(i, cone, cone, right, right)))
            .expect("the nominal Agile Wrist is a valid geometry")
    }

    /// The same mechanism with a platform that sags under its weight by `per_unit_rad` radians per
    /// unit of the gravity torque's arm ([`Spm::sagged`]).
    ///
    /// # Errors
    /// [`SpmError::PlatformSag`] for a sag that is not finite or beyond 10° per unit of arm.
    pub fn with_platform_sag(mut self, per_unit_rad: f64) -> Result<Self, SpmError> {
        if !(per_unit_rad.is_finite() && per_unit_rad.abs() <= MAX_PLATFORM_SAG) {
            return Err(SpmError::PlatformSag { value_deg: per_unit_rad.to_degrees() });
        }
        self.platform_sag = per_unit_rad;
        Ok(self)
    }

    /// The platform's sag, radians per unit of the gravity torque's arm (0: rigid).
    pub fn platform_sag(&self) -> f64 {
        self.platform_sag
    }

    /// Where the platform is when the rigid mechanism puts it at `rigid`: turned under its weight
    /// by `c (n × (−z))`, `c` the sag ([`Spm::platform_sag`]), `n = R z` the platform's axis and `z`
    /// the base's up (the gravity torque's arm: zero when the platform is level, one when it is
    /// horizontal). [`Spm::forward`] and [`Spm::track`] return this orientation; [`Spm::ik`] takes it.
    pub fn sagged(&self, rigid: &Rotation3<f64>) -> Rotation3<f64> {
        if self.platform_sag == 0.0 {
            return *rigid;
        }
        so3::exp(&(sag_arm(rigid) * self.platform_sag)) * rigid
    }

    /// The rigid mechanism's orientation whose [`Spm::sagged`] one is `observed` (the identity for
    /// a rigid mechanism): the fixed point of `R ← exp(−c·arm(R)) R_obs`, a contraction by `|c|`.
    /// The orientation [`Spm::jacobians`], [`Spm::branch_margins`] and [`Spm::ik_leg`] take.
    pub fn rigid(&self, observed: &Rotation3<f64>) -> Rotation3<f64> {
        if self.platform_sag == 0.0 {
            return *observed;
        }
        let mut r = *observed;
        for _ in 0..60 {
            let next = so3::exp(&(sag_arm(&r) * -self.platform_sag)) * observed;
            let step = so3::geodesic_angle(&next, &r);
            r = next;
            // Converged, or not a number (a non-finite orientation): either way, done.
            if step.is_nan() || step <= 1e-15 {
                break;
            }
        }
        r
    }

    /// The validated per-leg geometry.
    pub fn geometry(&self) -> &[LegGeometry; 3] {
        &self.geometry
    }

    /// Joint readings of the home orientation `R = I` in the working mode.
    pub fn home_joints(&self) -> Vector3<f64> {
        self.home_joints
    }

    /// Intermediate axes `w_i` for the joint readings.
    pub fn intermediate_axes(&self, joints: &Vector3<f64>) -> [Vector3<f64>; 3] {
        [0, 1, 2].map(|i| self.legs[i].w(joints[i]))
    }

    /// Platform axes `v_i = R v0_i` in B.
    pub fn platform_axes(&self, r: &Rotation3<f64>) -> [Vector3<f64>; 3] {
        [0, 1, 2].map(|i| r * self.legs[i].v0)
    }

    /// Loop-closure residuals `w_i(θ_i) · R v0_i − cos α2_i`.
    pub fn closure_residual(&self, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Vector3<f64> {
        let w = self.intermediate_axes(joints);
        Vector3::from_fn(|i, _| w[i].dot(&(r * self.legs[i].v0)) - self.legs[i].cos_a2)
    }

    // ----- inverse kinematics -------------------------------------------------------------

    /// Joint readings (rad, in `(−π, π]`) that put the MP at `r`, every leg in the working branch
    /// (`r` as the platform is, its sag included: [`Spm::rigid`] takes it back to the mechanism's).
    ///
    /// # Errors
    /// An [`IkError`] when a leg cannot reach `r`, `r` is not finite or a leg is at a serial singularity.
    pub fn ik(&self, r: &Rotation3<f64>) -> Result<Vector3<f64>, IkError> {
        if !r.matrix().iter().all(|v| v.is_finite()) {
            return Err(IkError::NotFinite);
        }
        self.ik_rigid(&self.rigid(r))
    }

    /// [`Spm::ik`] at the rigid mechanism's orientation.
    fn ik_rigid(&self, r: &Rotation3<f64>) -> Result<Vector3<f64>, IkError> {
        let mut joints = Vector3::zeros();
        for i in 0..3 {
            joints[i] = self.ik_leg(i, r, Branch::Working)?;
        }
        Ok(joints)
    }

    /// Joint reading of leg `i` (0-based) for the rigid mechanism's orientation `r` ([`Spm::rigid`])
    /// on the chosen branch.
    ///
    /// The closure `w(φ)·v = cos α2` reads `A cos φ + B sin φ = C` with
    /// `A = sin α1 z·v`, `B = sin α1 (u×z)·v`, `C = cos α2 − cos α1 u·v`; writing
    /// `A = ρ cos ψ`, `B = ρ sin ψ` gives `φ = ψ ± acos(C/ρ)`. Since
    /// `(u×w)·v = ρ sin(ψ − φ)`, the branch where it has sign `s` is `φ = ψ − s acos(C/ρ)`:
    /// the working branch takes the leg's home sign, the other its opposite. It is computed as
    /// one angle, `atan2(BC − sAH, AC + sBH)` with `H = √(ρ² − C²)`.
    ///
    /// # Errors
    /// An [`IkError`] as for [`Spm::ik`], for leg `i`.
    pub fn ik_leg(&self, i: usize, r: &Rotation3<f64>, branch: Branch) -> Result<f64, IkError> {
        let leg = &self.legs[i];
        let v = r * leg.v0;
        let a = leg.sin_a1 * leg.z.dot(&v);
        let b = leg.sin_a1 * leg.y.dot(&v);
        let c = leg.cos_a2 - leg.cos_a1 * leg.u.dot(&v);
        // `a`, `b` are at most sin α1 in size: no overflow for `hypot` to guard against.
        let rho = (a * a + b * b).sqrt();
        if !(rho.is_finite() && c.is_finite()) {
            return Err(IkError::NotFinite);
        }
        let ratio = c / rho;
        // Beyond 1 by more than rounding: the cone of v around w does not meet the circle of w.
        if ratio.abs() > 1.0 + 1e-12 {
            return Err(IkError::OutsideWorkspace { leg: i, ratio: ratio.abs() });
        }
        // ρ = sin α1 · sin∠(u, v): zero when v lies along u, where every φ closes the loop alike.
        let sine = rho / leg.sin_a1;
        if sine.is_nan() || sine < IK_SINGULAR_SINE {
            return Err(IkError::SerialSingularity { leg: i, angle_deg: sine.asin().to_degrees() });
        }
        let sign = match branch {
            Branch::Working => leg.sign,
            Branch::Other => -leg.sign,
        };
        // `φ = ψ − s γ` with `cos γ = C/ρ`, `sin γ = H/ρ`, `H = √(ρ² − C²)`: ρ² times its cosine
        // and sine are `AC + sBH` and `BC − sAH`, one `atan2` (no `acos`, no second `atan2`).
        let c = c.clamp(-rho, rho);
        let h = ((rho - c) * (rho + c)).sqrt();
        Ok(leg.reading((b * c - sign * a * h).atan2(a * c + sign * b * h)))
    }

    // ----- Jacobians and singularities ----------------------------------------------------

    /// Velocity Jacobians at joints `θ` and the rigid mechanism's orientation `r` (assumed to close
    /// the loops; [`Spm::rigid`] of what [`Spm::forward`] returns).
    pub fn jacobians(&self, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Jacobians {
        let w = self.intermediate_axes(joints);
        let v = self.platform_axes(r);
        let a = Matrix3::from_rows(&[0, 1, 2].map(|i| w[i].cross(&v[i]).transpose()));
        let b = Matrix3::from_diagonal(&Vector3::from_fn(|i, _| {
            self.legs[i].scale * self.legs[i].u.cross(&w[i]).dot(&v[i])
        }));
        Jacobians { a, b }
    }

    /// Branch margins `−s_i (u_i×w_i)·v_i / sin α1_i` in `[−1, 1]` at the rigid mechanism's
    /// orientation `r`, with `s_i` the leg's home sign: negative in the working branch, zero at a
    /// serial singularity of the leg.
    pub fn branch_margins(&self, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Vector3<f64> {
        let w = self.intermediate_axes(joints);
        Vector3::from_fn(|i, _| {
            let leg = &self.legs[i];
            -leg.sign * leg.u.cross(&w[i]).dot(&(r * leg.v0)) / leg.sin_a1
        })
    }

    /// The legs' branches at home (the signs of `(u×w)·v` the working mode keeps).
    pub fn home_branches(&self) -> [HomeBranch; 3] {
        self.geometry.map(|g| g.home_branch)
    }

    /// Branch of each leg at a pose.
    pub fn branches(&self, joints: &Vector3<f64>, r: &Rotation3<f64>) -> [Branch; 3] {
        let m = self.branch_margins(joints, r);
        [0, 1, 2].map(|i| if m[i] < 0.0 { Branch::Working } else { Branch::Other })
    }

    /// Reject a pose that is near a parallel singularity or has a leg off the working branch.
    fn check_pose(&self, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Result<(), FdaError> {
        let conditioning = self.jacobians(joints, r).conditioning();
        if conditioning < self.settings.min_conditioning {
            return Err(FdaError::NearSingular { conditioning });
        }
        let margins = self.branch_margins(joints, r);
        for i in 0..3 {
            if margins[i] > -self.settings.min_branch_margin {
                return Err(FdaError::LeftWorkingMode { leg: i, margin: margins[i] });
            }
        }
        Ok(())
    }

    // ----- forward displacement analysis --------------------------------------------------

    /// Newton on the closure equations from `start`, with the analytic Jacobian: perturbing
    /// `R ← exp(ω) R` changes residual i by `ω · (v_i × w_i)`. No allocation.
    /// Returns the orientation and the iterations used.
    pub(crate) fn newton(
        &self,
        w: &[Vector3<f64>; 3],
        start: &Rotation3<f64>,
        max_iterations: u32,
    ) -> Result<(Rotation3<f64>, u32), FdaError> {
        let mut r = *start;
        let mut residual = f64::INFINITY;
        for iteration in 0..=max_iterations {
            let v = self.platform_axes(&r);
            let f = Vector3::from_fn(|i, _| w[i].dot(&v[i]) - self.legs[i].cos_a2);
            residual = f.amax();
            if residual <= self.settings.tolerance {
                return Ok((r, iteration));
            }
            if !residual.is_finite() || iteration == max_iterations {
                break;
            }
            let jac = Matrix3::from_rows(&[0, 1, 2].map(|i| v[i].cross(&w[i]).transpose()));
            let Some(step) = jac.lu().solve(&(-f)) else {
                break;
            };
            r = so3::exp(&step) * r;
        }
        Err(FdaError::NotConverged { iterations: max_iterations, residual })
    }

    /// Tracking FDA, the haptic-loop path: Newton from the `previous` orientation, then checks
    /// that the result is near it, regular and in the working mode. No heap allocation. Both
    /// orientations are the platform's as it is, its sag included ([`Spm::sagged`]).
    ///
    /// # Errors
    /// An [`FdaError`] for non-finite readings, no convergence, a near-singular pose, a jump from `previous` or a solution off the working mode.
    pub fn track(&self, joints: &Vector3<f64>, previous: &Rotation3<f64>) -> Result<Rotation3<f64>, FdaError> {
        if !joints.iter().all(|j| j.is_finite()) {
            return Err(FdaError::NotFinite);
        }
        let w = self.intermediate_axes(joints);
        let previous = self.rigid(previous);
        let (r, _) = self.newton(&w, &previous, self.settings.max_iterations)?;
        let jump = so3::geodesic_angle(&previous, &r);
        if jump > self.settings.max_track_jump {
            return Err(FdaError::JumpTooLarge { jump_deg: jump.to_degrees() });
        }
        self.check_pose(joints, &r)?;
        Ok(self.sagged(&r))
    }

    /// FDA in the working mode: the solution continuously connected to home, followed along the
    /// straight joint-space path from the home readings by predictor–corrector continuation with
    /// step halving, then turned by the platform's sag ([`Spm::sagged`]). Fails with a typed error
    /// at or near a singularity.
    ///
    /// # Errors
    /// An [`FdaError`] for non-finite readings, a path through or near a singularity, or a solution off the working mode.
    pub fn forward(&self, joints: &Vector3<f64>) -> Result<Rotation3<f64>, FdaError> {
        if !joints.iter().all(|j| j.is_finite()) {
            return Err(FdaError::NotFinite);
        }
        let start = self.home_joints;
        // The shortest turn of each joint from home to the readings' angle (a reading a turn away
        // is the same angle only for a scale of 1: the path ends where `φ = sθ + δ` does).
        let delta = Vector3::from_fn(|i, _| {
            let s = self.legs[i].scale;
            so3::wrap_angle(s * (joints[i] - start[i])) / s
        });
        let mut r = Rotation3::identity();
        let full_step = (self.settings.continuation_step / delta.amax().max(1e-300)).min(1.0);
        let (mut s, mut ds) = (0.0_f64, full_step);
        while s < 1.0 {
            let next = (s + ds).min(1.0);
            let (from, to) = (start + delta * s, start + delta * next);
            match self.continuation_step(&from, &to, &r) {
                Ok(r_next) => {
                    r = r_next;
                    s = next;
                    ds = (2.0 * ds).min(full_step);
                }
                Err(e) if ds < 1e-6 => return Err(e),
                Err(_) => ds *= 0.5,
            }
        }
        self.check_pose(joints, &r)?;
        Ok(self.sagged(&r))
    }

    /// One predictor–corrector step of `forward`: first-order predictor `A ω = B Δθ`, Newton corrector.
    fn continuation_step(
        &self,
        from: &Vector3<f64>,
        to: &Vector3<f64>,
        r: &Rotation3<f64>,
    ) -> Result<Rotation3<f64>, FdaError> {
        let jac = self.jacobians(from, r);
        let conditioning = jac.conditioning();
        if conditioning < self.settings.min_conditioning {
            return Err(FdaError::NearSingular { conditioning });
        }
        let omega = jac.forward().ok_or(FdaError::NearSingular { conditioning: 0.0 })? * (to - from);
        let turn = omega.norm();
        // Other assembly modes come closer as the conditioning falls: the platform may turn in one
        // step no further than a joint may, times the conditioning index; else halve the step.
        if turn > self.settings.continuation_step * conditioning {
            return Err(FdaError::JumpTooLarge { jump_deg: turn.to_degrees() });
        }
        let predicted = so3::exp(&omega) * r;
        let w = self.intermediate_axes(to);
        // A corrector that needs many iterations left the predictor's basin: halve the step instead.
        let (corrected, _) = self.newton(&w, &predicted, 8)?;
        // The first-order predictor errs by the square of the step: a correction beyond a fifth
        // of the turn is Newton landing on another solution. (Half the turn let a coaxial SPM's
        // FDA jump 25° onto another mode with every leg on its home branch: tests/general_spm.rs.)
        if so3::geodesic_angle(&predicted, &corrected) > 0.2 * turn + 1e-9 {
            return Err(FdaError::JumpTooLarge { jump_deg: so3::geodesic_angle(r, &corrected).to_degrees() });
        }
        Ok(corrected)
    }
}

/// The gravity torque's arm on a platform at `r`: `n × (−z)`, `n = R z` its axis, `z` the base's up.
pub(crate) fn sag_arm(r: &Rotation3<f64>) -> Vector3<f64> {
    (r * Vector3::z()).cross(&-Vector3::z())
}
