//! Synthetic sessions with ground truth: a true geometry around the nominal model, a stereo
//! camera with realistic noise — or a rig of cameras seen through their pixels, its file
//! miscalibrated as configured (`camera.rig`) — occlusion and collision checks (parry), encoder
//! quantisation.

mod camera;
// A config's sections (`camera`, `encoders`, `capture`, `recording`, `truth`, `workspace`) are read
// from YAML; their types are public to the crate's own studies and tests only (`internals`), so
// the documented API stays narrow: a user writes the YAML, not the structs.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub))]
mod config;
// A rig is configured in YAML (`camera.rig`); its settings' types are public to the crate's own
// studies and tests only (`internals`), so the documented API stays narrow.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub))]
mod rig;
mod scene;
mod simulator;

#[cfg(not(feature = "internals"))]
pub(crate) use config::Camera;
// Only the crate's own unit tests name it outside the simulator.
#[cfg(all(test, not(feature = "internals")))]
pub(crate) use config::RigidBodySettings;
pub use config::SimConfig;
#[cfg(feature = "internals")]
pub use config::{Camera, CaptureSettings, Encoders, Recording, RigidBodySettings, Trajectory, TruthSpread, Workspace};
pub(crate) use config::{PlanRow, PlanSource};
#[cfg(feature = "internals")]
pub use rig::{Miscalibration, RigCameraSettings, RigSettings};
pub(crate) use simulator::Candidate;
pub use simulator::{SimError, SimSummary};
