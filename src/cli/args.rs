//! The arguments several commands share: which geometry, which session, which estimator.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use spmcal::dataset::Session;
use spmcal::model::{Parameters, RobotModel, Spm};
use spmcal::vision::Method;

use super::files::{Files, session_model};

/// The model used where none is named: the shipped Agile Wrist.
pub(crate) const DEFAULT_MODEL: &str = "agile_wrist";

/// Which manipulator geometry to use.
#[derive(Args)]
pub(crate) struct GeometryArgs {
    /// The model: a shipped model's name (agile_wrist, orbita3d) or a URDF's path, its companion
    /// `.yaml` beside it [default: the parameters file's model, else agile_wrist].
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// A parameters file (nominal or calibrated) to use instead of the model's nominal geometry.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
}

impl GeometryArgs {
    /// The model, and the parameters file when one is given (its `model`, else `--model`); the
    /// model is checked against the outputs in `files` before it is read.
    pub(crate) fn model_and_params(&self, files: &mut Files) -> Result<(RobotModel, Option<Parameters>)> {
        let params = self.params.as_deref().map(Parameters::read).transpose()?;
        match (&self.params, &params) {
            (Some(file), Some(p)) => {
                files.check_model(&p.model_reference(self.model.as_deref()))?;
                // The model the parameters name (found by identity when moved), which they must
                // fit (legs in order, the same markers).
                let (model, warnings) = p.load_model(file, self.model.as_deref())?;
                for w in warnings {
                    super::output::warn(w);
                }
                Ok((model, params))
            }
            _ => {
                let path = self.model_path();
                files.check_model(&path)?;
                Ok((RobotModel::load(&path)?, params))
            }
        }
    }

    /// `--model`, else the default model.
    pub(crate) fn model_path(&self) -> PathBuf {
        self.model.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_MODEL))
    }

    /// Register what [`GeometryArgs::model_and_params`] reads: the parameters file, and the model
    /// it names, else `--model`.
    pub(crate) fn register_model_and_params(&self, files: &mut Files) {
        match &self.params {
            Some(path) => {
                files.input("--params", path);
                let (path, model) = (path.clone(), self.model.clone());
                files.model_named_by(move || Some(Parameters::read(&path).ok()?.model_reference(model.as_deref())));
            }
            None => files.model(&self.model_path()),
        }
    }

    /// Register what [`GeometryArgs::spm`] reads: the parameters file when one is given (the model
    /// is not read then), else the model.
    pub(crate) fn register_spm(&self, files: &mut Files) {
        match &self.params {
            Some(path) => files.input("--params", path),
            None => files.model(&self.model_path()),
        }
    }

    pub(crate) fn spm(&self) -> Result<Spm> {
        match &self.params {
            Some(path) => {
                let params = Parameters::read(path)?;
                params.spm().with_context(|| format!("{}", path.display()))
            }
            None => Ok(RobotModel::load(&self.model_path())?.spm),
        }
    }
}

/// Which session, and optionally which model instead of the session's.
#[derive(Args)]
pub(crate) struct SessionArgs {
    /// The session folder, or a ROS 2 bag (an `.mcap` file or a bag folder).
    #[arg(long)]
    pub(crate) dataset: PathBuf,
    /// The model (overrides the session's): a shipped model's name (agile_wrist, orbita3d) or a
    /// URDF's path.
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
}

/// An error of work on the session at `dataset` as a whole, named by it (an error that names one
/// of its files already is left as it is).
pub(crate) fn about(dataset: &std::path::Path, error: impl std::fmt::Display) -> anyhow::Error {
    let (text, place) = (error.to_string(), dataset.display().to_string());
    match text.starts_with(&place) {
        true => anyhow::anyhow!(text),
        false => anyhow::anyhow!("{place}: {text}"),
    }
}

impl SessionArgs {
    /// Register the session folder and the files its reader looks for, and, when the command reads
    /// it, the model: `--model`, else the one `session.yaml` names.
    pub(crate) fn register(&self, files: &mut Files, reads_model: bool) {
        files.session("--dataset", &self.dataset);
        match (&self.model, reads_model) {
            (_, false) => {}
            (Some(model), true) => files.model(model),
            (None, true) => {
                let dir = self.dataset.clone();
                files.model_named_by(move || session_model(&dir));
            }
        }
    }

    /// Load the session, printing its warnings on standard error; the warnings also go to `--json`.
    /// The session at a parameters file's camera clock (a free-motion recording: its latency and
    /// clock rate), and a warning when frames fall outside the encoder stream there (printed, and
    /// added to `warnings`).
    pub(crate) fn at_latency(
        session: Session,
        params: &std::path::Path,
        parameters: &Parameters,
        warnings: &mut Vec<String>,
    ) -> Session {
        let Some(latency_s) = parameters.latency_s.filter(|_| session.streams.is_some()) else { return session };
        let rate_ppm = parameters.clock_rate_ppm.unwrap_or(0.0);
        let (moved, dropped) = session.at_clock(latency_s, rate_ppm);
        if let Some(first) = dropped.first() {
            let warning = format!(
                "{}: at its latency_s = {latency_s} s and clock_rate_ppm = {rate_ppm}, {} of {} camera frames fall outside the encoder stream and were left out (first: {})",
                params.display(),
                dropped.len(),
                moved.poses.len() + dropped.len(),
                match &first.topic {
                    Some(topic) => format!("{}, {topic}, message {}", first.path.display(), first.line),
                    None => format!("{}:{}", first.path.display(), first.line),
                }
            );
            super::output::warn(&warning);
            warnings.push(warning);
        }
        moved
    }

    /// `--cameras`: the pixel session seen through that camchain instead of its own (a session of
    /// points has no pixels to see: an error naming it).
    pub(crate) fn seen_through(&self, session: Session, cameras: Option<&std::path::Path>) -> Result<Session> {
        match cameras {
            Some(path) if session.rig.is_none() => anyhow::bail!(
                "--cameras {}: {} is a session of points, not pixels (pixels.csv + cameras.yaml): there are no pixels to see through a rig",
                path.display(),
                self.dataset.display()
            ),
            Some(path) => {
                let rig = spmcal::model::Rig::read(path)?;
                let own = session.rig.as_deref().expect("a pixel session");
                same_cameras(own, &rig).map_err(|why| anyhow::anyhow!("--cameras {}: {why}", path.display()))?;
                Ok(session.seen_through(&rig))
            }
            None => Ok(session),
        }
    }

    /// The session as the camera model of the parameters file at `params` corrects it (every
    /// marker by `K⁻¹`): what a perfect camera would have reported.
    pub(crate) fn corrected(session: Session, params: &std::path::Path, p: &Parameters) -> Result<Session> {
        session.undistorted(&p.camera_model).ok_or_else(|| {
            anyhow::anyhow!("{}: the camera model is singular: the markers cannot be corrected", params.display())
        })
    }

    /// The session, with what its loading found: warnings, and notes (expected, harmless), each
    /// printed and returned as text for `--json`.
    pub(crate) fn load(&self) -> Result<(Session, Vec<String>, Vec<String>)> {
        let (session, found) = load_session(&self.dataset, self.model.as_deref())?;
        let (notes, warnings): (Vec<_>, Vec<_>) = found.iter().partition(|w| w.note);
        let (notes, warnings): (Vec<String>, Vec<String>) =
            (notes.iter().map(|w| w.to_string()).collect(), warnings.iter().map(|w| w.to_string()).collect());
        warnings.iter().for_each(super::output::warn);
        notes.iter().for_each(super::output::note);
        Ok((session, warnings, notes))
    }
}

/// Whether `other` is a camchain of the cameras of the session's `own` (its `cameras.yaml`): the
/// same cameras, in order, of the same image sizes — its pixels were read against that size, and
/// a camera's pixels seen through another's lens would make points of nothing, without a word.
fn same_cameras(own: &spmcal::model::Rig, other: &spmcal::model::Rig) -> std::result::Result<(), String> {
    let names = |rig: &spmcal::model::Rig| rig.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>().join(", ");
    if names(own) != names(other) {
        return Err(format!(
            "its cameras ({}) are not the session's ({}, its cameras.yaml): a camchain of the same rig is needed",
            names(other),
            names(own)
        ));
    }
    for (a, b) in own.cameras.iter().zip(&other.cameras) {
        let ([w, h], [w0, h0]) = (b.lens.resolution, a.lens.resolution);
        if [w, h] != [w0, h0] {
            return Err(format!(
                "camera `{}`'s image is {w} × {h} pixels in it, {w0} × {h0} in the session's cameras.yaml, whose pixels.csv was read at that size: a camchain of the same rig is needed",
                b.name
            ));
        }
    }
    Ok(())
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum MethodArg {
    Paper,
    Kabsch,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Method {
        match m {
            MethodArg::Paper => Method::Paper,
            MethodArg::Kabsch => Method::Kabsch,
        }
    }
}

/// Load a session folder or a bag, a bag with a progress bar (by bytes).
pub(crate) fn load_session(
    path: &std::path::Path,
    model: Option<&std::path::Path>,
) -> Result<(Session, Vec<spmcal::dataset::Warning>)> {
    let bar = super::output::progress_bar(0, "reading");
    let loaded = Session::load_with_progress(path, model, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    });
    bar.finish_and_clear();
    Ok(loaded?)
}
