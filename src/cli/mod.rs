//! The command line: one file per command (its arguments, the library call, the printing), the
//! arguments several commands share ([`args`]), what each reads and writes, checked against each
//! other before any work ([`files`]), the plumbing they share ([`output`]) and the `--json`
//! envelope ([`envelope`]).

pub(crate) mod args;
pub(crate) mod calibrate;
pub(crate) mod check;
pub(crate) mod compare;
pub(crate) mod completions;
pub(crate) mod convert;
pub(crate) mod envelope;
pub(crate) mod estimate;
pub(crate) mod export;
pub(crate) mod fda;
pub(crate) mod files;
pub(crate) mod ik;
pub(crate) mod output;
pub(crate) mod plan;
pub(crate) mod replay;
pub(crate) mod simulate;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use calibrate::CalibrateArgs;
use check::CheckArgs;
use compare::CompareArgs;
use estimate::EstimateArgs;
use export::ExportArgs;
use fda::FdaArgs;
use ik::IkArgs;
use plan::PlanArgs;
use replay::ReplayArgs;
use simulate::SimulateArgs;

/// The version `--version` prints: the package's and the commit it was built from.
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (commit ", env!("SPMCAL_COMMIT"), ")");

/// Calibration of spherical parallel manipulators (the Agile Wrist, Orbita3d, any SPM a URDF describes) from joints and camera markers.
#[derive(Parser)]
#[command(name = "spmcal", version = VERSION, about)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Inverse kinematics: MP orientations in, working-mode joint readings out.
    Ik(IkArgs),
    /// Forward displacement analysis: joint readings in, MP orientations out.
    Fda(FdaArgs),
    /// Load a model and say what it is: geometry, home branches, conditioning over a workspace, problems.
    Check(CheckArgs),
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
    /// Choose the poses to capture that buy the most accuracy, in an order to follow.
    Plan(PlanArgs),
    /// Write a calibrated URDF and its companion from a parameters file.
    Export(ExportArgs),
    /// Convert a ROS 2 bag (MCAP) to a session folder (`--bag B --out DIR`), or a session to a bag (`--dataset D --to-bag B.mcap`).
    Convert(convert::ConvertArgs),
    /// Print the shell completion script for `shell` (bash, zsh, fish, elvish, powershell).
    Completions(completions::CompletionsArgs),
    /// Print the manual page (roff; e.g. `spmcal man > spmcal.1`), or with `--out-dir` write a page
    /// per command (`spmcal.1`, `spmcal-calibrate.1`, …) with every option.
    Man(completions::ManArgs),
}

/// The exit code of a command, its error printed on standard error.
/// On Ctrl-C (SIGINT) or SIGTERM, end as a shell expects (exit 130 / 143, one line saying so) and
/// leave nothing behind: every output is staged in a temporary file until it is complete, and those
/// are removed first (no destructor runs when a signal ends the process). Outputs already put in
/// place stay whole (each was renamed into place complete).
pub(crate) fn end_cleanly_on_signals() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else { return };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            spmcal::io::StagedFile::discard_unfinished();
            let name = if signal == SIGINT { "SIGINT" } else { "SIGTERM" };
            eprintln!("interrupted ({name}): stopped; no temporary file left, no output half-written");
            std::process::exit(128 + signal);
        }
    });
}

pub(crate) fn exit(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed standard output (`spmcal … | head`) ends the program quietly, as other tools do.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, a cause only where the message so far does not already say it
/// (errors that print their source and also return it would otherwise say it twice).
fn describe(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1).map(|c| c.to_string()) {
        if !text.contains(&cause) {
            text = format!("{text}: {cause}");
        }
    }
    text
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}
