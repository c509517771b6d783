//! `spmcal check`: load a model (or a parameters file) and say what it is — geometry, home
//! branches, conditioning over a workspace — and any problem, before it is used.

use anyhow::{Result, bail};
use clap::Args;
use spmcal::model::ModelSurvey;

use super::args::GeometryArgs;
use super::envelope::Envelope;
use super::files::Files;
use super::output::out;

#[derive(Args)]
pub(crate) struct CheckArgs {
    #[command(flatten)]
    pub(crate) geometry: GeometryArgs,
    /// Largest tilt of the surveyed workspace (deg).
    #[arg(long, default_value_t = 30.0)]
    pub(crate) max_tilt_deg: f64,
    /// Largest yaw either way of the surveyed workspace (deg).
    #[arg(long, default_value_t = 30.0)]
    pub(crate) max_yaw_deg: f64,
    /// Print a machine-readable summary (JSON) instead of the text.
    #[arg(long)]
    pub(crate) json: bool,
}

pub(crate) fn run(args: CheckArgs) -> Result<()> {
    for (name, value, limit) in
        [("--max-tilt-deg", args.max_tilt_deg, 90.0), ("--max-yaw-deg", args.max_yaw_deg, 180.0)]
    {
        if !(0.0..=limit).contains(&value) {
            bail!("{name} {value} is outside [0, {limit}]");
        }
    }
    let mut files = Files::new();
    args.geometry.register_spm(&mut files);
    files.check()?;
    let spm = args.geometry.spm()?;
    let survey = ModelSurvey::of(&spm, args.max_tilt_deg, args.max_yaw_deg);
    let source = args.geometry.params.clone().unwrap_or_else(|| args.geometry.model_path()).display().to_string();
    if args.json {
        return out(&(Envelope::new("check", &survey).input("model", &source).to_json() + "\n"));
    }
    out(&text(&source, &survey))
}

fn text(source: &str, s: &ModelSurvey) -> String {
    let v = |a: &nalgebra::Vector3<f64>| format!("[{:>6.3}, {:>6.3}, {:>6.3}]", a.x, a.y, a.z);
    let mut t = format!(
        "{source}: {}\n",
        if s.coaxial { "a coaxial SPM (one line carries all three actuated axes)" } else { "an SPM" }
    );
    t += "leg  u (in B)                  alpha1    alpha2    v0 (in P)                 delta     home: branch  reading   margin\n";
    for (i, g) in s.legs.iter().enumerate() {
        t += &format!(
            "{:<4} {} {:>8.3}° {:>8.3}° {} {:>8.3}° {:>9}  {:>8.3}° {:>7.3}\n",
            i + 1,
            v(&g.u),
            g.alpha1.to_degrees(),
            g.alpha2.to_degrees(),
            v(&g.v0),
            g.delta.to_degrees(),
            format!("{} {}", s.home_signs().chars().nth(i).unwrap_or('?'), g.home_branch),
            s.home_joints[i].to_degrees(),
            s.home_margins[i],
        );
    }
    t += &format!(
        "home (R = I): conditioning {:.3}; the working-mode FDA of all-zero readings is {}\n",
        s.home_conditioning,
        s.fda_at_zero_deg.map_or("not defined (it fails)".to_string(), |d| format!("{d:.2e}° from the identity"))
    );
    t += &format!(
        "workspace (tilt ≤ {}°, yaw ±{}°): {} of {} orientations regular; conditioning ≥ {:.3} (tilt {:.1}° towards {:.0}°, yaw {:.1}°), branch margin ≥ {:.3}\n",
        s.max_tilt_deg,
        s.max_yaw_deg,
        s.regular,
        s.orientations,
        s.min_conditioning,
        s.min_conditioning_at_deg[0],
        s.min_conditioning_at_deg[1],
        s.min_conditioning_at_deg[2],
        s.min_margin
    );
    if s.problems.is_empty() {
        t += "problems: none\n";
    } else {
        t += "problems:\n";
        t += &s.problems.iter().map(|p| format!("  - {p}\n")).collect::<String>();
    }
    t
}
