//! `spmcal simulate`: a synthetic session with ground truth, and optionally a recording of it.

use anyhow::{Result, anyhow};
use spmcal::dataset::Session;
use spmcal::model::RobotModel;
use spmcal::sim::SimConfig;

use super::args::SimulateArgs;
use super::envelope::Envelope;
use super::output::{Outputs, out, progress_bar, record, reserve};

pub(crate) fn run(args: SimulateArgs) -> Result<()> {
    let mut config = SimConfig::read(&args.config)?;
    config.seed = args.seed.unwrap_or(config.seed);
    config.poses = args.poses.unwrap_or(config.poses);
    config.name = args.name.unwrap_or(config.name);
    if let Some(path) = &args.plan {
        let plan = spmcal::plan::read_plan(path)?;
        config.poses = plan.len();
        config.plan = Some(plan.iter().map(|p| p.rotation).collect());
    }
    if let Some(model) = args.model {
        config.model = model;
    }
    config.check().map_err(|(key, reason)| anyhow!("{}: `{key}`: {reason}", args.config.display()))?;
    Session::check_destination(&args.out)?;
    let mut outputs = Outputs::new();
    let rrd = reserve(&mut outputs, args.rrd.as_deref())?;
    let model = RobotModel::load(&config.model)?;
    let bar = progress_bar(config.poses, "simulating");
    let (session, summary) = spmcal::sim::simulate(&config, &model, &mut |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    if let Some(slot) = rrd {
        record(&outputs, slot, &spmcal::record::simulation_scene(&session, &model)?)?;
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
