//! `spmcal estimate`: the MP orientation of every pose of a session from its markers, as a table
//! and a summary, and optionally a recording.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use spmcal::math::so3;
use spmcal::model::{Parameters, RobotModel};
use spmcal::vision::{EstimateSummary, Method, SessionEstimate};

use super::args::{MethodArg, SessionArgs};
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, record, reserve, table_to};

#[derive(Args)]
pub(crate) struct EstimateArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    pub(crate) rrd: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) session: SessionArgs,
    /// A parameters file (e.g. calibrated) whose camera model corrects the markers first (and
    /// whose latency reads a free-motion recording).
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
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

pub(crate) fn run(args: EstimateArgs) -> Result<()> {
    let mut files = Files::new();
    files.output_opt("--out", args.out.as_deref());
    files.output_opt("--rrd", args.rrd.as_deref());
    // The model is read only to draw the recording.
    args.session.register(&mut files, args.rrd.is_some());
    files.input_opt("--params", args.params.as_deref());
    files.check()?;
    let mut outputs = Outputs::new();
    let (table_slot, rrd) = (reserve(&mut outputs, args.out.as_deref())?, reserve(&mut outputs, args.rrd.as_deref())?);
    let (mut session, mut warnings, notes) = args.session.load()?;
    if let Some(path) = &args.params {
        let p = Parameters::read(path)?;
        session = SessionArgs::at_latency(session, path, &p, &mut warnings);
        session = SessionArgs::corrected(session, path, &p)?;
    }
    let method: Method = args.method.into();
    let result = SessionEstimate::of(&session, method)?;
    if let Some(slot) = rrd {
        files.check_model(&session.model)?;
        let model = RobotModel::load(&session.model)?;
        record(&outputs, slot, &spmcal::record::Scene::estimate(&session, &model, &result)?)?;
    }
    table_to(&mut outputs, table_slot, args.json, &estimate_csv(&result))?;
    outputs.commit()?;
    let summary = EstimateSummary::of(&result);
    if args.json {
        let mut envelope = Envelope::new("estimate", summary).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        envelope.notes = notes;
        return out(&(envelope.to_json() + "\n"));
    }
    // The table may be on standard output: the human summary goes to standard error then.
    if args.out.is_some() {
        return out(&summary.to_string());
    }
    eprint!("{summary}");
    Ok(())
}

/// The table: `pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m`, numbers as every table of spmcal
/// writes them (the shortest text that reads back to the same value).
fn estimate_csv(result: &SessionEstimate) -> String {
    let mut table = String::from("pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m\n");
    let mut buffer = ryu::Buffer::new();
    for (pose, e) in &result.poses {
        let q = so3::to_wxyz(&e.rotation);
        let t = e.translation;
        let angle = so3::log(&e.rotation).norm().to_degrees();
        table.push_str(&pose.to_string());
        for x in [q[0], q[1], q[2], q[3], angle, e.error, t.x, t.y, t.z] {
            table.push(',');
            table.push_str(buffer.format(x));
        }
        table.push('\n');
    }
    table
}
