//! The arguments several commands share: which geometry, which session, which estimator.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use spmcal::dataset::Session;
use spmcal::model::{Parameters, RobotModel, Spm};
use spmcal::vision::Method;

/// Which manipulator geometry to use.
#[derive(Args)]
pub(crate) struct GeometryArgs {
    /// The URDF model (its companion `.yaml` must sit beside it).
    #[arg(long, default_value = "models/agile_wrist.urdf")]
    pub(crate) model: PathBuf,
    /// A parameters file (nominal or calibrated) to use instead of the model's nominal geometry.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
}

impl GeometryArgs {
    /// The model, and the parameters file when one is given (its `model`, else `--model`).
    pub(crate) fn model_and_params(&self) -> Result<(RobotModel, Option<Parameters>)> {
        let params = self.params.as_deref().map(Parameters::read).transpose()?;
        let path = params.as_ref().and_then(|p| p.model.clone()).map_or_else(|| self.model.clone(), PathBuf::from);
        Ok((RobotModel::load(&path)?, params))
    }

    pub(crate) fn spm(&self) -> Result<Spm> {
        match &self.params {
            Some(path) => {
                let params = Parameters::read(path)?;
                params.spm().with_context(|| format!("{}", path.display()))
            }
            None => Ok(RobotModel::load(&self.model)?.spm),
        }
    }
}

/// Which session, and optionally which model instead of the session's.
#[derive(Args)]
pub(crate) struct SessionArgs {
    /// The session folder.
    #[arg(long)]
    pub(crate) dataset: PathBuf,
    /// The URDF model (overrides the session's).
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
}

impl SessionArgs {
    /// Load the session, printing its warnings on standard error; the warnings also go to `--json`.
    pub(crate) fn load(&self) -> Result<(Session, Vec<String>)> {
        let (session, warnings) = Session::load(&self.dataset, self.model.as_deref())?;
        let warnings: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        Ok((session, warnings))
    }
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
