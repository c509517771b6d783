//! `spmcal convert`: a ROS 2 bag as a session folder (CSV), or a session as a bag.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use super::args::load_session;
use super::envelope::Envelope;
use super::files::Files;
use super::output::out;

#[derive(Args)]
#[command(group = clap::ArgGroup::new("input").required(true).args(["bag", "dataset"]))]
#[command(group = clap::ArgGroup::new("output").required(true).args(["out", "to_bag"]))]
pub(crate) struct ConvertArgs {
    /// The bag to read (an `.mcap` file or a bag folder); with `--out`.
    #[arg(long, conflicts_with = "to_bag")]
    pub(crate) bag: Option<PathBuf>,
    /// The session folder to write (created; an existing session there is replaced): from the bag,
    /// or from `--dataset` with `--points`.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// The session folder (or bag) to read; with `--to-bag`, or `--out` and `--points`.
    #[arg(long)]
    pub(crate) dataset: Option<PathBuf>,
    /// The bag to write from the session (one `.mcap` file).
    #[arg(long, requires = "dataset")]
    pub(crate) to_bag: Option<PathBuf>,
    /// A session seen through its cameras' pixels: write the points its rig (`cameras.yaml`)
    /// triangulates instead, as a tracker that gives points would (a bag carries points only).
    #[arg(long)]
    pub(crate) points: bool,
    /// The model (overrides the session's, or the bag mapping's): a shipped model's name
    /// (agile_wrist, orbita3d) or a URDF's path [default for a bag: agile_wrist].
    #[arg(long)]
    pub(crate) model: Option<PathBuf>,
    /// Print a machine-readable summary (JSON).
    #[arg(long)]
    pub(crate) json: bool,
}

/// What was converted.
#[derive(Serialize)]
struct Converted {
    /// `static` or `free_motion`.
    kind: &'static str,
    /// Poses (static) or camera frames (free motion).
    poses: usize,
    /// Joint states of a free-motion recording.
    joint_states: usize,
    /// Marker points.
    markers: usize,
    /// A rigid body's poses (a session of a body: `markers` is then 0).
    body_poses: usize,
}

pub(crate) fn run(args: ConvertArgs) -> Result<()> {
    let mut files = Files::new();
    let (input, output) = match (&args.bag, &args.out, &args.dataset, &args.to_bag) {
        (Some(bag), Some(dir), _, _) => {
            files.input("--bag", bag);
            files.session_output("--out", dir);
            (bag, dir)
        }
        (_, Some(dir), Some(dataset), _) if args.points => {
            files.session("--dataset", dataset);
            files.session_output("--out", dir);
            (dataset, dir)
        }
        (_, Some(_), Some(_), _) => anyhow::bail!(
            "--dataset with --out writes a session's triangulated points: add --points (or --to-bag to write a bag)"
        ),
        (_, _, Some(dataset), Some(bag)) => {
            files.session("--dataset", dataset);
            files.output("--to-bag", bag);
            (dataset, bag)
        }
        _ => anyhow::bail!("--bag goes with --out, --dataset with --to-bag (or --out and --points)"),
    };
    if let Some(model) = &args.model {
        files.model(model);
    }
    files.check()?;
    let to_folder = args.to_bag.is_none();
    if to_folder {
        spmcal::dataset::Session::check_destination(output)?;
    }
    let (session, found) = load_session(input, args.model.as_deref())?;
    for w in &found {
        match w.note {
            true => super::output::note(w),
            false => super::output::warn(w),
        }
    }
    if session.rig.is_some() && args.to_bag.is_some() && !args.points {
        anyhow::bail!(
            "{}: a session seen through its cameras' pixels cannot be written as a bag, which carries marker points: \
             add --points to write the points its rig (cameras.yaml) triangulates",
            input.display()
        );
    }
    let session = if args.points { session.as_points() } else { session };
    if to_folder {
        session.write(output)?
    } else {
        session.write_bag(output)?
    }
    let converted = match &session.streams {
        Some(s) => Converted {
            kind: "free_motion",
            poses: session.poses.len(),
            joint_states: s.encoder_count(),
            markers: s.capture_count(),
            body_poses: s.body_poses().count(),
        },
        None => Converted {
            kind: "static",
            poses: session.poses.len(),
            joint_states: 0,
            markers: session.poses.iter().map(|p| p.seen()).sum(),
            body_poses: session.poses.iter().filter(|p| p.body.is_some()).count(),
        },
    };
    if args.json {
        out(&(Envelope::new("convert", &converted)
            .input("from", input.display())
            .input("to", output.display())
            .to_json()
            + "\n"))
    } else {
        let seen = match &session.body {
            Some(body) => format!("{} poses of the body `{body}`", converted.body_poses),
            None => format!("{} marker points", converted.markers),
        };
        let what = match converted.kind {
            "static" => format!("a static session of {} poses ({seen})", converted.poses),
            _ => format!(
                "a free-motion recording ({} joint states, {seen} in {} camera frames)",
                converted.joint_states, converted.poses
            ),
        };
        out(&format!("{}: {what}\nwrote {}\n", input.display(), output.display()))
    }
}
