//! What a command reads and what it writes, resolved and checked against each other before any
//! work: an output that is one of the command's inputs — the same path however it is spelled, a
//! symbolic link to it, or a hard link to the same file — or an output folder that holds an input,
//! is refused with one line naming the option and both paths, so that no run overwrites what it
//! reads. Every command registers every file (and folder) it will read and every file it will
//! write, companions included, then calls [`Files::check`] before it reads anything. A model that
//! another input names (a session's `session.yaml`, a parameters file, a simulation config) is
//! registered as a way to find it: [`Files::check`] reads that input for the name only after the
//! input itself passed the check, then checks the model.
//!
//! A path is compared in three ways: its entry (the path with its folder resolved: what a write
//! would replace), its target (every symbolic link followed, dangling ones too), and, on Unix, the
//! device and inode of the file it names (a hard link).

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use spmcal::FileError;
use spmcal::model::RobotModel;

/// The files the session reader looks for in a session folder (which of them it reads depends on
/// the session's kind: static files, or a free-motion recording's streams, of points or of pixels
/// with their rig; truth when present).
pub(crate) const SESSION_FILES: [&str; 9] = [
    "session.yaml",
    "joints.csv",
    "markers.csv",
    "encoders.csv",
    "captures.csv",
    "pixels.csv",
    "cameras.yaml",
    "truth.yaml",
    "truth_orientations.csv",
];

/// The inputs and outputs of one command.
#[derive(Default)]
pub(crate) struct Files {
    inputs: Vec<Input>,
    outputs: Vec<Output>,
    /// Ways to find a model that an input names, tried once the inputs so far passed the check.
    named_models: Vec<Box<dyn FnOnce() -> Option<PathBuf>>>,
}

/// A file or folder the command reads.
#[derive(Debug)]
struct Input {
    /// How a message names it with its path: `--joints j.csv`, `the model m.urdf`, `joints.csv of
    /// --dataset d`.
    label: String,
    /// How a message names it when the output was given as the same text: `--joints`, `the model`.
    short: String,
    path: PathBuf,
    at: Place,
}

/// A file or folder the command writes.
#[derive(Debug)]
struct Output {
    /// How a message names it: `--out x.csv`, `x.yaml (the companion of --urdf x.urdf)`.
    name: String,
    path: PathBuf,
    /// A file, a folder the command writes files into (`simulate --out`), or one of the files it
    /// writes there.
    role: Role,
    at: Place,
}

/// What an output is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// A file given on its own.
    File,
    /// A session folder: it holds the session alone.
    Folder,
    /// A file the command writes into its session folder.
    InFolder,
}

/// Where a path leads.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Place {
    /// The path made absolute, its folder resolved (symbolic links and `..` included): the
    /// directory entry a write replaces.
    entry: PathBuf,
    /// What the path finally names, every symbolic link followed (a dangling one too); the entry
    /// when it is no link.
    target: PathBuf,
    /// Device and inode of the file it names, when it exists (Unix).
    id: Option<(u64, u64)>,
}

/// How an output reaches an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reach {
    /// The same directory entry, however spelled.
    Same,
    /// One of the two paths is a symbolic link that leads to the other's file.
    Symbolic,
    /// Two names of one file.
    Hard,
}

impl Reach {
    fn how(self) -> &'static str {
        match self {
            Reach::Same => "",
            Reach::Symbolic => ", through a symbolic link",
            Reach::Hard => ", through a hard link",
        }
    }
}

impl Place {
    fn of(path: &Path) -> Place {
        let entry = entry_of(path);
        let target = target_of(&entry);
        Place { id: file_id(&target), entry, target }
    }

    /// Whether `self` and `other` are one file (or folder), and how.
    fn reaches(&self, other: &Place) -> Option<Reach> {
        if self.entry == other.entry {
            Some(Reach::Same)
        } else if self.target == other.target {
            Some(Reach::Symbolic)
        } else if self.id.is_some() && self.id == other.id {
            Some(Reach::Hard)
        } else {
            None
        }
    }

    /// Whether `self` (a folder) holds `other`, and how.
    fn holds(&self, other: &Place) -> Option<Reach> {
        let inside = |p: &Path| p.starts_with(&self.entry) || p.starts_with(&self.target);
        if inside(&other.entry) {
            Some(Reach::Same)
        } else if inside(&other.target) {
            Some(Reach::Symbolic)
        } else {
            None
        }
    }
}

/// The path made absolute with its folder canonicalised (the last component kept as it is, so a
/// symbolic link stays the link); as given, made absolute, when its folder does not exist.
fn entry_of(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent(), absolute.file_name()) {
        (Some(parent), Some(name)) => std::fs::canonicalize(parent).map_or(absolute.clone(), |p| p.join(name)),
        // `/`, or a path ending in `..`: a folder, resolved whole.
        _ => std::fs::canonicalize(&absolute).unwrap_or(absolute),
    }
}

/// Every symbolic link followed; a dangling link still leads to the path it names (a file that
/// does not exist yet but would be written through the link).
fn target_of(entry: &Path) -> PathBuf {
    if let Ok(real) = std::fs::canonicalize(entry) {
        return real;
    }
    let mut at = entry.to_path_buf();
    // A bounded walk: a loop of links leads nowhere.
    for _ in 0..40 {
        let Ok(link) = std::fs::read_link(&at) else { break };
        at = entry_of(&at.parent().unwrap_or(Path::new("/")).join(link));
    }
    at
}

#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_path: &Path) -> Option<(u64, u64)> {
    None
}

/// The model a session folder's `session.yaml` names, resolved as the session reader resolves it
/// (relative to the folder); `None` when the file cannot be read or names none (the session
/// reader then reports the problem itself, before any model is read).
///
/// Only the top-level `model` key is wanted, so the file is read as a stream of events (linear in
/// its size), stopping at the key or at the first sign of trouble: nesting deeper than a session's
/// (the reader refuses that, located), a malformed document. A full parse here (serde_yaml's) took
/// time quadratic in the nesting before the reader's checks ever ran: 42 s for 100,000 brackets.
pub(crate) fn session_model(dir: &Path) -> Option<PathBuf> {
    use saphyr_parser::{Event, Parser};
    let path = dir.join("session.yaml");
    // Anything but a file of a session.yaml's size is left to the reader.
    let meta = std::fs::metadata(&path).ok()?;
    if !meta.is_file() || meta.len() > 1 << 20 {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let (mut depth, mut key, mut model_next) = (0usize, true, false);
    for event in Parser::new_from_str(&text) {
        match event.ok()?.0 {
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                depth += 1;
                // A session.yaml nests two deep; the reader refuses more, with its line.
                if depth > 4 || model_next {
                    return None;
                }
            }
            Event::MappingEnd | Event::SequenceEnd => {
                depth = depth.checked_sub(1)?;
                key = true;
            }
            Event::Scalar(value, ..) if depth == 1 => {
                if model_next {
                    return Some(RobotModel::reference_in(dir, Path::new(value.as_ref())));
                }
                model_next = key && value == "model";
                key = !key;
            }
            Event::Alias(_) if depth == 1 => return None,
            Event::StreamEnd => return None,
            _ => {}
        }
    }
    None
}

impl Files {
    /// No files yet.
    pub(crate) fn new() -> Self {
        Files::default()
    }

    /// A file (or folder) the command reads, given by `option`.
    pub(crate) fn input(&mut self, option: &str, path: &Path) {
        self.push_input(format!("{option} {}", path.display()), option.to_string(), path);
    }

    /// An optional input.
    pub(crate) fn input_opt(&mut self, option: &str, path: Option<&Path>) {
        if let Some(path) = path {
            self.input(option, path);
        }
    }

    /// A model the command reads: the URDF and its companion (none for a shipped model's name:
    /// it is compiled in).
    pub(crate) fn model(&mut self, urdf: &Path) {
        if RobotModel::is_shipped(urdf) {
            return;
        }
        let companion = RobotModel::companion_path(urdf);
        self.push_input(format!("the model {}", urdf.display()), "the model".into(), urdf);
        self.push_input(
            format!("the model's companion {}", companion.display()),
            "the model's companion".into(),
            &companion,
        );
    }

    /// A model whose path another input names: `find` reads that input for the name (`None` when
    /// it cannot; the command then reports the input's problem itself, before any model is read).
    pub(crate) fn model_named_by(&mut self, find: impl FnOnce() -> Option<PathBuf> + 'static) {
        self.named_models.push(Box::new(find));
    }

    /// A session folder given by `option`: the folder and every file its reader looks for there.
    pub(crate) fn session(&mut self, option: &str, dir: &Path) {
        self.input(option, dir);
        for name in SESSION_FILES {
            let label = format!("{name} of {option} {}", dir.display());
            self.push_input(label.clone(), label, &dir.join(name));
        }
    }

    fn push_input(&mut self, label: String, short: String, path: &Path) {
        self.inputs.push(Input { label, short, path: path.to_path_buf(), at: Place::of(path) });
    }

    /// A file the command writes, given by `option`.
    pub(crate) fn output(&mut self, option: &str, path: &Path) {
        self.push_output(format!("{option} {}", path.display()), path, Role::File);
    }

    /// An optional output.
    pub(crate) fn output_opt(&mut self, option: &str, path: Option<&Path>) {
        if let Some(path) = path {
            self.output(option, path);
        }
    }

    /// A URDF the command writes (given by `option`) and the companion written beside it.
    pub(crate) fn model_output(&mut self, option: &str, urdf: &Path) {
        self.output(option, urdf);
        let companion = RobotModel::companion_path(urdf);
        let name = format!("{} (the companion of {option} {})", companion.display(), urdf.display());
        self.push_output(name, &companion, Role::File);
    }

    /// A session folder the command writes (given by `option`) and the files it writes there.
    pub(crate) fn session_output(&mut self, option: &str, dir: &Path) {
        self.push_output(format!("{option} {}", dir.display()), dir, Role::Folder);
        for name in SESSION_FILES {
            let path = dir.join(name);
            let name = format!("{} (written into {option} {})", path.display(), dir.display());
            self.push_output(name, &path, Role::InFolder);
        }
    }

    fn push_output(&mut self, name: String, path: &Path, role: Role) {
        self.outputs.push(Output { name, path: path.to_path_buf(), role, at: Place::of(path) });
    }

    /// Refuse an output that is an input (the same path, a symbolic or a hard link) or an output
    /// folder that holds an input; then find the models other inputs name and refuse an output
    /// that is one of them; then one file given as two outputs, and an output written into a
    /// session folder that is not the session's (a session folder holds the session alone).
    ///
    /// # Errors
    /// The first such output, named with its option and the input's role and path.
    pub(crate) fn check(&mut self) -> Result<()> {
        for output in &self.outputs {
            for input in &self.inputs {
                check_pair(output, input)?;
            }
        }
        for find in std::mem::take(&mut self.named_models) {
            if let Some(urdf) = find() {
                self.check_model(&urdf)?;
            }
        }
        for (k, output) in self.outputs.iter().enumerate() {
            if self.outputs[..k].iter().any(|earlier| earlier.at.reaches(&output.at).is_some()) {
                return Err(FileError::new(&output.path, "is given as two different outputs").into());
            }
        }
        for folder in self.outputs.iter().filter(|o| o.role == Role::Folder) {
            if let Some(other) = self.outputs.iter().find(|o| o.role == Role::File && folder.at.holds(&o.at).is_some())
            {
                bail!(
                    "{} is inside {}: a session folder holds only the session; write it beside it",
                    other.name,
                    folder.name
                );
            }
        }
        Ok(())
    }

    /// A model registered and checked at once, before it is read: one found by [`Files::check`],
    /// or one learnt only once the work has started (the model a loaded session or config names),
    /// which is the one the check already saw unless it could not read the file naming it.
    ///
    /// # Errors
    /// The URDF or its companion is one of the outputs.
    pub(crate) fn check_model(&mut self, urdf: &Path) -> Result<()> {
        let from = self.inputs.len();
        self.model(urdf);
        for input in &self.inputs[from..] {
            for output in &self.outputs {
                check_pair(output, input)?;
            }
        }
        Ok(())
    }
}

fn check_pair(output: &Output, input: &Input) -> Result<()> {
    if let Some(reach) = output.at.reaches(&input.at) {
        let named = if reach == Reach::Same && output.path == input.path { &input.short } else { &input.label };
        bail!("{} is an input of this command ({named}{}): refusing to overwrite it", output.name, reach.how());
    }
    if output.role == Role::Folder
        && let Some(reach) = output.at.holds(&input.at)
    {
        bail!(
            "{} contains an input of this command ({}{}): refusing to write into it",
            output.name,
            input.label,
            reach.how()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files(dir: &Path) -> Files {
        let mut files = Files::new();
        files.input("--joints", &dir.join("j.csv"));
        files
    }

    #[test]
    fn the_same_file_however_reached_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::write(dir.join("j.csv"), "x").unwrap();
        std::fs::create_dir(dir.join("sub")).unwrap();
        let spelled = dir.join("sub/../j.csv");
        let mut f = files(dir);
        f.output("--out", &spelled);
        let e = f.check().unwrap_err().to_string();
        assert!(e.contains("(--joints ") && e.ends_with("j.csv): refusing to overwrite it"), "{e}");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.join("j.csv"), dir.join("s.csv")).unwrap();
            std::fs::hard_link(dir.join("j.csv"), dir.join("h.csv")).unwrap();
            std::os::unix::fs::symlink(dir.join("none.csv"), dir.join("dangling.csv")).unwrap();
            for (name, how) in [("s.csv", "symbolic"), ("h.csv", "hard")] {
                let mut f = files(dir);
                f.output("--out", &dir.join(name));
                let e = f.check().unwrap_err().to_string();
                assert!(e.contains(&format!("through a {how} link")), "{e}");
            }
            // A link as the input, the file itself as the output.
            let mut f = Files::new();
            f.input("--joints", &dir.join("s.csv"));
            f.output("--out", &dir.join("j.csv"));
            assert!(f.check().unwrap_err().to_string().contains("through a symbolic link"));
            // A dangling link leads to the file a write through it would create.
            let mut f = Files::new();
            f.session("--dataset", dir);
            f.output("--out", &dir.join("dangling.csv"));
            assert!(f.check().is_ok());
            let mut f = Files::new();
            f.input("--joints", &dir.join("none.csv"));
            f.output("--out", &dir.join("dangling.csv"));
            assert!(f.check().unwrap_err().to_string().contains("through a symbolic link"));
        }
    }

    #[test]
    fn other_files_folders_that_hold_inputs_and_outputs_given_twice() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::write(dir.join("j.csv"), "x").unwrap();
        let mut f = files(dir);
        f.output("--out", &dir.join("k.csv"));
        f.output("--rrd", &dir.join("missing/r.rrd"));
        assert!(f.check().is_ok());
        let mut f = files(dir);
        f.session_output("--out", dir);
        let e = f.check().unwrap_err().to_string();
        assert!(e.contains("contains an input of this command (--joints "), "{e}");
        let mut f = Files::new();
        f.output("--out", &dir.join("k.csv"));
        std::fs::create_dir(dir.join("sub")).unwrap();
        f.output("--rrd", &dir.join("sub/../k.csv"));
        assert!(f.check().unwrap_err().to_string().ends_with("k.csv: is given as two different outputs"));
        let mut f = Files::new();
        f.input("--params", &dir.join("p.yaml"));
        f.model_output("--urdf", &dir.join("p.urdf"));
        let e = f.check().unwrap_err().to_string();
        assert!(
            e.contains("p.yaml (the companion of --urdf ") && e.contains("is an input of this command (--params)"),
            "{e}"
        );
    }
}
