//! The views of a calibration's one report ([`crate::calib::CalibrationReport`]): the text that
//! `calibrate` prints (`text`: its `Display`), the HTML page with its figures (`html`), and the
//! markdown tables the Rerun recording shows (`tables`). JSON is the report's own serialisation
//! (`serde`), the same fields. Each view reads the report the calibration kept; none computes
//! anything the calibration did not.

mod html;
pub(crate) mod tables;
mod text;
