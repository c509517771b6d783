//! Marker-based pose estimation: the paper's least squares and polar decomposition, the optimal
//! (Kabsch) rotation, the error metric `e_j`, the centre of rotation, and a session's summary.

mod centre;
mod pose;
mod session;
mod summary;

pub use centre::CentreOfRotation;
pub use pose::{MarkerError, Method, PoseEstimate, Reference};
pub use session::{SessionEstimate, VisionError};
pub use summary::EstimateSummary;
