//! Session files: loading, validation, writing (formats in DESIGN.md).

mod joints;
mod markers;
mod orientations;
mod session;
mod streams;

pub use joints::{JointReading, joints_csv, read_joints, write_joints};
pub use markers::{MarkerRow, markers_csv, read_markers, write_markers};
pub use orientations::{OrientationRecord, read_orientations, write_orientations};
pub use session::{MIN_MARKERS, Session, SessionPose, Truth, Warning};
pub use streams::{
    Capture, EncoderSample, StreamLimits, Streams, VELOCITY_WINDOW_S, captures_csv, encoders_csv, read_captures,
    read_encoders,
};
