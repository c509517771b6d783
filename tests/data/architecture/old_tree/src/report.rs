use crate::Settings;
use crate::calib::Calibration;

pub(crate) fn page(_c: &Calibration, _s: &Settings) {}
