//! `spmcal simulate`: a synthetic session with ground truth, and optionally a recording of it.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use clap::Args;
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, progress_bar, record, reserve};

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
    /// Session name [default: the --out folder's name, so that two sessions of one config are told
    /// apart].
    #[arg(long)]
    pub(crate) name: Option<String>,
    /// Capture exactly the poses of this plan (`spmcal plan`), in its order.
    #[arg(long, conflicts_with = "poses")]
    pub(crate) plan: Option<PathBuf>,
    /// The model (overrides the config's): a shipped model's name (agile_wrist, orbita3d) or a
    /// URDF's path.
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn run(args: SimulateArgs) -> Result<()> {
    let mut files = Files::new();
    files.session_output("--out", &args.out);
    files.output_opt("--rrd", args.rrd.as_deref());
    files.input("--config", &args.config);
    files.input_opt("--plan", args.plan.as_deref());
    match &args.model {
        Some(model) => files.model(model),
        None => {
            let config = args.config.clone();
            files.model_named_by(move || SimConfig::read(&config).ok().map(|c| c.model));
        }
    }
    files.check()?;
    let mut config = SimConfig::read(&args.config)?;
    config.seed = args.seed.unwrap_or(config.seed);
    config.poses = args.poses.unwrap_or(config.poses);
    // Named after its folder unless told: one config simulated twice (other seeds, other counts)
    // makes two sessions, which must not share the config's name.
    let folder_name = args.out.file_name().and_then(|n| n.to_str()).filter(|n| !n.is_empty()).map(str::to_string);
    config.name = args.name.or(folder_name).unwrap_or(config.name);
    if let Some(path) = &args.plan {
        spmcal::plan::PlannedPose::read_into(path, &mut config)?;
    }
    if let Some(model) = args.model {
        config.model = model;
    }
    config.check().map_err(|(key, reason)| anyhow!("{}: `{key}`: {reason}", args.config.display()))?;
    files.check_model(&config.model)?;
    Session::check_destination(&args.out)?;
    let mut outputs = Outputs::new();
    let rrd = reserve(&mut outputs, args.rrd.as_deref())?;
    let model = RobotModel::load(&config.model)?;
    let bar = progress_bar(config.poses, "simulating");
    let (session, summary) = config.simulate(&model, &mut |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    if let Some(slot) = rrd {
        record(&outputs, slot, &spmcal::record::Scene::simulation(&session, &model)?)?;
    }
    session.write(&args.out)?;
    outputs.commit()?;
    if args.json {
        out(&(Envelope::new("simulate", &summary)
            .input("config", args.config.display())
            .input("out", args.out.display())
            .to_json()
            + "\n"))
    } else {
        out(&format!("{summary}wrote {}\n", args.out.display()))
    }
}
