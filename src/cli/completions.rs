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

#[derive(Args)]
pub(crate) struct ManArgs {
    /// Write the pages into this folder, one per command (`spmcal.1`, `spmcal-calibrate.1`, …),
    /// instead of printing the main page.
    #[arg(long)]
    pub(crate) out_dir: Option<std::path::PathBuf>,
}

/// The manual page (roff) on standard output, or every command's page written into a folder.
pub(crate) fn man(args: ManArgs, command: clap::Command) -> Result<()> {
    let Some(dir) = args.out_dir else {
        return out(&String::from_utf8_lossy(&render(command)?));
    };
    if !dir.is_dir() {
        anyhow::bail!("{}: no such folder (--out-dir)", dir.display());
    }
    // The main page names `spmcal-<command>(1)` for each command: write those pages beside it.
    // (clap takes names as `&'static str`: the dozen short ones are leaked, once per run.)
    let leak = |s: String| -> &'static str { Box::leak(s.into_boxed_str()) };
    let version = leak(command.get_version().unwrap_or_default().to_string());
    let pages: Vec<(String, clap::Command)> = std::iter::once(("spmcal".to_string(), command.clone()))
        .chain(command.get_subcommands().filter(|c| c.get_name() != "help").map(|c| {
            let name = format!("spmcal-{}", c.get_name());
            (name.clone(), c.clone().name(leak(name)).version(version))
        }))
        .collect();
    let mut written = Vec::new();
    for (name, page) in pages {
        let path = dir.join(format!("{name}.1"));
        let mut file = spmcal::io::StagedFile::create(&path)?;
        file.write(&render(page)?)?;
        file.commit()?;
        written.push(path.display().to_string());
    }
    out(&format!("wrote {} manual pages: {}\n", written.len(), written.join(", ")))
}

/// One command's page in roff.
fn render(command: clap::Command) -> Result<Vec<u8>> {
    let mut page = Vec::new();
    clap_mangen::Man::new(command).render(&mut page)?;
    Ok(page)
}
