use crate::calib::pipeline::{Calibration, Level};

pub(crate) struct MarkerLevel;

impl Level for MarkerLevel {}

impl MarkerLevel {
    pub(crate) fn prepare() -> Calibration {
        Calibration
    }
}
