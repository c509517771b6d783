//! Synthetic sessions with ground truth: a true geometry around the nominal model, a stereo
//! camera with realistic noise, occlusion and collision checks (parry), encoder quantisation.

mod camera;
mod config;
mod rig;
mod scene;
mod simulator;

pub use config::{Camera, CaptureSettings, Encoders, Recording, SimConfig, Trajectory, TruthSpread, Workspace};
pub(crate) use config::{PlanRow, PlanSource};
pub use rig::{Miscalibration, RigCameraSettings, RigSettings};
pub(crate) use simulator::Candidate;
pub use simulator::{SimError, SimSummary};
