//! The two fit levels: how each makes its observations, registers them and reports what it adds.

mod markers;
mod orientations;

pub(crate) use markers::{MarkerLevel, clock_rate_held};
pub(crate) use orientations::OrientationLevel;
