//! `spmcal plan`: the capture plan, its summary, and optionally a recording of it.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use clap::Args;
use spmcal::dataset::Session;
use spmcal::model::CameraModelKind;
use spmcal::plan::{Plan, PlanSettings, PlannedPose};
use spmcal::sim::SimConfig;

use super::args::GeometryArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, record, reserve};

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
    /// The camera model the calibration will fit (as `calibrate`'s `camera_model`).
    #[arg(long, value_enum, default_value = "depth_scale")]
    pub(crate) camera_model: CameraModelArg,
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

pub(crate) fn run(args: PlanArgs) -> Result<()> {
    let mut files = Files::new();
    files.output("--out", &args.out);
    files.output_opt("--rrd", args.rrd.as_deref());
    files.input_opt("--config", args.config.as_deref());
    args.geometry.register_model_and_params(&mut files);
    if let Some(dir) = &args.augment {
        files.session("--augment", dir);
    }
    files.check()?;
    let mut outputs = Outputs::new();
    let slot = outputs.reserve(&args.out)?;
    let rrd = reserve(&mut outputs, args.rrd.as_deref())?;
    let config = match &args.config {
        Some(path) => {
            let config = SimConfig::read(path)?;
            config.check().map_err(|(key, reason)| anyhow!("{}: `{key}`: {reason}", path.display()))?;
            config
        }
        None => SimConfig::default(),
    };
    let (model, params) = args.geometry.model_and_params(&mut files)?;
    let augment = args.augment.as_deref().map(|dir| Session::load(dir, None)).transpose()?.map(|(s, _)| s);
    let settings = PlanSettings {
        poses: args.poses,
        candidates: args.candidates,
        margin_deg: args.margin_deg,
        camera_model: args.camera_model.into(),
        ..PlanSettings::default()
    };
    if settings.poses == 0 {
        anyhow::bail!("--poses must be at least 1");
    }
    if !(settings.margin_deg.is_finite() && (0.0..=20.0).contains(&settings.margin_deg)) {
        anyhow::bail!("--margin-deg must be between 0 and 20 degrees (got {})", settings.margin_deg);
    }
    let plan = Plan::design(&model, params.as_ref(), &config, &settings, augment.as_ref()).map_err(|e| match &args
        .augment
    {
        Some(dir) => super::args::about(dir, e),
        None => e.into(),
    })?;
    outputs.write(slot, PlannedPose::csv(&plan.poses).as_bytes())?;
    if let Some(slot) = rrd {
        let session = plan.session(&model);
        record(&outputs, slot, &spmcal::record::Scene::plan(&session, &model, &plan, params.as_ref())?)?;
    }
    outputs.commit()?;
    if args.json {
        return out(&(Envelope::new("plan", &plan.summary).input("out", args.out.display()).to_json() + "\n"));
    }
    out(&format!("{}wrote {}\n", plan.summary, args.out.display()))
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum CameraModelArg {
    Rigid,
    #[value(name = "depth_scale")]
    DepthScale,
    Affine,
}

impl From<CameraModelArg> for CameraModelKind {
    fn from(m: CameraModelArg) -> CameraModelKind {
        match m {
            CameraModelArg::Rigid => CameraModelKind::Rigid,
            CameraModelArg::DepthScale => CameraModelKind::DepthScale,
            CameraModelArg::Affine => CameraModelKind::Affine,
        }
    }
}
