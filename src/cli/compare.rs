//! `spmcal compare`: model against camera, per pose, for the nominal model and a parameters file.

use std::collections::BTreeSet;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use spmcal::compare::SetComparison;
use spmcal::model::{Parameters, RobotModel};
use spmcal::vision::Method;

use super::args::{MethodArg, SessionArgs};
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, record, reserve};

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
    /// A session seen through its cameras' pixels: see them through this rig instead of the
    /// session's cameras.yaml (a Kalibr camchain, e.g. the one `calibrate --cameras-out` wrote).
    #[arg(long)]
    pub(crate) cameras: Option<PathBuf>,
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

pub(crate) fn run(args: CompareArgs) -> Result<()> {
    let mut files = Files::new();
    files.output_opt("--rrd", args.rrd.as_deref());
    args.session.register(&mut files, true);
    files.input_opt("--params", args.params.as_deref());
    files.input_opt("--cameras", args.cameras.as_deref());
    files.check()?;
    let mut outputs = Outputs::new();
    let rrd = reserve(&mut outputs, args.rrd.as_deref())?;
    let (session, mut warnings, notes) = args.session.load()?;
    files.check_model(&session.model)?;
    let model = RobotModel::load(&session.model)?;
    // The model's own camera model (an exported calibration carries one) corrects its markers.
    let nominal = Parameters { camera_model: model.camera_model, ..Parameters::nominal(&model.spm, None) };
    let mut sets = vec![("nominal".to_string(), nominal)];
    let mut session = args.session.seen_through(session, args.cameras.as_deref())?;
    if let Some(path) = &args.params {
        let params = Parameters::read(path)?;
        warnings.extend(params.check_model(path, &model)?);
        // A free-motion recording is drawn at the parameters' latency.
        session = SessionArgs::at_latency(session, path, &params, &mut warnings);
        let label = format!("{:?}", params.source).to_lowercase();
        sets.push((label, params));
    }
    let method: Method = args.method.into();
    let dataset = &args.session.dataset;
    let result = spmcal::compare::compare(&session, &model, &sets, method, args.level.map(Into::into))
        .map_err(|e| super::args::about(dataset, e))?;
    if let Some(slot) = rrd {
        record(&outputs, slot, &spmcal::record::Scene::comparison(&session, &model, &sets, &result, method)?)?;
    }
    outputs.commit()?;
    if args.json {
        let mut envelope = Envelope::new("compare", &result).input("dataset", args.session.dataset.display());
        envelope.warnings = warnings;
        envelope.notes = notes;
        return out(&(envelope.to_json() + "\n"));
    }
    out(&comparison_csv(&result))?;
    for c in &result {
        eprint!("{c}");
    }
    Ok(())
}

/// The table: one row per pose any set predicts, one column per set (empty where that set's FDA
/// failed).
fn comparison_csv(results: &[SetComparison]) -> String {
    let mut table = String::from("pose");
    for c in results {
        table.push_str(&format!(",{}_{}", c.label, c.unit));
    }
    table.push('\n');
    let poses: BTreeSet<u64> = results.iter().flat_map(|c| c.per_pose.iter().map(|(p, _)| *p)).collect();
    for pose in poses {
        table.push_str(&pose.to_string());
        for c in results {
            let value = c.per_pose.iter().find(|(p, _)| *p == pose).map_or(String::new(), |(_, a)| format!("{a:.5}"));
            table.push_str(&format!(",{value}"));
        }
        table.push('\n');
    }
    table
}
