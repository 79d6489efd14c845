//! Command line: `lucent view` (the default), `lucent render` (headless, to PNG/EXR) and
//! `lucent bench` (kernel, robustness and convergence measurements).

pub mod args;
mod bench;
mod convergence;
mod plot;
pub mod render;

use clap::Parser;
use std::process::ExitCode;

/// Parses the command line and runs the subcommand; errors are one line and exit non-zero.
pub fn main() -> ExitCode {
    let cli = match args::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            eprintln!("{first} (see --help)");
            return ExitCode::from(2);
        }
    };
    let result = match cli.command.unwrap_or(args::Command::View(args::ViewArgs::default())) {
        args::Command::View(v) => crate::viewer::run(&v),
        args::Command::Render(r) => render::run(&r),
        args::Command::Bench(b) => bench::run(&b),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
