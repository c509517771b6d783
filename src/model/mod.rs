//! SPM geometry and parameters, URDF loading, inverse kinematics, forward displacement
//! analysis (tracking, continuation, all assembly modes, the per-pose FDA report) and Jacobians.

mod assembly;
#[cfg(feature = "full")]
pub(crate) mod camchain;
mod camera;
#[cfg(feature = "full")]
mod consistency;
#[cfg(feature = "full")]
mod export;
mod geometry;
pub(crate) mod limits;
#[cfg(feature = "full")]
mod modes;
mod params;
#[cfg(feature = "full")]
mod perturb;
#[cfg(feature = "full")]
// Without `internals`, the projection's derivatives and the fit's terms are the crate's own.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
mod rig;
#[cfg(feature = "full")]
pub(crate) mod shipped;
mod spm;
#[cfg(feature = "full")]
mod survey;
#[cfg(feature = "full")]
mod urdf;
#[cfg(feature = "full")]
mod urdf_check;

pub use assembly::AssemblyMode;
pub use camera::{CameraModel, CameraModelKind, CameraTerm};
// Named only where configs hold it (`CalibConfig::camera_terms`): reachable, not a separate API item.
#[cfg(feature = "full")]
pub(crate) use camera::CameraTerms;
#[cfg(feature = "full")]
pub use export::{ExportedModel, export};
pub use geometry::{GeometryError, HomeBranch, LegGeometry};
#[cfg(feature = "full")]
pub use modes::{FdaPose, ModeReport};
pub use params::{CameraRegistration, MarkerPosition, ParameterSource, Parameters};
#[cfg(feature = "full")]
pub use perturb::GeometrySpread;
#[cfg(feature = "full")]
pub use rig::{DistortionModel, Lens, Rig, RigCamera};
#[cfg(feature = "internals")]
pub use rig::{Projection, RigProjection, RigTerm};
#[cfg(all(feature = "full", not(feature = "internals")))]
pub(crate) use rig::{RigProjection, RigTerm};
pub use spm::{Branch, FdaError, FdaSettings, IkError, Jacobians, Spm, SpmError};
#[cfg(feature = "full")]
pub(crate) use spm::{MAX_PLATFORM_SAG, sag_arm};
#[cfg(feature = "full")]
pub use survey::ModelSurvey;
#[cfg(feature = "full")]
pub(crate) use urdf::reference_from;
#[cfg(feature = "full")]
pub use urdf::{Body, BodyShape, Marker, ModelError, RobotModel, Shape};
