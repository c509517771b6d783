//! Everything sent to Rerun. A [`Scene`] describes one run — the session, the mechanism that
//! draws it, the camera registration, per-pose MP frames and error series, the fit's iterations and
//! text documents — and [`Scene::write`] turns it into one `.rrd` recording with the timelines
//! `pose` (plus `time` when the session has capture times) and `iteration`.
//!
//! Entities: `world/base` (frame and actuated axes), `world/camera`, `world/legs/leg{i}/{proximal,
//! distal}` (arcs on their spheres), `world/mp/<frame>` (one MP frame per source: `fda_nominal`,
//! `fda_calibrated`, `vision`, `truth`, `planned`, …), `world/markers/{measured,predicted,model}`
//! (`model`: the model's positions beside fitted ones), scalars under `errors/` and `fit/`, and
//! documents under `parameters/`.

//!
//! Files: `scene` (what a recording shows), `scenes` (each command's scene), `draw` (entities),
//! `write` (the recording file and its layout); this facade only re-exports.

mod draw;
mod scene;
mod scenes;
mod write;

pub use scene::{RecordError, RecordingSummary, Scene};
pub use scenes::SceneError;
