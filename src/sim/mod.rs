//! Synthetic sessions with ground truth: a true geometry around the nominal model, a stereo
//! camera with realistic noise, occlusion and collision checks (parry), encoder quantisation.

mod camera;
mod config;
mod scene;
mod simulator;

pub use camera::{looking_down, measure};
pub use config::{
    Camera, CaptureSettings, Encoders, PlanRow, PlanSource, Recording, SimConfig, Trajectory, TruthSpread, Workspace,
};
pub use scene::CollisionScene;
pub use simulator::{Candidate, SimError, SimSummary, candidates, simulate};
