// The trait lives in the file that uses it, and the levels import it back.
use super::levels;

pub trait Level {}
pub struct Calibration;

pub fn calibrate() -> Calibration {
    levels::MarkerLevel::prepare()
}
