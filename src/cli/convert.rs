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
pub(crate) struct ConvertArgs {
    /// The bag to read (an `.mcap` file or a bag folder); with `--out`.
    #[arg(long, requires = "out")]
    pub(crate) bag: Option<PathBuf>,
    /// The session folder to write from the bag (created; an existing session there is replaced).
    #[arg(long, requires = "bag")]
    pub(crate) out: Option<PathBuf>,
    /// The session folder (or bag) to read; with `--to-bag`.
    #[arg(long, requires = "to_bag")]
    pub(crate) dataset: Option<PathBuf>,
    /// The bag to write from the session (one `.mcap` file).
    #[arg(long, requires = "dataset")]
    pub(crate) to_bag: Option<PathBuf>,
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
}

pub(crate) fn run(args: ConvertArgs) -> Result<()> {
    let mut files = Files::new();
    let (input, output) = match (&args.bag, &args.out, &args.dataset, &args.to_bag) {
        (Some(bag), Some(dir), _, _) => {
            files.input("--bag", bag);
            files.session_output("--out", dir);
            (bag, dir)
        }
        (_, _, Some(dataset), Some(bag)) => {
            files.session("--dataset", dataset);
            files.output("--to-bag", bag);
            (dataset, bag)
        }
        _ => unreachable!("clap requires --bag with --out or --dataset with --to-bag"),
    };
    if let Some(model) = &args.model {
        files.model(model);
    }
    files.check()?;
    if args.bag.is_some() {
        spmcal::dataset::Session::check_destination(output)?;
    }
    let (session, warnings) = load_session(input, args.model.as_deref())?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if args.bag.is_some() {
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
        },
        None => Converted {
            kind: "static",
            poses: session.poses.len(),
            joint_states: 0,
            markers: session.poses.iter().map(|p| p.seen()).sum(),
        },
    };
    if args.json {
        out(&(Envelope::new("convert", &converted)
            .input("from", input.display())
            .input("to", output.display())
            .to_json()
            + "\n"))
    } else {
        let what = match converted.kind {
            "static" => format!("a static session of {} poses ({} marker points)", converted.poses, converted.markers),
            _ => format!(
                "a free-motion recording ({} joint states, {} marker points in {} camera frames)",
                converted.joint_states, converted.markers, converted.poses
            ),
        };
        out(&format!("{}: {what}\nwrote {}\n", input.display(), output.display()))
    }
}
