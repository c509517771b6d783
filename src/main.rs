//! `spmcal` command line: argument parsing and printing only; the work is in the library.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::Parser;
use spmcal::dataset::{
    JointReading, OrientationRecord, Session, joints_csv, read_joints, read_orientations, write_orientations,
};
use spmcal::model::{Parameters, RobotModel};
use spmcal::record::Scene;
use spmcal::report::{self, Envelope};
use spmcal::sim::SimConfig;
use spmcal::so3;
use spmcal::vision::{Method, estimate_session};
use spmcal::{Outputs, Slot};

mod cli {
    pub(crate) mod args;
    pub(crate) mod calibrate;
    pub(crate) mod export;
    pub(crate) mod plan;
}
use cli::args::*;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed standard output (`spmcal … | head`) ends the program quietly, as other tools do.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, a cause only where the message so far does not already say it
/// (errors that print their source and also return it would otherwise say it twice).
fn describe(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1).map(|c| c.to_string()) {
        if !text.contains(&cause) {
            text = format!("{text}: {cause}");
        }
    }
    text
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Ik(args) => ik(args),
        Command::Fda(args) => fda(args),
        Command::Simulate(args) => simulate(args),
        Command::Estimate(args) => estimate(args),
        Command::Calibrate(args) => cli::calibrate::calibrate(args),
        Command::Compare(args) => compare(args),
        Command::Replay(args) => replay(args),
        Command::Plan(args) => cli::plan::plan(args),
        Command::Export(args) => cli::export::export(args),
    }
}

/// Print to standard output; a closed pipe is an error that `main` ends quietly on.
fn out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout.write_all(text.as_bytes())?;
    stdout.flush()?;
    Ok(())
}

/// Reserve an optional output before any work, so a failed run changes no file.
fn reserve(outputs: &mut Outputs, path: Option<&Path>) -> Result<Option<Slot>> {
    Ok(path.map(|p| outputs.reserve(p)).transpose()?)
}

/// The table goes to its `--out` file, else to standard output unless `--json` owns it.
fn table_to(outputs: &mut Outputs, slot: Option<Slot>, json: bool, table: &str) -> Result<()> {
    match slot {
        Some(slot) => outputs.write(slot, table.as_bytes())?,
        None if !json => out(table)?,
        None => {}
    }
    Ok(())
}

/// Write a recording into its reserved slot and say so on standard error.
fn record(outputs: &Outputs, slot: Slot, scene: &Scene) -> Result<spmcal::record::RecordingSummary> {
    let summary = spmcal::record::stage_recording(outputs, slot, scene)?;
    eprintln!("recording: {} ({} poses, {} bytes)", summary.path.display(), summary.poses, summary.bytes);
    Ok(summary)
}

fn ik(args: IkArgs) -> Result<()> {
    let mut outputs = Outputs::new();
    let slot = reserve(&mut outputs, args.out.as_deref())?;
    let spm = args.geometry.spm()?;
    let (source, orientations) = match (&args.orientations, &args.quat) {
        (Some(path), _) => (path.display().to_string(), read_orientations(path)?),
        (None, Some(q)) => {
            let &[w, x, y, z] = q.as_slice() else { bail!("--quat takes four numbers qw,qx,qy,qz, got {}", q.len()) };
            let rotation = so3::from_wxyz([w, x, y, z]).context("--quat is not a unit quaternion")?;
            ("--quat".to_string(), vec![OrientationRecord { pose: 0, mode: None, rotation, extra: vec![], line: 0 }])
        }
        (None, None) => bail!("give --orientations FILE or --quat qw,qx,qy,qz"),
    };
    let mut readings = Vec::with_capacity(orientations.len());
    for o in &orientations {
        let joints = spm.ik(&o.rotation).with_context(|| format!("{source}:{}: pose {}", o.line, o.pose))?;
        readings.push(JointReading { pose: o.pose, line: o.line, joints, time_s: None, station: None });
    }
    table_to(&mut outputs, slot, args.json, &joints_csv(&readings))?;
    outputs.commit()?;
    if args.json {
        let solutions: Vec<_> = readings.iter().map(|r| (r.pose, [r.joints[0], r.joints[1], r.joints[2]])).collect();
        out(&(Envelope::new("ik", solutions).input("orientations", &source).to_json() + "\n"))?;
    }
    Ok(())
}

fn fda(args: FdaArgs) -> Result<()> {
    let mut outputs = Outputs::new();
    let slot = reserve(&mut outputs, args.out.as_deref())?;
    let spm = args.geometry.spm()?;
    let readings = read_joints(&args.joints)?;
    let source = args.joints.display().to_string();
    let (records, poses) = report::fda(&spm, &readings, args.all_modes)
        .map_err(|(line, pose, e)| anyhow::anyhow!("{source}:{line}: pose {pose}: {e}"))?;
    table_to(&mut outputs, slot, args.json, &write_orientations(&records))?;
    outputs.commit()?;
    if args.json {
        let envelope = Envelope::new("fda", poses).input("joints", &source).input("all_modes", args.all_modes);
        out(&(envelope.to_json() + "\n"))?;
    }
    Ok(())
}

/// A progress bar on standard error for `total` steps (hidden when it is not a terminal).
fn progress_bar(total: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

fn simulate(args: SimulateArgs) -> Result<()> {
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
    config.check().map_err(|(key, reason)| anyhow::anyhow!("{}: `{key}`: {reason}", args.config.display()))?;
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

fn estimate(args: EstimateArgs) -> Result<()> {
    let mut outputs = Outputs::new();
    let (table_slot, rrd) = (reserve(&mut outputs, args.out.as_deref())?, reserve(&mut outputs, args.rrd.as_deref())?);
    let (session, warnings) = args.session.load()?;
    let method: Method = args.method.into();
    let result = estimate_session(&session, method)?;
    if let Some(slot) = rrd {
        let model = RobotModel::load(&session.model)?;
        record(&outputs, slot, &spmcal::record::estimate_scene(&session, &model, &result)?)?;
    }
    table_to(&mut outputs, table_slot, args.json, &report::estimate_csv(&result))?;
    outputs.commit()?;
    let summary = report::EstimateSummary::of(&result);
    if args.json {
        let mut envelope = Envelope::new("estimate", summary).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        return out(&(envelope.to_json() + "\n"));
    }
    // The table may be on standard output: the human summary goes to standard error then.
    if args.out.is_some() {
        return out(&summary.to_string());
    }
    eprint!("{summary}");
    Ok(())
}

fn compare(args: CompareArgs) -> Result<()> {
    let mut outputs = Outputs::new();
    let rrd = reserve(&mut outputs, args.rrd.as_deref())?;
    let (session, warnings) = args.session.load()?;
    let model = RobotModel::load(&session.model)?;
    let mut sets = vec![("nominal".to_string(), Parameters::nominal(&model.spm, None))];
    if let Some(path) = &args.params {
        let params = Parameters::read(path)?;
        let label = format!("{:?}", params.source).to_lowercase();
        sets.push((label, params));
    }
    // A free-motion recording is drawn at the parameters' latency (each set is compared at its own).
    let session = match sets.last().and_then(|(_, p)| p.latency_s) {
        Some(latency_s) => session.at_latency(latency_s).0,
        None => session,
    };
    let method: Method = args.method.into();
    let result = spmcal::compare::compare(&session, &model, &sets, method, args.level.map(Into::into))?;
    if let Some(slot) = rrd {
        record(&outputs, slot, &spmcal::record::comparison_scene(&session, &model, &sets, &result, method)?)?;
    }
    outputs.commit()?;
    if args.json {
        let mut envelope = Envelope::new("compare", &result).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        return out(&(envelope.to_json() + "\n"));
    }
    out(&report::comparison_csv(&result))?;
    for c in &result {
        eprint!("{c}");
    }
    Ok(())
}

fn replay(args: ReplayArgs) -> Result<()> {
    let mut outputs = Outputs::new();
    let slot = outputs.reserve(&args.rrd)?;
    let (session, warnings) = args.session.load()?;
    let model = RobotModel::load(&session.model)?;
    let params = args.params.as_deref().map(Parameters::read).transpose()?;
    let session = match params.as_ref().and_then(|p| p.latency_s) {
        Some(latency_s) => session.at_latency(latency_s).0,
        None => session,
    };
    let summary = record(&outputs, slot, &spmcal::record::replay_scene(&session, &model, params.as_ref())?)?;
    outputs.commit()?;
    if args.json {
        let mut envelope = Envelope::new("replay", summary).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        out(&(envelope.to_json() + "\n"))?;
    }
    Ok(())
}
