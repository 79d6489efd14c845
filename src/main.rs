//! The `lucent` command: parses arguments and dispatches to the viewer or the CLI.

use lucent::cli::{self, args::Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    let command = match cli::parse() {
        Ok(command) => command,
        Err(code) => return code,
    };
    cli::exit(match command {
        Command::View(v) => cli::launch(&v).and_then(lucent::viewer::run),
        Command::Render(r) => cli::render::run(&r),
        Command::Bench(b) => cli::bench::run(&b),
        Command::Merge(m) => cli::merge::run(&m),
        Command::Farm(cli::args::FarmCommand::Slurm(f)) => cli::farm::run(&f),
    })
}
