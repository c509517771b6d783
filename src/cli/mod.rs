//! The command line: one file per command (parse its arguments in [`args`], call the library,
//! print), the plumbing they share ([`output`]) and the `--json` envelope ([`envelope`]).

pub(crate) mod args;
pub(crate) mod calibrate;
pub(crate) mod compare;
pub(crate) mod envelope;
pub(crate) mod estimate;
pub(crate) mod export;
pub(crate) mod fda;
pub(crate) mod ik;
pub(crate) mod output;
pub(crate) mod plan;
pub(crate) mod replay;
pub(crate) mod simulate;

use std::process::ExitCode;

/// The exit code of a command, its error printed on standard error.
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
