//! `spmcal replay`: a session, pose by pose, as a Rerun recording to open offline.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use spmcal::model::{Parameters, RobotModel};

use super::args::SessionArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, record};

#[derive(Args)]
pub(crate) struct ReplayArgs {
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// Parameters (e.g. calibrated) that draw the mechanism, their camera model correcting the
    /// markers; default: the nominal model and the markers as measured.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
    /// A session seen through its cameras' pixels: see them through this rig instead of the
    /// session's cameras.yaml (a Kalibr camchain, e.g. the one `calibrate --cameras-out` wrote):
    /// its cameras' image planes, and the points it triangulates.
    #[arg(long)]
    pub(crate) cameras: Option<PathBuf>,
    /// The recording to write.
    #[arg(long)]
    pub(crate) rrd: PathBuf,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn run(args: ReplayArgs) -> Result<()> {
    let mut files = Files::new();
    files.output("--rrd", &args.rrd);
    args.session.register(&mut files, true);
    files.input_opt("--params", args.params.as_deref());
    files.input_opt("--cameras", args.cameras.as_deref());
    files.check()?;
    let mut outputs = Outputs::new();
    let slot = outputs.reserve(&args.rrd)?;
    let (session, mut warnings, notes) = args.session.load()?;
    files.check_model(&session.model)?;
    let model = RobotModel::load(&session.model)?;
    let params = args.params.as_deref().map(Parameters::read).transpose()?;
    let mut session = args.session.seen_through(session, args.cameras.as_deref())?;
    if let (Some(path), Some(p)) = (&args.params, &params) {
        warnings.extend(p.check_model(path, &model)?);
        session = SessionArgs::at_latency(session, path, p, &mut warnings);
        session = SessionArgs::corrected(session, path, p)?;
    }
    let scene = spmcal::record::Scene::replay(&session, &model, params.as_ref())
        .map_err(|e| super::args::about(&args.session.dataset, e))?;
    let summary = record(&outputs, slot, &scene)?;
    outputs.commit()?;
    if args.json {
        let mut envelope = Envelope::new("replay", summary).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        envelope.notes = notes;
        out(&(envelope.to_json() + "\n"))?;
    }
    Ok(())
}
