//! Synthetic sessions with ground truth: a true geometry around the nominal model, a stereo
//! camera with realistic noise, occlusion and collision checks (parry), encoder quantisation.

mod camera;
mod config;
mod scene;
mod simulator;

pub use camera::{Measurement, lenses, looking_down, measure};
pub use config::{Camera, Capture, DEFAULT_MODEL, Encoders, Recording, SimConfig, Trajectory, TruthSpread, Workspace};
pub use scene::{BodyRotations, Scene};
pub use simulator::{Candidate, SimError, SimSummary, candidates, simulate};
