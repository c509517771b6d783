//! `spmcal` command line: argument parsing and printing only; the work is in the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use serde_json::json;
use spmcal::calib::{CalibConfig, CalibrationReport, ErrorSummary};
use spmcal::dataset::Session;
use spmcal::dataset::{JointReading, OrientationRecord, read_joints, read_orientations, write_orientations};
use spmcal::files::{number, write_atomic};
use spmcal::model::{Parameters, RobotModel, Spm};
use spmcal::sim::SimConfig;
use spmcal::so3;
use spmcal::vision::{Method, SessionEstimate, Stats, estimate_session};

/// Calibration of spherical parallel manipulators (the Agile Wrist) from joints and camera markers.
#[derive(Parser)]
#[command(name = "spmcal", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
}

#[derive(Args)]
struct ReplayArgs {
    #[command(flatten)]
    session: SessionArgs,
    /// Parameters (e.g. calibrated) that draw the mechanism; default: the nominal model.
    #[arg(long)]
    params: Option<PathBuf>,
    /// The recording to write.
    #[arg(long)]
    rrd: PathBuf,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    json: bool,
}

/// Which manipulator geometry to use.
#[derive(Args)]
struct GeometryArgs {
    /// The URDF model (its companion `.yaml` must sit beside it).
    #[arg(long, default_value = "models/agile_wrist.urdf")]
    model: PathBuf,
    /// A parameters file (nominal or calibrated) to use instead of the model's nominal geometry.
    #[arg(long)]
    params: Option<PathBuf>,
}

impl GeometryArgs {
    fn spm(&self) -> Result<Spm> {
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
struct IkArgs {
    #[command(flatten)]
    geometry: GeometryArgs,
    /// CSV of orientations `pose,qw,qx,qy,qz` (MP → base, scalar first).
    #[arg(long, conflicts_with = "quat", required_unless_present = "quat")]
    orientations: Option<PathBuf>,
    /// One orientation as `qw,qx,qy,qz`.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    quat: Option<Vec<f64>>,
    /// Write `pose,theta1_rad,theta2_rad,theta3_rad` here (atomically) instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct FdaArgs {
    #[command(flatten)]
    geometry: GeometryArgs,
    /// CSV of joint readings `pose,theta1_rad,theta2_rad,theta3_rad`.
    #[arg(long)]
    joints: PathBuf,
    /// Every real assembly mode (up to 8) instead of the working mode.
    #[arg(long)]
    all_modes: bool,
    /// Write the orientations here (atomically) instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct SimulateArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Simulation settings (YAML).
    #[arg(long)]
    config: PathBuf,
    /// The session folder to write (created; an existing session there is replaced).
    #[arg(long)]
    out: PathBuf,
    /// Random seed (overrides the config's).
    #[arg(long)]
    seed: Option<u64>,
    /// Number of poses (overrides the config's).
    #[arg(long)]
    poses: Option<usize>,
    /// Session name (overrides the config's).
    #[arg(long)]
    name: Option<String>,
    /// The URDF model (overrides the config's).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    json: bool,
}

/// Which session, and optionally which model instead of the session's.
#[derive(Args)]
struct SessionArgs {
    /// The session folder.
    #[arg(long)]
    dataset: PathBuf,
    /// The URDF model (overrides the session's).
    #[arg(long)]
    model: Option<PathBuf>,
}

impl SessionArgs {
    /// Load the session, printing its warnings on standard error.
    fn load(&self) -> Result<Session> {
        let (session, warnings) = Session::load(&self.dataset, self.model.as_deref())?;
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        Ok(session)
    }
}

#[derive(Args)]
struct EstimateArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    rrd: Option<PathBuf>,
    #[command(flatten)]
    session: SessionArgs,
    /// `paper` (least squares + polar decomposition) or `kabsch` (optimal rotation).
    #[arg(long, value_enum, default_value = "paper")]
    method: MethodArg,
    /// Write `pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m` here (atomically) instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct CalibrateArgs {
    /// Print every iteration of the fit (RMS, step, trust radius, ratio) on standard error.
    #[arg(long, short)]
    verbose: bool,
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    rrd: Option<PathBuf>,
    #[command(flatten)]
    session: SessionArgs,
    /// Calibration settings (default: the built-in values, as in configs/calibrate.yaml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// The calibrated parameters file to write (atomically).
    #[arg(long)]
    out: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct CompareArgs {
    /// Also write a Rerun recording of the run here (open it with `rerun FILE`).
    #[arg(long)]
    rrd: Option<PathBuf>,
    #[command(flatten)]
    session: SessionArgs,
    /// A parameters file (e.g. calibrated) to compare beside the nominal model.
    #[arg(long)]
    params: Option<PathBuf>,
    /// Vision estimator.
    #[arg(long, value_enum, default_value = "kabsch")]
    method: MethodArg,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MethodArg {
    Paper,
    Kabsch,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Ik(args) => ik(args),
        Command::Fda(args) => fda(args),
        Command::Simulate(args) => simulate(args),
        Command::Estimate(args) => estimate(args),
        Command::Calibrate(args) => calibrate(args),
        Command::Compare(args) => compare(args),
        Command::Replay(args) => replay(args),
    }
}

/// Print `text`, or write it atomically to `out`.
fn emit(out: Option<&Path>, text: &str) -> Result<()> {
    match out {
        Some(path) => Ok(write_atomic(path, text.as_bytes())?),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

fn ik(args: IkArgs) -> Result<()> {
    let spm = args.geometry.spm()?;
    let (source, orientations) = match (&args.orientations, &args.quat) {
        (Some(path), _) => (path.display().to_string(), read_orientations(path)?),
        (None, Some(q)) => {
            let &[w, x, y, z] = q.as_slice() else { bail!("--quat takes four numbers qw,qx,qy,qz, got {}", q.len()) };
            let q = [w, x, y, z];
            let rotation = so3::from_wxyz([q[0], q[1], q[2], q[3]]).context("--quat is not a unit quaternion")?;
            ("--quat".to_string(), vec![OrientationRecord { pose: 0, mode: None, rotation, extra: vec![], line: 0 }])
        }
        (None, None) => bail!("give --orientations FILE or --quat qw,qx,qy,qz"),
    };
    let mut readings = Vec::with_capacity(orientations.len());
    for o in &orientations {
        let joints = spm.ik(&o.rotation).with_context(|| format!("{source}:{}: pose {}", o.line, o.pose))?;
        readings.push(JointReading { pose: o.pose, line: o.line, joints, time_s: None });
    }
    if args.json {
        let poses: Vec<_> = readings
            .iter()
            .map(|r| json!({"pose": r.pose, "joints_rad": [r.joints[0], r.joints[1], r.joints[2]]}))
            .collect();
        println!("{}", json!({"command": "ik", "poses": readings.len(), "solutions": poses}));
    }
    let mut text = String::from("pose,theta1_rad,theta2_rad,theta3_rad\n");
    for r in &readings {
        text.push_str(&format!("{},{},{},{}\n", r.pose, number(r.joints[0]), number(r.joints[1]), number(r.joints[2])));
    }
    if args.json && args.out.is_none() {
        return Ok(());
    }
    emit(args.out.as_deref(), &text)
}

fn fda(args: FdaArgs) -> Result<()> {
    let spm = args.geometry.spm()?;
    let readings = read_joints(&args.joints)?;
    let source = args.joints.display().to_string();
    let mut records = Vec::new();
    let mut summary = Vec::new();
    for r in &readings {
        if args.all_modes {
            let modes = spm.all_modes(&r.joints);
            let working = spm.forward(&r.joints).ok();
            let mut listed: Vec<_> = modes.iter().collect();
            // The working mode (continuation from home), when it exists, is mode 0.
            if let Some(w) = working {
                listed.sort_by_key(|m| so3::geodesic_angle(&m.rotation, &w) > 1e-8);
            }
            let mut pose_modes = Vec::new();
            for (k, m) in listed.iter().enumerate() {
                let is_working = working.is_some_and(|w| so3::geodesic_angle(&m.rotation, &w) < 1e-8);
                records.push(OrientationRecord {
                    pose: r.pose,
                    mode: Some(k),
                    rotation: m.rotation,
                    extra: vec![
                        ("branches".into(), m.branch_label()),
                        ("conditioning".into(), format!("{:.6}", m.conditioning)),
                        ("working".into(), is_working.to_string()),
                    ],
                    line: r.line,
                });
                pose_modes.push(json!({"mode": k, "q_wxyz": so3::to_wxyz(&m.rotation), "branches": m.branch_label(),
                    "conditioning": m.conditioning, "working": is_working}));
            }
            summary.push(json!({"pose": r.pose, "modes": pose_modes}));
        } else {
            let rotation = spm.forward(&r.joints).with_context(|| format!("{source}:{}: pose {}", r.line, r.pose))?;
            let conditioning = spmcal::model::conditioning_index(&spm.jacobians(&r.joints, &rotation).a);
            records.push(OrientationRecord { pose: r.pose, mode: None, rotation, extra: vec![], line: r.line });
            summary.push(json!({"pose": r.pose, "q_wxyz": so3::to_wxyz(&rotation), "conditioning": conditioning}));
        }
    }
    if args.json {
        println!(
            "{}",
            json!({"command": "fda", "all_modes": args.all_modes, "poses": readings.len(), "results": summary})
        );
        if args.out.is_none() {
            return Ok(());
        }
    }
    emit(args.out.as_deref(), &write_orientations(&records))
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
    if let Some(model) = args.model {
        config.model = model;
    }
    config.check().map_err(|(key, reason)| anyhow::anyhow!("{key}: {reason}"))?;
    let model = RobotModel::load(&config.model)?;
    let bar = progress_bar(config.poses, "simulating");
    let (session, summary) = spmcal::sim::simulate(&config, &model, &mut |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    session.write(&args.out)?;
    if let Some(path) = &args.rrd {
        record(path, &spmcal::record::simulation_scene(&session, &model)?)?;
    }
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "{}: {} poses written to {} ({} attempts; rejected: {} unreachable, {} near a singularity, {} colliding)",
            summary.name,
            summary.poses,
            args.out.display(),
            summary.attempts,
            summary.rejected_unreachable,
            summary.rejected_singular,
            summary.rejected_collision
        );
        println!(
            "markers: {} seen, {} occluded, {} outliers; {} poses with fewer than 3 markers",
            summary.markers_seen, summary.markers_occluded, summary.outliers, summary.poses_with_too_few_markers
        );
    }
    Ok(())
}

fn estimate(args: EstimateArgs) -> Result<()> {
    let session = args.session.load()?;
    let method: Method = args.method.into();
    let result = estimate_session(&session, method)?;
    if let Some(path) = &args.rrd {
        let model = RobotModel::load(&session.model)?;
        record(path, &spmcal::record::estimate_scene(&session, &model, &result)?)?;
    }
    let mut table = String::from("pose,qw,qx,qy,qz,angle_deg,e,tx_m,ty_m,tz_m\n");
    for (pose, e) in &result.poses {
        let q = so3::to_wxyz(&e.rotation);
        let t = e.translation;
        let angle = so3::log(&e.rotation).norm().to_degrees();
        let fields = [q[0], q[1], q[2], q[3], angle, e.error, t.x, t.y, t.z].map(number);
        table.push_str(&format!("{pose},{}\n", fields.join(",")));
    }
    let errors: Vec<f64> =
        result.poses.iter().filter(|(p, _)| *p != result.reference_pose).map(|(_, e)| e.error).collect();
    let iterations: Vec<f64> = result.poses.iter().map(|(_, e)| e.polar_iterations as f64).collect();
    let difference_deg: Vec<f64> = result.method_difference.iter().map(|a| a.to_degrees()).collect();
    let redundant = result.poses.iter().filter(|(_, e)| e.redundant).count();
    let summary = json!({
        "command": "estimate",
        "dataset": args.session.dataset.display().to_string(),
        "method": format!("{method:?}").to_lowercase(),
        "reference_pose": result.reference_pose,
        "poses_estimated": result.poses.len(),
        "poses_without_redundancy": result.poses.len() - redundant,
        "skipped": result.skipped.iter().map(|s| json!({"pose": s.pose, "reason": s.reason.to_string()})).collect::<Vec<_>>(),
        "e": Stats::of(&errors),
        "polar_iterations": Stats::of(&iterations),
        "paper_vs_kabsch_deg": Stats::of(&difference_deg),
        "centre_of_rotation": result.centre,
    });
    match (&args.out, args.json) {
        (Some(out), _) => write_atomic(out, table.as_bytes())?,
        (None, false) => print!("{table}"),
        (None, true) => {}
    }
    if args.json {
        println!("{summary}");
        return Ok(());
    }
    // The table may be on standard output: the human summary goes to standard error then.
    let report = estimate_report(&result, &errors, &difference_deg, redundant);
    if args.out.is_some() {
        print!("{report}")
    } else {
        eprint!("{report}")
    }
    Ok(())
}

fn estimate_report(result: &SessionEstimate, errors: &[f64], difference_deg: &[f64], redundant: usize) -> String {
    let mut r = format!(
        "{} poses estimated against pose {} ({} without redundancy), {} skipped\n",
        result.poses.len(),
        result.reference_pose,
        result.poses.len() - redundant,
        result.skipped.len()
    );
    const LISTED: usize = 10;
    for s in result.skipped.iter().take(LISTED) {
        r.push_str(&format!("  skipped {s}\n"));
    }
    if result.skipped.len() > LISTED {
        r.push_str(&format!("  … and {} more (all are listed by --json)\n", result.skipped.len() - LISTED));
    }
    if let Some(e) = Stats::of(errors) {
        r.push_str(&format!("e_j: mean {:.4}, median {:.4}, max {:.4}\n", e.mean, e.median, e.max));
    }
    if let Some(d) = Stats::of(difference_deg) {
        r.push_str(&format!("paper vs kabsch: mean {:.4}°, max {:.4}°\n", d.mean, d.max));
    }
    match &result.centre {
        Some(c) => r.push_str(&format!(
            "centre of rotation (camera frame): [{:.4}, {:.4}, {:.4}] m, residual RMS {:.2} mm, max {:.2} mm\n",
            c.position_m[0],
            c.position_m[1],
            c.position_m[2],
            c.rms_residual_m * 1e3,
            c.max_residual_m * 1e3
        )),
        None => r.push_str("centre of rotation: undetermined (rotations too few or all about one axis)\n"),
    }
    r
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Method {
        match m {
            MethodArg::Paper => Method::Paper,
            MethodArg::Kabsch => Method::Kabsch,
        }
    }
}

fn calibrate(args: CalibrateArgs) -> Result<()> {
    let session = args.session.load()?;
    let model = RobotModel::load(&session.model)?;
    let config = match &args.config {
        Some(path) => CalibConfig::read(path)?,
        None => CalibConfig::default(),
    };
    let spinner = indicatif::ProgressBar::new_spinner();
    if args.verbose {
        eprintln!("iteration   RMS (deg)   step (rad)   radius (rad)   ratio   accepted");
    }
    let calibration = spmcal::calib::calibrate(&session, &model, &config, &mut |it| {
        if args.verbose {
            spinner.suspend(|| {
                eprintln!(
                    "{:9} {:11.5} {:12.3e} {:14.3e} {:7.3} {}",
                    it.iteration, it.rms_deg, it.step, it.radius, it.ratio, it.accepted
                )
            });
        }
        spinner.set_message(format!("iteration {}: RMS {:.4}°, step {:.2e} rad", it.iteration, it.rms_deg, it.step));
        spinner.tick();
    })?;
    spinner.finish_and_clear();
    calibration.parameters.write(&args.out)?;
    if let Some(path) = &args.rrd {
        record(path, &spmcal::record::calibration_scene(&session, &model, &calibration)?)?;
    }
    if args.json {
        println!("{}", serde_json::to_string(&calibration.report)?);
    } else {
        print!("{}", calibration_report(&calibration.report, &args.out));
    }
    Ok(())
}

fn calibration_report(r: &CalibrationReport, out: &Path) -> String {
    let mut s = format!(
        "{}: {} poses, {} fitted, {} held out, {} excluded; vision {:?}, loss {:?}\n",
        r.session,
        r.poses,
        r.fit_poses,
        r.held_out_poses,
        r.excluded.len(),
        r.vision_method,
        r.loss
    );
    for e in r.excluded.iter().take(10) {
        s.push_str(&format!("  excluded {e}\n"));
    }
    s.push_str("FDA vs vision (deg)          RMS      median   max\n");
    let line = |label: &str, e: &ErrorSummary| {
        format!("  {label:<26} {:8.4} {:8.4} {:8.4}\n", e.rms_deg, e.median_deg, e.max_deg)
    };
    s.push_str(&line("nominal, fitted poses", &r.before.fit));
    s.push_str(&line("calibrated, fitted poses", &r.after.fit));
    if let (Some(b), Some(a)) = (&r.before.held_out, &r.after.held_out) {
        s.push_str(&line("nominal, held out", b));
        s.push_str(&line("calibrated, held out", a));
    }
    let converged = r.iterations.last().map_or(0, |l| l.iteration);
    s.push_str(&format!("converged in {converged} iterations\n"));
    s.push_str(&format!(
        "identifiability: {} of {} directions, condition number {:.3e}\n",
        r.identifiability.rank, r.identifiability.parameters, r.identifiability.condition
    ));
    for d in &r.identifiability.weakest {
        s.push_str(&format!("  weak: {}\n", d.describe()));
    }
    for d in &r.regularised {
        s.push_str(&format!("  REGULARISED (not identifiable, held at its start): {d}\n"));
    }
    s.push_str("parameter                    change (deg)   std error (deg)\n");
    for p in &r.parameters {
        match p.std_error_deg {
            Some(se) => s.push_str(&format!("  {:<26} {:+12.5} {:14.5}\n", p.name, p.change_deg, se)),
            None => s.push_str(&format!("  {:<26} {:+12.5}         frozen\n", p.name, p.change_deg)),
        }
    }
    if !r.not_significant.is_empty() {
        s.push_str(&format!(
            "not distinguishable from nominal (|change| < 2 std errors): {} of {}: {}\n",
            r.not_significant.len(),
            r.parameters.iter().filter(|p| !p.frozen).count(),
            r.not_significant.join(", ")
        ));
    }
    for c in r.high_correlations.iter().take(5) {
        s.push_str(&format!("  correlated: {} ~ {} (rho {:+.3})\n", c.a, c.b, c.rho));
    }
    for (markers, poses, sigma) in &r.residual_sigma_deg {
        s.push_str(&format!(
            "residual sigma, {poses} poses with {markers} markers: [{:.4}, {:.4}, {:.4}] deg (camera x, y, z)\n",
            sigma[0], sigma[1], sigma[2]
        ));
    }
    if let Some(u) = &r.orientation_uncertainty_deg {
        s.push_str(&format!(
            "predicted orientation uncertainty (1 sigma, as the camera sees it): mean {:.4} deg, max {:.4} deg\n",
            u.mean, u.max
        ));
    }
    let t = r.camera_translation_m;
    let se = r.camera_translation_std_error_m;
    s.push_str(&format!(
        "camera translation t_CB: [{:.4}, {:.4}, {:.4}] m (± [{:.4}, {:.4}, {:.4}] mm)\n",
        t[0],
        t[1],
        t[2],
        se[0] * 1e3,
        se[1] * 1e3,
        se[2] * 1e3
    ));
    s.push_str(&format!(
        "outlier poses: {}\n",
        r.outliers.iter().map(|o| format!("{} ({:.3} deg)", o.pose, o.residual_deg)).collect::<Vec<_>>().join(", ")
    ));
    s.push_str(&format!("wrote {}\n", out.display()));
    s
}

fn compare(args: CompareArgs) -> Result<()> {
    let session = args.session.load()?;
    let model = RobotModel::load(&session.model)?;
    let mut sets = vec![("nominal".to_string(), Parameters::nominal(&model.spm, None))];
    if let Some(path) = &args.params {
        let params = Parameters::read(path)?;
        let label = format!("{:?}", params.source).to_lowercase();
        sets.push((label, params));
    }
    let result = spmcal::compare::compare(&session, &sets, args.method.into())?;
    if let Some(path) = &args.rrd {
        record(path, &spmcal::record::comparison_scene(&session, &model, &sets, &result)?)?;
    }
    if args.json {
        let sets: Vec<_> = result
            .iter()
            .map(|c| json!({"label": c.label, "registration": c.registration, "rms_deg": c.rms_deg, "median_deg": c.median_deg,
                "max_deg": c.max_deg, "poses": c.per_pose.len(), "excluded": c.excluded,
                "per_pose_deg": c.per_pose.iter().map(|(p, a)| json!({"pose": p, "angle_deg": a})).collect::<Vec<_>>()}))
            .collect();
        println!(
            "{}",
            json!({"command": "compare", "dataset": args.session.dataset.display().to_string(), "sets": sets})
        );
        return Ok(());
    }
    let mut table = String::from("pose");
    for c in &result {
        table.push_str(&format!(",{}_deg", c.label));
    }
    table.push('\n');
    // Every pose any set could predict; a set whose FDA failed on a pose leaves its cell empty.
    let poses: std::collections::BTreeSet<u64> =
        result.iter().flat_map(|c| c.per_pose.iter().map(|(p, _)| *p)).collect();
    for pose in poses {
        table.push_str(&pose.to_string());
        for c in &result {
            let value = c.per_pose.iter().find(|(p, _)| *p == pose).map_or(String::new(), |(_, a)| format!("{a:.5}"));
            table.push_str(&format!(",{value}"));
        }
        table.push('\n');
    }
    print!("{table}");
    for c in &result {
        eprintln!(
            "{:<11} RMS {:.4}°, median {:.4}°, max {:.4}° over {} poses (registration: {})",
            c.label,
            c.rms_deg,
            c.median_deg,
            c.max_deg,
            c.per_pose.len(),
            c.registration
        );
    }
    Ok(())
}

/// Write a recording and say so on standard error.
fn record(path: &Path, scene: &spmcal::record::Scene) -> Result<spmcal::record::RecordingSummary> {
    let summary = spmcal::record::write_recording(path, scene)?;
    eprintln!("recording: {} ({} poses, {} bytes)", summary.path.display(), summary.poses, summary.bytes);
    Ok(summary)
}

fn replay(args: ReplayArgs) -> Result<()> {
    let session = args.session.load()?;
    let model = RobotModel::load(&session.model)?;
    let params = args.params.as_deref().map(Parameters::read).transpose()?;
    let scene = spmcal::record::replay_scene(&session, &model, params.as_ref())?;
    let summary = record(&args.rrd, &scene)?;
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}
