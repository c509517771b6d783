//! `spmcal plan`: the capture plan, its summary, and optionally a recording of it.

use anyhow::{Result, anyhow};
use spmcal::dataset::Session;
use spmcal::plan::{PlanSettings, plan_csv};
use spmcal::sim::SimConfig;

use super::args::PlanArgs;
use super::envelope::Envelope;
use super::output::{Outputs, out, record, reserve};

pub(crate) fn run(args: PlanArgs) -> Result<()> {
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
    let (model, params) = args.geometry.model_and_params()?;
    let augment = args.augment.as_deref().map(|dir| Session::load(dir, None)).transpose()?.map(|(s, _)| s);
    let settings = PlanSettings {
        poses: args.poses,
        candidates: args.candidates,
        margin_deg: args.margin_deg,
        ..PlanSettings::default()
    };
    if settings.poses == 0 {
        anyhow::bail!("--poses must be at least 1");
    }
    if !(settings.margin_deg.is_finite() && (0.0..=20.0).contains(&settings.margin_deg)) {
        anyhow::bail!("--margin-deg must be between 0 and 20 degrees (got {})", settings.margin_deg);
    }
    let plan = spmcal::plan::plan(&model, params.as_ref(), &config, &settings, augment.as_ref())?;
    outputs.write(slot, plan_csv(&plan.poses).as_bytes())?;
    if let Some(slot) = rrd {
        let session = plan.session(&model);
        record(&outputs, slot, &spmcal::record::plan_scene(&session, &model, &plan, params.as_ref())?)?;
    }
    outputs.commit()?;
    if args.json {
        return out(&(Envelope::new("plan", &plan.summary).input("out", args.out.display()).to_json() + "\n"));
    }
    out(&format!("{}wrote {}\n", plan.summary, args.out.display()))
}
