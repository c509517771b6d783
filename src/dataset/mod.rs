//! Session files: loading, validation, writing (formats in DESIGN.md).

mod joints;
mod orientations;

pub use joints::{JointReading, read_joints, write_joints};
pub use orientations::{OrientationRecord, read_orientations, write_orientations};
