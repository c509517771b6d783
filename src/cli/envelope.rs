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
        let mut all = self.clone_shape();
        // Every warning and note printed on the way (loading the session, the model, the
        // parameters), before the ones the command set itself.
        let (warnings, notes) = super::output::said();
        let before = |said: Vec<String>, own: &[String]| -> Vec<String> {
            said.into_iter().filter(|s| !own.contains(s)).chain(own.iter().cloned()).collect()
        };
        all.warnings = before(warnings, &self.warnings);
        all.notes = before(notes, &self.notes);
        serde_json::to_string(&all).expect("reports serialise to JSON")
    }

    /// The envelope with its results borrowed.
    fn clone_shape(&self) -> Envelope<&T> {
        Envelope {
            command: self.command,
            version: self.version,
            inputs: self.inputs.clone(),
            results: &self.results,
            warnings: Vec::new(),
            notes: Vec::new(),
        }
    }
}
