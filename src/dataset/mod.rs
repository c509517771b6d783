//! Session files: loading, validation, writing (formats in docs/formats.md).

mod bag;
mod body;
mod joints;
mod markers;
mod open;
mod orientations;
mod pixels;
mod session;
mod streams;

pub(crate) use body::BodyCapture;
pub use body::BodyPose;
pub use joints::JointReading;
pub use orientations::OrientationRecord;
pub use pixels::SeenPixel;
pub(crate) use pixels::{PixelRow, triangulate};
pub(crate) use session::MIN_MARKERS;
pub use session::{Session, SessionPose, Truth, Warning};
pub use streams::Streams;
pub(crate) use streams::{Capture, Clock, EncoderSample};
