//! `spmcal` command line: parse the arguments and run the command (each in its own file of
//! `cli/`); the work is in the library.

mod cli;

use std::process::ExitCode;

use clap::{CommandFactory, Parser};
use cli::{Cli, Command};

fn main() -> ExitCode {
    cli::end_cleanly_on_signals();
    cli::exit(match Cli::parse().command {
        Command::Ik(args) => cli::ik::run(args),
        Command::Fda(args) => cli::fda::run(args),
        Command::Check(args) => cli::check::run(args),
        Command::Simulate(args) => cli::simulate::run(args),
        Command::Estimate(args) => cli::estimate::run(args),
        Command::Calibrate(args) => cli::calibrate::run(args),
        Command::Compare(args) => cli::compare::run(args),
        Command::Replay(args) => cli::replay::run(args),
        Command::Plan(args) => cli::plan::run(args),
        Command::Export(args) => cli::export::run(args),
        Command::Convert(args) => cli::convert::run(args),
        Command::Completions(args) => cli::completions::completions(args, Cli::command()),
        Command::Man(args) => cli::completions::man(args, Cli::command()),
    })
}
