//! The one shape every command's `--json` takes.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

/// The machine-readable summary of one command: the same top-level keys for every command.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Envelope<T: Serialize> {
    /// The command's name (`calibrate`, `compare`, …).
    pub(crate) command: &'static str,
    /// The version of spmcal that wrote it.
    pub(crate) version: &'static str,
    /// The inputs it read, by option name (paths and settings as given).
    pub(crate) inputs: BTreeMap<String, String>,
    /// What it computed.
    pub(crate) results: T,
    /// What the user should know but did not stop the command: every warning it printed (a
    /// calibration's own are also in its report, `results.warnings`).
    pub(crate) warnings: Vec<String>,
    /// What is expected and harmless but said (a recording's frames at its ends left out).
    pub(crate) notes: Vec<String>,
}

impl<T: Serialize> Envelope<T> {
    /// An envelope for `command` with no inputs and no warnings yet.
    pub(crate) fn new(command: &'static str, results: T) -> Self {
        let version = env!("CARGO_PKG_VERSION");
        Envelope { command, version, inputs: BTreeMap::new(), results, warnings: Vec::new(), notes: Vec::new() }
    }

    /// Record an input.
    pub(crate) fn input(mut self, name: &str, value: impl fmt::Display) -> Self {
        self.inputs.insert(name.to_string(), value.to_string());
        self
    }

    /// The JSON text.
    ///
    /// # Panics
    /// Never in practice: reports serialise to JSON.
    pub(crate) fn to_json(&self) -> String {
        serde_json::to_string(self).expect("reports serialise to JSON")
    }
}
