//! The command line's arguments (clap): what each command takes.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use spmcal::dataset::Session;
use spmcal::model::{Parameters, RobotModel, Spm};
use spmcal::vision::Method;

/// Calibration of spherical parallel manipulators (the Agile Wrist) from joints and camera markers.
#[derive(Parser)]
#[command(name = "spmcal", version, about)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Inverse kinematics: MP orientations in, working-mode joint readings out.
    Ik(IkArgs),
    /// Forward displacement analysis: joint readings in, MP orientations out.
    Fda(FdaArgs),
    /// Simulate a session with ground truth (true geometry, stereo camera, occlusion, collisions).
    Simulate(SimulateArgs),
    /// Estimate the MP orientation of every pose of a session from its markers.
    Estimate(EstimateArgs),
    /// Identify the link and misalignment parameters from a session; write a parameters file.
    Calibrate(CalibrateArgs),
    /// Compare FDA-predicted with vision-measured orientations, nominal and calibrated.
    Compare(CompareArgs),
    /// Write a session, pose by pose, as a Rerun recording to open offline.
    Replay(ReplayArgs),
    /// Choose the poses to capture that buy the most accuracy, in an order to follow.
    Plan(PlanArgs),
    /// Write a calibrated URDF and its companion from a parameters file.
    Export(ExportArgs),
}

#[derive(Args)]
pub(crate) struct ExportArgs {
    /// The (calibrated) parameters file.
    #[arg(long)]
    pub(crate) params: PathBuf,
    /// The URDF to write; its companion `.yaml` is written beside it.
    #[arg(long)]
    pub(crate) urdf: PathBuf,
    /// The model whose URDF is copied (default: the parameters file's `model`, else the nominal one).
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct PlanArgs {
    /// Poses to plan.
    #[arg(long)]
    pub(crate) poses: usize,
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// Simulation settings (YAML) giving the workspace, the camera and its noise; default:
    /// `configs/simulate_agile_wrist.yaml`'s values.
    #[arg(long)]
    pub(crate) config: Option<PathBuf>,
    /// Candidate poses drawn from the workspace.
    #[arg(long, default_value_t = 2000)]
    pub(crate) candidates: usize,
    /// Plan the poses that add most to this session.
    #[arg(long)]
    pub(crate) augment: Option<PathBuf>,
    /// Candidates must pass the workspace checks and keep their markers this far beyond (tilt
    /// outwards, yaw either way), degrees: how far the real mechanism and hand may be from the model.
    #[arg(long, default_value_t = 2.0)]
    pub(crate) margin_deg: f64,
    /// The plan to write (`step,qw,qx,qy,qz,theta1_rad,theta2_rad,theta3_rad`).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Also write a Rerun recording of the plan here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct ReplayArgs {
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// Parameters (e.g. calibrated) that draw the mechanism; default: the nominal model.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
    /// The recording to write.
    #[arg(long)]
    pub(crate) rrd: PathBuf,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

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

#[derive(Args)]
pub(crate) struct IkArgs {
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// CSV of orientations `pose,qw,qx,qy,qz` (MP → base, scalar first).
    #[arg(long, conflicts_with = "quat", required_unless_present = "quat")]
    pub(crate) orientations: Option<PathBuf>,
    /// One orientation as `qw,qx,qy,qz`.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub(crate) quat: Option<Vec<f64>>,
    /// Write `pose,theta1_rad,theta2_rad,theta3_rad` here (atomically) instead of standard output.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct FdaArgs {
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// CSV of joint readings `pose,theta1_rad,theta2_rad,theta3_rad`.
    #[arg(long)]
    pub(crate) joints: PathBuf,
    /// Every real assembly mode (up to 8) instead of the working mode.
    #[arg(long)]
    pub(crate) all_modes: bool,
    /// Write the orientations here (atomically) instead of standard output.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct SimulateArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    /// Simulation settings (YAML).
    #[arg(long)]
    pub(crate) config: PathBuf,
    /// The session folder to write (created; an existing session there is replaced).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Random seed (overrides the config's).
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Number of poses (overrides the config's).
    #[arg(long)]
    pub(crate) poses: Option<usize>,
    /// Session name (overrides the config's).
    #[arg(long)]
    pub(crate) name: Option<String>,
    /// Capture exactly the poses of this plan (`spmcal plan`), in its order.
    #[arg(long, conflicts_with = "poses")]
    pub(crate) plan: Option<PathBuf>,
    /// The URDF model (overrides the config's).
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
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

#[derive(Args)]
pub(crate) struct EstimateArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// `paper` (least squares + polar decomposition) or `kabsch` (optimal rotation).
    #[arg(long, value_enum, default_value = "paper")]
    pub(crate) method: MethodArg,
    /// Write `pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m` here (atomically) instead of standard output.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct CalibrateArgs {
    /// Print every iteration of the fit (RMS, step, trust radius, ratio) on standard error.
    #[arg(long, short)]
    pub(crate) verbose: bool,
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    /// Also write a report a person can read and share here: one self-contained HTML file.
    #[arg(long)]
    pub(crate) report: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// Calibration settings (default: the built-in values, as in configs/calibrate.yaml).
    #[arg(long)]
    pub(crate) config: Option<PathBuf>,
    /// The calibrated parameters file to write (atomically).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct CompareArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// A parameters file (e.g. calibrated) to compare beside the nominal model.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
    /// Vision estimator.
    #[arg(long, value_enum, default_value = "kabsch")]
    pub(crate) method: MethodArg,
    /// Compare orientations (degrees, from the per-pose estimator) or markers (millimetres);
    /// default: orientations where a pose sees three markers, markers otherwise.
    #[arg(long, value_enum)]
    pub(crate) level: Option<LevelArg>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum LevelArg {
    Orientations,
    Markers,
}

impl From<LevelArg> for spmcal::calib::FitLevel {
    fn from(l: LevelArg) -> Self {
        match l {
            LevelArg::Orientations => spmcal::calib::FitLevel::Orientations,
            LevelArg::Markers => spmcal::calib::FitLevel::Markers,
        }
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
