mod levels;
mod pipeline;

pub use pipeline::{Calibration, calibrate};
