//! `spmcal ik`: working-mode joint readings for MP orientations (a file of them, or one).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use nalgebra::{Rotation3, Vector3};
use spmcal::dataset::{JointReading, OrientationRecord};
use spmcal::math::so3;
use spmcal::model::Spm;

use super::args::GeometryArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::{Outputs, out, reserve, table_to, warn};

#[derive(Args)]
pub(crate) struct IkArgs {
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// CSV of orientations `pose,qw,qx,qy,qz` (MP → base, scalar first).
    #[arg(long, conflicts_with = "quat", required_unless_present = "quat")]
    pub(crate) orientations: Option<PathBuf>,
    /// One orientation as `qw,qx,qy,qz`.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub(crate) quat: Option<Vec<f64>>,
    /// Write `pose,theta1_rad,theta2_rad,theta3_rad` here (atomically) instead of standard output.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a machine-readable summary (JSON) instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
}

/// The orientations beyond the working mode a warning lists.
const LISTED: usize = 5;

/// Why the working-mode FDA of `joints` does not return `r` (the IK takes each leg's working
/// branch, which a pose beyond a parallel singularity of the working mode has too), or `None`.
fn beyond_working_mode(spm: &Spm, joints: &Vector3<f64>, r: &Rotation3<f64>) -> Option<String> {
    // The FDA converges to 1e-12 rad; an orientation of another assembly mode is degrees away.
    const SAME_RAD: f64 = 1e-6;
    match spm.forward(joints).map(|back| so3::geodesic_angle(&back, r)) {
        Err(e) => Some(format!("its FDA: {e}")),
        Ok(away) if away > SAME_RAD => Some(format!("its FDA gives an orientation {:.3}° away", away.to_degrees())),
        Ok(_) => None,
    }
}

pub(crate) fn run(args: IkArgs) -> Result<()> {
    let mut files = Files::new();
    files.output_opt("--out", args.out.as_deref());
    args.geometry.register_spm(&mut files);
    files.input_opt("--orientations", args.orientations.as_deref());
    files.check()?;
    let mut outputs = Outputs::new();
    let slot = reserve(&mut outputs, args.out.as_deref())?;
    let spm = args.geometry.spm()?;
    let (source, orientations) = match (&args.orientations, &args.quat) {
        (Some(path), _) => (path.display().to_string(), OrientationRecord::read(path)?),
        (None, Some(q)) => {
            let &[w, x, y, z] = q.as_slice() else { bail!("--quat takes four numbers qw,qx,qy,qz, got {}", q.len()) };
            // Typed with four or five digits, a unit quaternion's norm is 1 within 1e-4: normalised,
            // as orientations.csv's are; further off is a wrong number.
            let n = (w * w + x * x + y * y + z * z).sqrt();
            if !n.is_finite() || (n - 1.0).abs() > 1e-3 {
                bail!("--quat has norm {n:.6}, not 1 (within 1e-3): a unit quaternion qw,qx,qy,qz");
            }
            let rotation = so3::from_wxyz([w / n, x / n, y / n, z / n]).context("--quat is not a unit quaternion")?;
            ("--quat".to_string(), vec![OrientationRecord { pose: 0, mode: None, rotation, extra: vec![], line: 0 }])
        }
        (None, None) => bail!("give --orientations FILE or --quat qw,qx,qy,qz"),
    };
    let mut readings = Vec::with_capacity(orientations.len());
    let mut beyond = Vec::new();
    for o in &orientations {
        let at = if o.line > 0 { format!("{source}:{}", o.line) } else { source.clone() };
        let joints = spm.ik(&o.rotation).with_context(|| format!("{at}: pose {}", o.pose))?;
        if let Some(why) = beyond_working_mode(&spm, &joints, &o.rotation) {
            beyond.push(format!("{at}: pose {} ({why})", o.pose));
        }
        readings.push(JointReading { pose: o.pose, line: o.line, joints, time_s: None, station: None });
    }
    if !beyond.is_empty() {
        let more = beyond.len().saturating_sub(LISTED);
        warn(format!(
            "{} of {} orientations lie beyond the working mode: each leg's reading is on its working branch, but the working-mode FDA of the readings does not return the orientation: it lies beyond a singularity of the working mode, or the FDA's path from home passes near one: {}{}",
            beyond.len(),
            orientations.len(),
            beyond[..beyond.len().min(LISTED)].join("; "),
            if more > 0 { format!("; and {more} more") } else { String::new() }
        ));
    }
    table_to(&mut outputs, slot, args.json, &JointReading::csv(&readings))?;
    outputs.commit()?;
    if args.json {
        let solutions: Vec<_> = readings.iter().map(|r| (r.pose, [r.joints[0], r.joints[1], r.joints[2]])).collect();
        out(&(Envelope::new("ik", solutions).input("orientations", &source).to_json() + "\n"))?;
    }
    Ok(())
}
