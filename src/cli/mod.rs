//! Command line: parsing (`args`), `lucent render` (headless, to PNG/EXR, or a piece),
//! `lucent merge` (pieces into the image), `lucent farm` (cluster job scripts) and `lucent
//! bench` (kernel, robustness, convergence and throughput measurements), and what `lucent view`
//! hands the viewer. `main.rs` dispatches.

mod adaptive;
pub mod args;
pub mod bench;
mod convergence;
pub mod farm;
pub mod merge;
mod plot;
pub mod render;
mod throughput;

use crate::film::output::{Format, check_can_write, check_writable};
use crate::viewer::Launch;
use clap::Parser;
use std::process::ExitCode;

/// The command line parsed, or the exit code after clap printed help, a version or a
/// one-line error.
pub fn parse() -> Result<args::Command, ExitCode> {
    match args::Cli::try_parse() {
        Ok(cli) => Ok(cli.command.unwrap_or(args::Command::View(args::ViewArgs::default()))),
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            Err(ExitCode::SUCCESS)
        }
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("invalid arguments");
            eprintln!("{first} (see --help)");
            Err(ExitCode::from(2))
        }
    }
}

/// What the viewer opens for `lucent view`, checked.
pub fn launch(args: &args::ViewArgs) -> Result<Launch, String> {
    if args.denoise {
        crate::film::denoise::available()?;
    }
    let view = args.options.resolve(None)?;
    if let Some(shot) = &args.screenshot {
        if view.settings.target_spp.is_none() {
            return Err("--screenshot needs --spp N, the sample count at which to save it".into());
        }
        if check_writable(shot).map_err(|e| e.to_string())? != Format::Png {
            return Err(format!("--screenshot {} must name a .png (the .exr is written beside it)", shot.display()));
        }
    }
    if let Some(gltf) = &args.save_gltf {
        check_can_write(gltf).map_err(|e| e.to_string())?;
    }
    Ok(Launch {
        save_gltf: args.save_gltf.clone(),
        scene: args.scene.clone(),
        view,
        file_camera: args.options.camera,
        fixed_size: args.options.fixed_size(),
        keep_dark: args.options.keeps_dark(),
        variant: args.options.variant.clone(),
        instancing: args.options.instancing(),
        threads: args.options.threads,
        screenshot: args.screenshot.clone(),
        denoise: if args.no_denoise { Some(false) } else { args.denoise.then_some(true) },
        compare: args.compare.clone(),
    })
}

/// The exit code for a command's result; an error is printed as one line.
pub fn exit(result: Result<(), String>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
