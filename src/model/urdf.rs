//! Loading the nominal model from a URDF and its YAML companion.
//!
//! URDF holds trees only, so `NAME.urdf` comes with `NAME.yaml` beside it, which names the
//! three joints of each leg, says which link of legs 2 and 3 is rigidly the MP once the loop
//! is closed, and gives the marker positions in P. The geometry of docs/conventions.md is read off the
//! tree at the zero configuration (all joint values 0 = the home pose `R = I`):
//! `u` = actuated axis, `w(0)` = intermediate axis, `v0` = platform axis, all in B;
//! `α1 = ∠(u, w(0))`, `α2 = ∠(w(0), v0)`, `z = (w(0) − cos α1 u) / sin α1`, and `δ` the
//! companion's `encoder_offsets_deg` (0 when absent) and `s` its `encoder_scales` (1 when absent):
//! joint value = scale × encoder reading + offset.

use std::collections::{BTreeMap, HashMap, HashSet, VecDeque};
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

use super::camera::CameraModel;
use super::geometry::{HomeBranch, LegGeometry};
use super::limits::Ranges;
use super::params::CameraRecord;
use super::spm::{Spm, SpmError};
use super::urdf_check::Fault;
use crate::io::files::FileError;
use crate::io::yaml::KeyLines;
use crate::math::constellation;

/// Largest distance (m) from O of a joint axis line still accepted as passing through O:
/// a few CAD rounding steps, far below any real misalignment worth calibrating.
pub(crate) const CONCURRENCY_TOLERANCE_M: f64 = 1e-6;
/// Largest angle (rad) between a closure link and the MP at the zero configuration.
pub(crate) const CLOSURE_TOLERANCE_RAD: f64 = 1e-6;

/// A named marker on the MP.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Marker name (from the companion).
    pub name: String,
    /// Position in the MP frame P, metres.
    pub position: Vector3<f64>,
}

/// Which rigid body of the mechanism a collision shape belongs to (legs 0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Body {
    /// The fixed base.
    Base,
    /// The proximal link of a leg (0-based index).
    Proximal(usize),
    /// The distal link of a leg (0-based index).
    Distal(usize),
    /// The moving platform.
    Platform,
}

/// A collision primitive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Along the local z axis, centred.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Length (m).
        length: f64,
    },
    /// Along the local z axis, centred; `length` excludes the caps.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the straight part (m).
        length: f64,
    },
    /// A box, centred.
    Cuboid {
        /// Half the side lengths (m).
        half_extents: Vector3<f64>,
    },
    /// A sphere, centred.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
}

/// A collision shape with its pose in B at the home pose.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyShape {
    /// The body it moves with.
    pub body: Body,
    /// The primitive.
    pub shape: Shape,
    /// Its pose in B at the home pose.
    pub pose_at_home: Isometry3<f64>,
}

/// The nominal model: geometry, markers and collision shapes.
#[derive(Debug, Clone)]
pub struct RobotModel {
    /// Robot name (URDF).
    pub name: String,
    /// The URDF file, or a shipped model's name (`agile_wrist`): how the model was named.
    pub urdf_path: PathBuf,
    /// The model's identity: the SHA-256 (hex) of its URDF's bytes followed by its companion's
    /// (`cat m.urdf m.yaml | sha256sum`), which a parameters file records as `model_sha256`.
    pub sha256: String,
    /// The nominal mechanism.
    pub spm: Spm,
    /// Markers on the MP (companion).
    pub markers: Vec<Marker>,
    /// Collision shapes.
    pub shapes: Vec<BodyShape>,
    /// The camera model of a calibrated (exported) model's companion; a perfect camera otherwise.
    pub camera_model: CameraModel,
}

/// Why a model could not be loaded. Every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    #[error("{path}: {reason}")]
    /// A file of the model (the URDF or its companion) cannot be read or parsed, or the URDF's
    /// tree as a whole is invalid (no links, not exactly one root).
    Unreadable {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    #[error(transparent)]
    /// The companion file is invalid.
    File(FileError),
    #[error("exporting {path} with the parameters: {reason}")]
    /// A calibrated copy of the model cannot be made (`export`).
    Export {
        /// The model's URDF.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    #[error("{path}: joint `{joint}` {reason}")]
    /// A joint is invalid.
    Joint {
        /// The file.
        path: PathBuf,
        /// Joint name.
        joint: String,
        /// Why.
        reason: String,
    },
    #[error("{path}: link `{link}` {reason}")]
    /// A link is invalid.
    Link {
        /// The file.
        path: PathBuf,
        /// Link name.
        link: String,
        /// Why.
        reason: String,
    },
    #[error(
        "{path}: axis of joint `{joint}` misses the centre of rotation O by {distance_mm:.4} mm (tolerance {tolerance_mm} mm)"
    )]
    /// A joint axis does not pass through the centre of rotation.
    AxisMissesCentre {
        /// The file.
        path: PathBuf,
        /// Joint name.
        joint: String,
        /// Distance from the centre (mm).
        distance_mm: f64,
        /// Allowed distance (mm).
        tolerance_mm: f64,
    },
    #[error("{path}: the loop closure of leg {leg_number} has no solution at home: {reason}", leg_number = .leg + 1)]
    /// A leg does not close on the MP at home.
    Closure {
        /// The file.
        path: PathBuf,
        /// Leg index (0-based).
        leg: usize,
        /// Why.
        reason: String,
    },
    #[error("{path}: {source}")]
    /// The geometry does not make a usable manipulator.
    Geometry {
        /// The file.
        path: PathBuf,
        /// Why.
        source: SpmError,
    },
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Companion {
    pub(super) platform_link: String,
    pub(super) legs: Vec<CompanionLeg>,
    pub(super) markers_m: BTreeMap<String, [f64; 3]>,
    /// Per leg, what the URDF joint value of `theta_i` is ahead of the encoder reading (joint value
    /// = reading + offset), degrees; absent: 0 (a calibrated URDF has them).
    #[serde(default)]
    pub(super) encoder_offsets_deg: Option<[f64; 3]>,
    /// Per leg, the URDF joint value's turn per radian of the encoder reading (joint value =
    /// scale × reading + offset); absent: 1 (a calibrated URDF has them when a scale is not 1).
    #[serde(default)]
    pub(super) encoder_scales: Option<[f64; 3]>,
    /// The platform's sag under its weight, degrees per unit of the gravity torque's arm
    /// (`Spm::sagged`; a URDF has no term for it): absent, 0 (an export writes a fitted one).
    #[serde(default)]
    pub(super) platform_sag_deg: Option<f64>,
    /// The camera model a calibration fitted (an export writes it; the model carries it).
    #[serde(default)]
    pub(super) camera: Option<CameraRecord>,
    /// That camera model, as checked when the companion was read.
    #[serde(skip)]
    pub(super) camera_model: CameraModel,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CompanionLeg {
    pub(super) actuated: String,
    pub(super) intermediate: String,
    pub(super) platform: String,
    pub(super) closes_on: Option<String>,
}

/// The companion file of a URDF: same folder and stem, extension `.yaml`.
pub(crate) fn companion_path(urdf: &Path) -> PathBuf {
    urdf.with_extension("yaml")
}

/// A joint of the tree at the zero configuration, in B.
struct PlacedJoint<'a> {
    joint: &'a urdf_rs::Joint,
    /// Pose of the joint (= child link) frame in B.
    frame: Isometry3<f64>,
}

impl PlacedJoint<'_> {
    fn axis(&self) -> Vector3<f64> {
        self.frame.rotation * Vector3::from(self.joint.axis.xyz.0)
    }
}

pub(super) fn origin_isometry(pose: &urdf_rs::Pose) -> Isometry3<f64> {
    let [r, p, y] = pose.rpy.0;
    Isometry3::from_parts(Translation3::from(Vector3::from(pose.xyz.0)), UnitQuaternion::from_euler_angles(r, p, y))
}

impl RobotModel {
    /// The companion file of the URDF `urdf`: same folder and stem, extension `.yaml`.
    pub fn companion_path(urdf: &Path) -> PathBuf {
        companion_path(urdf)
    }

    /// Load `urdf` and its companion, derive and validate the geometry.
    ///
    /// # Errors
    /// A [`ModelError`] naming the file and the joint or link for anything `check_urdf` rejects, a missing or invalid companion, axes that miss the centre, or legs that do not close.
    ///
    /// `urdf` may also be a shipped model's name as written — `agile_wrist`, `orbita3d` (no
    /// folder, no extension) — which loads the model compiled into the program.
    pub fn load(urdf: &Path) -> Result<Self, ModelError> {
        let texts = ModelTexts::of(urdf)?;
        let robot = urdf_rs::read_from_string(&texts.urdf)
            .map_err(|e| ModelError::Unreadable { path: urdf.to_path_buf(), reason: e.to_string() })?;
        super::urdf_check::check(&robot).map_err(|fault| {
            let path = urdf.to_path_buf();
            match fault {
                Fault::Joint(joint, reason) => ModelError::Joint { path, joint, reason },
                Fault::Link(link, reason) => ModelError::Link { path, link, reason },
                Fault::Robot(reason) => ModelError::Unreadable { path, reason: format!("the robot {reason}") },
            }
        })?;
        let (companion, keys) = parse_companion(&texts.companion_path, &texts.companion)?;
        check_names(urdf, &robot, &companion, &Ranges { path: &texts.companion_path, keys: &keys })
            .map_err(companion_error)?;
        let mut model = Loader { path: urdf, robot: &robot }.build(companion)?;
        model.sha256 = texts.sha256();
        Ok(model)
    }

    /// The names of the models that ship with spmcal (compiled in): `agile_wrist`, `orbita3d`.
    pub fn shipped() -> [&'static str; 2] {
        super::shipped::NAMES
    }

    /// Whether `reference` names a shipped model (its name as written: no folder, no extension)
    /// rather than a URDF file.
    pub fn is_shipped(reference: &Path) -> bool {
        super::shipped::named(reference).is_some()
    }

    /// A model reference written in a file in `folder` (a session's, a config's `model:`), as
    /// seen from the working folder: a name or an absolute path as written, a relative path
    /// joined to `folder`.
    pub fn reference_in(folder: &Path, reference: &Path) -> PathBuf {
        crate::io::files::resolve_reference(folder, reference)
    }

    /// How a file that names this model records it: the shipped model's name when its content is
    /// a shipped model's (whichever path it was loaded from), else its path.
    pub(crate) fn reference(&self) -> PathBuf {
        super::shipped::with_sha256(&self.sha256).map_or_else(|| self.urdf_path.clone(), |s| PathBuf::from(s.name))
    }
}

/// How a file in `folder` records the model `model` (a name, or a path from the working folder):
/// a shipped model's name when that is what it names or its content is a shipped model's; an
/// absolute path as it is; a relative one relative to `folder` (`../models/m.urdf`), or absolute
/// when the two share no folder but the root (no `../../../../` climbing to `/`); as given when it
/// cannot be resolved.
pub(crate) fn reference_from(folder: &Path, model: &Path) -> PathBuf {
    if crate::io::files::is_name(model) {
        return model.to_path_buf();
    }
    if let Ok(texts) = ModelTexts::of(model)
        && let Some(shipped) = super::shipped::with_sha256(&texts.sha256())
    {
        return PathBuf::from(shipped.name);
    }
    if model.is_absolute() {
        // As given, but without the `..` a folder given absolutely leaves in it.
        return model.canonicalize().unwrap_or_else(|_| model.to_path_buf());
    }
    let (Ok(from), Ok(target)) = (folder.canonicalize(), model.canonicalize()) else {
        return model.to_path_buf();
    };
    let common = from.components().zip(target.components()).take_while(|(a, b)| a == b).count();
    if common <= 1 {
        return target;
    }
    let mut out: PathBuf = from.components().skip(common).map(|_| "..").collect();
    out.extend(target.components().skip(common));
    out
}

/// The two texts of a model: its files', or a shipped model's.
pub(crate) struct ModelTexts {
    pub(crate) urdf: String,
    pub(crate) companion: String,
    /// The companion as messages name it: the file, or `agile_wrist.yaml (shipped)`.
    pub(crate) companion_path: PathBuf,
}

impl ModelTexts {
    /// The texts of the model `urdf` names (a path, or a shipped model's name).
    pub(crate) fn of(urdf: &Path) -> Result<Self, ModelError> {
        if let Some(shipped) = super::shipped::named(urdf) {
            return Ok(ModelTexts {
                urdf: shipped.urdf.to_string(),
                companion: shipped.companion.to_string(),
                companion_path: PathBuf::from(format!("{}.yaml (shipped)", shipped.name)),
            });
        }
        let text = std::fs::read_to_string(urdf).map_err(|e| {
            let shipped = super::shipped::listed();
            let reason = match e.kind() {
                std::io::ErrorKind::NotFound if crate::io::files::is_name(urdf) => format!(
                    "no model ships with spmcal under this name (the shipped models are {shipped}), nor is there a \
                     file of this name"
                ),
                std::io::ErrorKind::NotFound => {
                    format!("cannot read: {e} (the models that ship with spmcal are named {shipped})")
                }
                _ => format!("cannot read: {e}"),
            };
            ModelError::Unreadable { path: urdf.to_path_buf(), reason }
        })?;
        let companion_path = companion_path(urdf);
        let companion = crate::io::yaml::read_bounded(&companion_path).map_err(|e| ModelError::Unreadable {
            path: companion_path.clone(),
            reason: format!("cannot read the URDF companion: {}", e.reason),
        })?;
        Ok(ModelTexts { urdf: text, companion, companion_path })
    }

    /// The model's identity.
    pub(crate) fn sha256(&self) -> String {
        super::shipped::identity(self.urdf.as_bytes(), self.companion.as_bytes())
    }
}

/// Every joint and link the companion names is in the URDF: else an error at the companion's
/// line that names it.
fn check_names(urdf: &Path, robot: &urdf_rs::Robot, companion: &Companion, check: &Ranges) -> Result<(), FileError> {
    let joints: HashSet<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    let links: HashSet<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
    let file = urdf.display();
    if !links.contains(companion.platform_link.as_str()) {
        let reason = format!("link `{}` (the MP) is missing from {file}", companion.platform_link);
        return Err(check.error("platform_link", reason));
    }
    for (k, leg) in companion.legs.iter().enumerate() {
        for (field, name) in leg.joints() {
            if !joints.contains(name) {
                return Err(
                    check.error(&format!("legs[{k}].{field}"), format!("joint `{name}` is missing from {file}"))
                );
            }
        }
        if let Some(link) = leg.closes_on.as_deref()
            && !links.contains(link)
        {
            let reason = format!("link `{link}` (leg {}'s closure on the MP) is missing from {file}", k + 1);
            return Err(check.error(&format!("legs[{k}].closes_on"), reason));
        }
    }
    Ok(())
}

impl CompanionLeg {
    /// The leg's three joints by their companion keys, from the base out.
    fn joints(&self) -> [(&'static str, &str); 3] {
        [
            ("actuated", self.actuated.as_str()),
            ("intermediate", self.intermediate.as_str()),
            ("platform", self.platform.as_str()),
        ]
    }
}

fn companion_error(e: FileError) -> ModelError {
    ModelError::File(e)
}

/// The companion of the model `urdf` names (a path or a shipped model's name), with its keys'
/// lines and its path as messages name it.
pub(super) fn read_companion(urdf: &Path) -> Result<(Companion, KeyLines, PathBuf), ModelError> {
    let texts = ModelTexts::of(urdf)?;
    let (companion, keys) = parse_companion(&texts.companion_path, &texts.companion)?;
    Ok((companion, keys, texts.companion_path))
}

pub(super) fn parse_companion(path: &Path, text: &str) -> Result<(Companion, KeyLines), ModelError> {
    let (mut companion, keys) = crate::io::yaml::parse::<Companion>(path, text).map_err(companion_error)?;
    let check = Ranges { path, keys: &keys };
    if companion.legs.len() != 3 {
        let reason = format!("`legs` lists {} legs; an SPM of this kind has 3", companion.legs.len());
        return Err(companion_error(check.error("legs", reason)));
    }
    // A joint belongs to one leg, once: found in one pass.
    let mut used: HashMap<&str, String> = HashMap::new();
    for (k, leg) in companion.legs.iter().enumerate() {
        for (field, name) in leg.joints() {
            let key = format!("legs[{k}].{field}");
            if name.trim().is_empty() {
                return Err(companion_error(check.error(&key, "a joint name is empty")));
            }
            if let Some(first) = used.insert(name, key.clone()) {
                let reason =
                    format!("joint `{name}` is named twice (also as `{first}`); each joint is in one leg, once");
                return Err(companion_error(check.error(&key, reason)));
            }
        }
    }
    if let Some(offsets) = companion.encoder_offsets_deg {
        for (i, offset) in offsets.iter().enumerate() {
            let what = format!("the encoder offset of leg {}", i + 1);
            check.offset_deg(&format!("encoder_offsets_deg[{i}]"), &what, *offset).map_err(companion_error)?;
        }
    }
    if let Some(scales) = companion.encoder_scales {
        for (i, scale) in scales.iter().enumerate() {
            check
                .joint_scale(&format!("encoder_scales[{i}]"), &format!("the encoder scale of leg {}", i + 1), *scale)
                .map_err(companion_error)?;
        }
    }
    if let Some(sag) = companion.platform_sag_deg
        && !(sag.is_finite() && sag.to_radians().abs() <= super::spm::MAX_PLATFORM_SAG)
    {
        let reason = format!(
            "`platform_sag_deg` = {sag}: a platform's sag must be a finite number of degrees per unit of arm within ±10"
        );
        return Err(companion_error(check.error("platform_sag_deg", reason)));
    }
    if let Some(camera) = &companion.camera {
        if camera.has_registration() {
            let reason = "a model's `camera` holds its camera model only: the registration (`r_cb_wxyz`, `t_cb_m`) belongs to a parameters file";
            return Err(companion_error(check.error("camera", reason)));
        }
        companion.camera_model = camera.camera_model(&check).map_err(companion_error)?;
    }
    for (name, p) in &companion.markers_m {
        let key = format!("markers_m.{name}");
        if name.trim().is_empty() {
            return Err(companion_error(check.error(&key, "a marker name is empty")));
        }
        check.position(&key, &format!("marker `{name}`'s position"), p).map_err(companion_error)?;
    }
    let points: Vec<Vector3<f64>> = companion.markers_m.values().map(|p| Vector3::from(*p)).collect();
    // The model's own markers must fix an orientation, whatever the camera's noise: judged
    // against the noise the vision estimator assumes.
    if let Err(d) = constellation::check(&points, constellation::MARKER_NOISE_M) {
        let names: Vec<&String> = companion.markers_m.keys().collect();
        let (key, reason) = match &d {
            constellation::Degeneracy::Coincident { first, second, .. } => (
                format!("markers_m.{}", names[second - 1]),
                format!("markers `{}` and `{}`: {d}", names[first - 1], names[second - 1]),
            ),
            _ => ("markers_m".to_string(), format!("the markers cannot fix an orientation: {d}")),
        };
        return Err(companion_error(check.error(&key, reason)));
    }
    Ok((companion, keys))
}

pub(super) struct Loader<'a> {
    pub(super) path: &'a Path,
    pub(super) robot: &'a urdf_rs::Robot,
}

impl<'a> Loader<'a> {
    fn joint_error(&self, joint: &str, reason: impl Into<String>) -> ModelError {
        ModelError::Joint { path: self.path.to_path_buf(), joint: joint.to_string(), reason: reason.into() }
    }

    fn link_error(&self, link: &str, reason: impl Into<String>) -> ModelError {
        ModelError::Link { path: self.path.to_path_buf(), link: link.to_string(), reason: reason.into() }
    }

    /// Pose in B of every link at the zero configuration, from the tree's root.
    pub(super) fn link_frames(&self) -> Result<HashMap<&'a str, Isometry3<f64>>, ModelError> {
        let children: HashSet<&str> = self.robot.joints.iter().map(|j| j.child.link.as_str()).collect();
        let roots: Vec<&str> =
            self.robot.links.iter().map(|l| l.name.as_str()).filter(|n| !children.contains(n)).collect();
        let [root] = roots[..] else {
            return Err(ModelError::Unreadable {
                path: self.path.to_path_buf(),
                reason: format!(
                    "expected one root link (the base), found {}: {:?}{}",
                    roots.len(),
                    &roots[..roots.len().min(5)],
                    if roots.len() > 5 { " …" } else { "" }
                ),
            });
        };
        // Breadth first from the root, each joint once: linear in the size of the tree.
        let mut by_parent: HashMap<&str, Vec<&'a urdf_rs::Joint>> = HashMap::new();
        for j in &self.robot.joints {
            by_parent.entry(j.parent.link.as_str()).or_default().push(j);
        }
        let mut frames = HashMap::from([(root, Isometry3::identity())]);
        let mut queue = VecDeque::from([root]);
        while let Some(link) = queue.pop_front() {
            let parent = frames[link];
            for j in by_parent.get(link).map_or(&[][..], Vec::as_slice) {
                let child = j.child.link.as_str();
                if !frames.contains_key(child) {
                    frames.insert(child, parent * origin_isometry(&j.origin));
                    queue.push_back(child);
                }
            }
        }
        if let Some(j) = self.robot.joints.iter().find(|j| !frames.contains_key(j.parent.link.as_str())) {
            return Err(
                self.joint_error(&j.name, format!("has parent link `{}`, which is not in the tree", j.parent.link))
            );
        }
        Ok(frames)
    }

    fn placed(
        &self,
        frames: &HashMap<&str, Isometry3<f64>>,
        joints: &HashMap<&str, &'a urdf_rs::Joint>,
        name: &str,
    ) -> Result<PlacedJoint<'a>, ModelError> {
        let joint = *joints.get(name).ok_or_else(|| self.joint_error(name, "is missing"))?;
        if !matches!(joint.joint_type, urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous) {
            return Err(self.joint_error(name, format!("is {:?}; the legs' joints must be revolute", joint.joint_type)));
        }
        let frame = frames[joint.parent.link.as_str()] * origin_isometry(&joint.origin);
        let placed = PlacedJoint { joint, frame };
        let axis = placed.axis();
        if !axis.iter().all(|c| c.is_finite()) || axis.norm() < 1e-9 {
            return Err(self.joint_error(name, "has a zero-length axis"));
        }
        let distance = frame.translation.vector.cross(&axis.normalize()).norm();
        if distance > CONCURRENCY_TOLERANCE_M {
            return Err(ModelError::AxisMissesCentre {
                path: self.path.to_path_buf(),
                joint: name.to_string(),
                distance_mm: distance * 1e3,
                tolerance_mm: CONCURRENCY_TOLERANCE_M * 1e3,
            });
        }
        Ok(placed)
    }

    pub(super) fn build(&self, companion: Companion) -> Result<RobotModel, ModelError> {
        let frames = self.link_frames()?;
        let platform = frames
            .get(companion.platform_link.as_str())
            .copied()
            .ok_or_else(|| self.link_error(&companion.platform_link, "(the MP, per the companion) is missing"))?;
        let tilt = platform.rotation.angle();
        if tilt > CLOSURE_TOLERANCE_RAD {
            return Err(self.link_error(
                &companion.platform_link,
                format!(
                    "is rotated {:.4}° from B at the zero configuration; the home pose must be R = I",
                    tilt.to_degrees()
                ),
            ));
        }
        let mut legs = [LegGeometry::nominal(0, 1.0, 1.0, 1.0, 1.0); 3];
        let mut leg_links: Vec<[String; 2]> = Vec::new();
        let joints: HashMap<&str, &urdf_rs::Joint> = self.robot.joints.iter().map(|j| (j.name.as_str(), j)).collect();
        for (i, leg) in companion.legs.iter().enumerate() {
            let actuated = self.placed(&frames, &joints, &leg.actuated)?;
            let intermediate = self.placed(&frames, &joints, &leg.intermediate)?;
            let wrist = self.placed(&frames, &joints, &leg.platform)?;
            self.check_chain(i, [&actuated, &intermediate, &wrist], leg, &companion.platform_link)?;
            self.check_closure(i, &frames, leg, &platform)?;
            let u = actuated.axis().normalize();
            let w0 = intermediate.axis().normalize();
            let v0 = platform.rotation.inverse() * wrist.axis().normalize();
            let alpha1 = u.dot(&w0).clamp(-1.0, 1.0).acos();
            legs[i] = LegGeometry {
                u,
                z: (w0 - u * alpha1.cos()).normalize(),
                alpha1,
                alpha2: w0.dot(&(platform.rotation * v0)).clamp(-1.0, 1.0).acos(),
                v0,
                delta: companion.encoder_offsets_deg.map_or(0.0, |o| o[i].to_radians()),
                scale: companion.encoder_scales.map_or(1.0, |s| s[i]),
                // The zero configuration is home, so the working mode keeps the branch it shows.
                home_branch: HomeBranch::of(u.cross(&w0).dot(&v0)),
            };
            leg_links.push([actuated.joint.child.link.clone(), intermediate.joint.child.link.clone()]);
        }
        let spm = Spm::new(legs)
            .and_then(|spm| spm.with_platform_sag(companion.platform_sag_deg.unwrap_or(0.0).to_radians()))
            .map_err(|source| ModelError::Geometry { path: self.path.to_path_buf(), source })?;
        let markers =
            companion.markers_m.into_iter().map(|(name, p)| Marker { name, position: Vector3::from(p) }).collect();
        let shapes = self.shapes(&frames, &leg_links, &companion.platform_link)?;
        Ok(RobotModel {
            name: self.robot.name.clone(),
            urdf_path: self.path.to_path_buf(),
            spm,
            markers,
            shapes,
            camera_model: companion.camera_model,
            sha256: String::new(),
        })
    }

    /// The three joints of a leg must form a chain from the base to the MP (leg 1) or to its closure link.
    fn check_chain(
        &self,
        leg: usize,
        joints: [&PlacedJoint; 3],
        names: &CompanionLeg,
        platform: &str,
    ) -> Result<(), ModelError> {
        let [a, b, c] = joints.map(|j| j.joint);
        let end = if leg == 0 { platform } else { names.closes_on.as_deref().unwrap_or(platform) };
        if b.parent.link != a.child.link || c.parent.link != b.child.link {
            return Err(self.joint_error(
                &b.name,
                format!("is not in a chain `{}` → `{}` → `{}` (leg {})", a.name, b.name, c.name, leg + 1),
            ));
        }
        if c.child.link != end {
            return Err(self.joint_error(
                &c.name,
                format!("ends at link `{}`, but leg {} should end at `{end}`", c.child.link, leg + 1),
            ));
        }
        Ok(())
    }

    /// A closure link must coincide with the MP at the zero configuration.
    fn check_closure(
        &self,
        leg: usize,
        frames: &HashMap<&str, Isometry3<f64>>,
        names: &CompanionLeg,
        platform: &Isometry3<f64>,
    ) -> Result<(), ModelError> {
        let Some(link) = names.closes_on.as_deref() else {
            return if leg == 0 {
                Ok(())
            } else {
                Err(ModelError::Closure {
                    path: self.path.to_path_buf(),
                    leg,
                    reason: "the companion gives no `closes_on` link".into(),
                })
            };
        };
        let frame =
            frames.get(link).ok_or_else(|| self.link_error(link, "(a closure link, per the companion) is missing"))?;
        let angle = frame.rotation.angle_to(&platform.rotation);
        let offset = (frame.translation.vector - platform.translation.vector).norm();
        if angle > CLOSURE_TOLERANCE_RAD || offset > CONCURRENCY_TOLERANCE_M {
            return Err(ModelError::Closure {
                path: self.path.to_path_buf(),
                leg,
                reason: format!(
                    "at the zero configuration link `{link}` is {:.4}° and {:.4} mm away from the MP",
                    angle.to_degrees(),
                    offset * 1e3
                ),
            });
        }
        Ok(())
    }

    fn shapes(
        &self,
        frames: &HashMap<&str, Isometry3<f64>>,
        leg_links: &[[String; 2]],
        platform: &str,
    ) -> Result<Vec<BodyShape>, ModelError> {
        let mut shapes = Vec::new();
        for link in &self.robot.links {
            let body = if link.name == platform {
                Body::Platform
            } else if let Some(i) = leg_links.iter().position(|l| l[0] == link.name) {
                Body::Proximal(i)
            } else if let Some(i) = leg_links.iter().position(|l| l[1] == link.name) {
                Body::Distal(i)
            } else if frames.get(link.name.as_str()).is_some_and(|f| *f == Isometry3::identity())
                && !link.collision.is_empty()
            {
                Body::Base
            } else {
                continue;
            };
            for c in &link.collision {
                let shape = match &c.geometry {
                    urdf_rs::Geometry::Cylinder { radius, length } => {
                        Shape::Cylinder { radius: *radius, length: *length }
                    }
                    urdf_rs::Geometry::Capsule { radius, length } => {
                        Shape::Capsule { radius: *radius, length: *length }
                    }
                    urdf_rs::Geometry::Box { size } => Shape::Cuboid { half_extents: Vector3::from(size.0) / 2.0 },
                    urdf_rs::Geometry::Sphere { radius } => Shape::Sphere { radius: *radius },
                    urdf_rs::Geometry::Mesh { filename, .. } => {
                        return Err(self.link_error(&link.name, format!("has mesh collision geometry `{filename}`; spmcal needs primitives (cylinder, capsule, box, sphere)")));
                    }
                };
                shapes.push(BodyShape {
                    body,
                    shape,
                    pose_at_home: frames[link.name.as_str()] * origin_isometry(&c.origin),
                });
            }
        }
        Ok(shapes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How a file records its model: a name stays a name; a copy of a shipped model's files is
    /// that model's name; another model's path is relative to the file's folder; an absolute path
    /// stays absolute; a path that resolves nowhere stays as given.
    #[test]
    fn a_file_records_its_model_by_name_or_by_a_path_from_its_folder() {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path();
        std::fs::create_dir_all(root.join("lab/models")).unwrap();
        std::fs::create_dir_all(root.join("out/params")).unwrap();
        let shipped = super::super::shipped::SHIPPED[0];
        std::fs::write(root.join("lab/models/copy.urdf"), shipped.urdf).unwrap();
        std::fs::write(root.join("lab/models/copy.yaml"), shipped.companion).unwrap();
        std::fs::write(root.join("lab/models/own.urdf"), format!("<!-- ours -->\n{}", shipped.urdf)).unwrap();
        std::fs::write(root.join("lab/models/own.yaml"), shipped.companion).unwrap();
        let folder = root.join("out/params");
        assert_eq!(reference_from(&folder, Path::new("orbita3d")), Path::new("orbita3d"));
        assert_eq!(reference_from(&folder, &root.join("lab/models/copy.urdf")), Path::new("agile_wrist"));
        let own = root.join("lab/models/own.urdf");
        assert_eq!(reference_from(&folder, &own), own, "absolute as given");
        // Relative (to the working folder) → relative to the file's folder.
        let cwd = std::env::current_dir().unwrap();
        let common = cwd.components().zip(own.components()).take_while(|(a, b)| a == b).count();
        let from_cwd: PathBuf = cwd
            .components()
            .skip(common)
            .map(|_| "..")
            .collect::<PathBuf>()
            .join(own.components().skip(common).collect::<PathBuf>());
        assert_eq!(reference_from(&folder, &from_cwd), Path::new("../../lab/models/own.urdf"));
        // Sharing no folder but the root (the checkout against the temporary folder): absolute,
        // not a climb of `../` to `/`.
        let checkout_model = Path::new("tests/data/models/agile_wrist_axes_reversed.urdf");
        let shares =
            folder.canonicalize().unwrap().components().nth(1) == cwd.canonicalize().unwrap().components().nth(1);
        if !shares {
            assert_eq!(reference_from(&folder, checkout_model), checkout_model.canonicalize().unwrap());
        }
        assert_eq!(reference_from(&folder, Path::new("no/such/m.urdf")), Path::new("no/such/m.urdf"));
    }
}
