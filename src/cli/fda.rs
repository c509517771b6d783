//! `spmcal fda`: MP orientations for joint readings, in the working mode or in every assembly mode.

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use clap::Args;
use spmcal::dataset::{JointReading, OrientationRecord};
use spmcal::math::so3;
use spmcal::model::FdaPose;

use super::args::GeometryArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, reserve, table_to};

#[derive(Args)]
pub(crate) struct FdaArgs {
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// CSV of joint readings `pose,theta1_rad,theta2_rad,theta3_rad`.
    #[arg(long)]
    pub(crate) joints: PathBuf,
    /// Every real assembly mode (up to 8) instead of the working mode.
    #[arg(long)]
    pub(crate) all_modes: bool,
    /// Write the orientations here (atomically) instead of standard output.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn run(args: FdaArgs) -> Result<()> {
    let mut files = Files::new();
    files.output_opt("--out", args.out.as_deref());
    args.geometry.register_spm(&mut files);
    files.input("--joints", &args.joints);
    files.check()?;
    let mut outputs = Outputs::new();
    let slot = reserve(&mut outputs, args.out.as_deref())?;
    let spm = args.geometry.spm()?;
    let readings = JointReading::read(&args.joints)?;
    let source = args.joints.display().to_string();
    // The table of orientations (one row a mode with `--all-modes`) and the per-pose report; the
    // first pose whose working-mode FDA fails stops it.
    let mut records = Vec::new();
    let mut poses = Vec::new();
    for r in &readings {
        if args.all_modes {
            let pose = FdaPose::all_modes(&spm, r.pose, &r.joints);
            for m in &pose.modes {
                records.push(OrientationRecord {
                    pose: r.pose,
                    mode: Some(m.mode),
                    rotation: so3::from_wxyz(m.q_wxyz).expect("a rotation's quaternion"),
                    extra: vec![
                        ("branches".into(), m.branches.clone()),
                        ("conditioning".into(), format!("{:.6}", m.conditioning)),
                        ("working".into(), m.working.to_string()),
                    ],
                    line: r.line,
                });
            }
            poses.push(pose);
        } else {
            let (pose, rotation) = FdaPose::working(&spm, r.pose, &r.joints)
                .map_err(|e| anyhow!("{source}:{}: pose {}: {e}", r.line, r.pose))?;
            records.push(OrientationRecord { pose: r.pose, mode: None, rotation, extra: vec![], line: r.line });
            poses.push(pose);
        }
    }
    table_to(&mut outputs, slot, args.json, &OrientationRecord::csv(&records))?;
    outputs.commit()?;
    if args.json {
        let envelope = Envelope::new("fda", poses).input("joints", &source).input("all_modes", args.all_modes);
        out(&(envelope.to_json() + "\n"))?;
    }
    Ok(())
}
