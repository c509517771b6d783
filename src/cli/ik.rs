//! `spmcal ik`: working-mode joint readings for MP orientations (a file of them, or one).

use anyhow::{Context, Result, bail};
use spmcal::dataset::{JointReading, OrientationRecord, joints_csv, read_orientations};
use spmcal::math::so3;

use super::args::IkArgs;
use super::envelope::Envelope;
use super::output::{Outputs, out, reserve, table_to};

pub(crate) fn run(args: IkArgs) -> Result<()> {
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
