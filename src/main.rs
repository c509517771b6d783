//! `spmcal` command line: argument parsing and printing only; the work is in the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use serde_json::json;
use spmcal::dataset::{JointReading, OrientationRecord, read_joints, read_orientations, write_orientations};
use spmcal::files::{number, write_atomic};
use spmcal::model::{Parameters, RobotModel, Spm};
use spmcal::sim::SimConfig;
use spmcal::so3;

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
