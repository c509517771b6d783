//! The views of a calibration's one report ([`crate::calib::CalibrationReport`]): the text that
//! `calibrate` prints (`text`: its `Display`), the HTML page (`html`: its charts in `charts`,
//! drawn for any screen by `figures`, long series summarised by `summary`, its tables in
//! `html_tables`), and the tables the Rerun recording shows (`tables`, whose `Table` renders
//! markdown and HTML alike). JSON is the report's own serialisation (`serde`), the same fields.
//! Each view reads the report the calibration kept; none computes anything the calibration did
//! not.

mod charts;
mod figures;
mod html;
mod html_tables;
mod summary;
pub(crate) mod tables;
mod text;
