//! `spmcal calibrate`: the fit with a spinner (or every iteration with `-v`), the parameters
//! file, and optionally a recording and a shareable HTML report, written together.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use spmcal::calib::CalibConfig;
use spmcal::model::RobotModel;

use super::args::SessionArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, record, reserve};

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
    /// A pixel session (pixels.csv + cameras.yaml): also write the camera rig refined with the
    /// mechanism here, in Kalibr's camchain format (the baseline's length as the file gave it).
    #[arg(long)]
    pub(crate) cameras_out: Option<PathBuf>,
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

pub(crate) fn run(args: CalibrateArgs) -> Result<()> {
    let mut files = Files::new();
    files.output("--out", &args.out);
    files.output_opt("--rrd", args.rrd.as_deref());
    files.output_opt("--report", args.report.as_deref());
    files.output_opt("--cameras-out", args.cameras_out.as_deref());
    args.session.register(&mut files, true);
    files.input_opt("--config", args.config.as_deref());
    files.check()?;
    let mut outputs = Outputs::new();
    let (params_slot, rrd) = (outputs.reserve(&args.out)?, reserve(&mut outputs, args.rrd.as_deref())?);
    let html = reserve(&mut outputs, args.report.as_deref())?;
    let cameras = reserve(&mut outputs, args.cameras_out.as_deref())?;
    let (session, warnings, notes) = args.session.load()?;
    if cameras.is_some() && session.rig.is_none() {
        anyhow::bail!(
            "--cameras-out: {} is a session of points, not pixels (pixels.csv + cameras.yaml): it has no camera rig to refine",
            args.session.dataset.display()
        );
    }
    files.check_model(&session.model)?;
    let model = RobotModel::load(&session.model)?;
    let config = match &args.config {
        Some(path) => CalibConfig::read(path)?,
        None => CalibConfig::default(),
    };
    let spinner = indicatif::ProgressBar::new_spinner();
    if args.verbose {
        eprintln!(
            "stage        iteration   RMS (°|mm)  step         radius        ratio  accepted  solver        decrement (σ)"
        );
    }
    let calibration = spmcal::calib::calibrate(&session, &model, &config, &mut |it| {
        if args.verbose {
            let stage = if it.stage == "calibration" { "calibration" } else { "refit" };
            let solver = match it.solver {
                spmcal::calib::Solver::GaussNewton => "Gauss–Newton",
                spmcal::calib::Solver::Clarabel => "clarabel",
            };
            spinner.suspend(|| {
                eprintln!(
                    "{stage:<12} {:9} {:11.5} {:12.3e} {:13.3e} {:6.3}  {:<8}  {solver:<12}  {:.2e}",
                    it.iteration, it.rms, it.step, it.radius, it.ratio, it.accepted, it.decrement
                )
            });
        }
        spinner.set_message(format!("iteration {}: RMS {:.4}, step {:.2e}", it.iteration, it.rms, it.step));
        spinner.tick();
    })
    .with_context(|| match &args.config {
        Some(path) => format!("calibrating {} with {}", args.session.dataset.display(), path.display()),
        None => format!("calibrating {} with the built-in settings", args.session.dataset.display()),
    })?;
    spinner.finish_and_clear();
    if args.verbose {
        eprintln!("stage                          iterations   time (s)");
        for stage in &calibration.report.stages {
            eprintln!("{:<30} {:10} {:10.4}", stage.name, stage.iterations, stage.seconds);
        }
    }
    outputs.write(params_slot, calibration.parameters.to_yaml_at(&args.out).as_bytes())?;
    if let Some(slot) = rrd {
        record(&outputs, slot, &spmcal::record::Scene::calibration(&session, &model, &calibration)?)?;
    }
    if let Some(slot) = html {
        let text = calibration.report.to_string();
        outputs.write(slot, calibration.html(&text).as_bytes())?;
    }
    let refined = calibration.report.markers.as_ref().and_then(|m| m.rig.as_ref());
    if let (Some(slot), Some(rig)) = (cameras, refined) {
        outputs.write(slot, rig.refined.to_camchain().as_bytes())?;
    }
    outputs.commit()?;
    if args.json {
        let mut envelope = Envelope::new("calibrate", &calibration.report)
            .input("dataset", args.session.dataset.display())
            .input("out", args.out.display());
        // Every warning and note printed, the calibration's own too (also in `results`).
        envelope.warnings = warnings.into_iter().chain(calibration.report.warnings.iter().cloned()).collect();
        envelope.notes = notes.into_iter().chain(calibration.report.notes.iter().cloned()).collect();
        out(&(envelope.to_json() + "\n"))
    } else {
        out(&format!("{}wrote {}\n", calibration.report, args.out.display()))
    }
}
