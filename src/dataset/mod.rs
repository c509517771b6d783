//! Session files: loading, validation, writing (formats in DESIGN.md).

mod joints;
mod markers;
mod orientations;
mod session;
mod streams;

pub use joints::{JointReading, joints_csv, read_joints};
pub use orientations::{OrientationRecord, read_orientations, write_orientations};
pub(crate) use session::MIN_MARKERS;
pub use session::{Session, SessionPose, Truth, Warning};
pub use streams::{Capture, EncoderSample, StreamLimits, Streams};
