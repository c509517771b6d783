//! `spmcal completions SHELL` and `spmcal man`: the shell completion script and the manual page,
//! both generated from the command line's own definition (handed in by `main`, so that this file
//! does not import the definition that lists it), so they cannot drift from it.

use anyhow::Result;
use clap::Args;

use super::output::out;

#[derive(Args)]
pub(crate) struct CompletionsArgs {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub(crate) shell: clap_complete::Shell,
}

/// The completion script on standard output (e.g. `spmcal completions bash >
/// ~/.local/share/bash-completion/completions/spmcal`).
pub(crate) fn completions(args: CompletionsArgs, mut command: clap::Command) -> Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "spmcal", &mut script);
    out(&String::from_utf8_lossy(&script))
}

/// The manual page (roff) on standard output.
pub(crate) fn man(command: clap::Command) -> Result<()> {
    let mut page = Vec::new();
    clap_mangen::Man::new(command).render(&mut page)?;
    out(&String::from_utf8_lossy(&page))
}
