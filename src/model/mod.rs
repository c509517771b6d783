//! SPM geometry and parameters, URDF loading, inverse kinematics, forward displacement
//! analysis (tracking, continuation, all assembly modes) and Jacobians.

mod assembly;
mod geometry;
mod perturb;
mod spm;

pub use assembly::AssemblyMode;
pub use geometry::{AXIS_TOLERANCE, GeometryError, LegGeometry};
pub use perturb::{GeometrySpread, perturb, tilt};
pub use spm::{
    Branch, FdaError, FdaSettings, IkError, Jacobians, Spm, SpmError, conditioning_index,
    wrap_angle,
};
