//! Command-line arguments (clap derive) and their mapping onto render settings.

use crate::integrator::{LightSampling, PixelSampling, Settings};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Lucent: a physically based path tracer for glTF scenes.
#[derive(Parser, Debug)]
#[command(version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene headless to a PNG (tonemapped sRGB) or OpenEXR (linear) file.
    Render(RenderArgs),
    /// Measure samples/s and rays/s on the built-in Cornell box.
    Bench(BenchArgs),
}

/// On/off switch values.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Switch {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// Pixel sampling modes.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelMode {
    /// Independent uniform positions.
    Random,
    /// Jittered strata.
    Stratified,
    /// Uniform sub-pixel grid (deterministic, biased).
    Grid,
}

/// Light sampling modes.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightMode {
    /// BSDF sampling only.
    Off,
    /// Explicit light sampling without double counting.
    Explicit,
    /// Multiple importance sampling of lights and BSDF.
    Mis,
}

/// Options shared by everything that renders.
#[derive(Args, Debug, Clone)]
pub struct RenderOptions {
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Maximum bounces (pbrt-v4 maxdepth: 0 emitters only, 1 direct light).
    #[arg(long, default_value_t = 7)]
    pub max_depth: u32,
    /// Bounce from which Russian roulette may end paths.
    #[arg(long, default_value_t = 3)]
    pub rr_depth: u32,
    /// How camera rays sample the pixel area.
    #[arg(long, value_enum, default_value_t = PixelMode::Random)]
    pub pixel_sampling: PixelMode,
    /// Strata per pixel axis for stratified and grid sampling [default: sqrt(spp), at most 16, or 4].
    #[arg(long)]
    pub strata: Option<u32>,
    /// Importance sampling of BSDF directions (off: uniform hemisphere).
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub importance: Switch,
    /// Light sampling strategy.
    #[arg(long, value_enum, default_value_t = LightMode::Mis)]
    pub lights: LightMode,
    /// Firefly clamp on a sample's largest component (biased; off unless given).
    #[arg(long, allow_negative_numbers = true)]
    pub clamp: Option<f32>,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
}

impl RenderOptions {
    /// Render settings for these options and an optional sample target.
    pub fn settings(&self, target_spp: Option<u32>) -> Settings {
        let strata =
            self.strata.unwrap_or_else(|| target_spp.map_or(4, |n| ((n as f64).sqrt().floor() as u32).clamp(1, 16)));
        Settings {
            width: self.width,
            height: self.height,
            seed: self.seed,
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            pixel_sampling: match self.pixel_sampling {
                PixelMode::Random => PixelSampling::Random,
                PixelMode::Stratified => PixelSampling::Stratified,
                PixelMode::Grid => PixelSampling::Grid,
            },
            strata,
            importance_sampling: self.importance == Switch::On,
            light_sampling: match self.lights {
                LightMode::Off => LightSampling::Off,
                LightMode::Explicit => LightSampling::Explicit,
                LightMode::Mis => LightSampling::Mis,
            },
            firefly_clamp: self.clamp,
            target_spp,
        }
    }
}

/// `lucent render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// glTF scene (.gltf or .glb) [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Samples per pixel [default: 64 unless --time is given].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render for this many seconds instead of a sample count (--spp then caps it).
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Exposure in EV applied before PNG tonemapping.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Output file: .png (tonemapped sRGB) or .exr (linear float).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Shared render options.
    #[command(flatten)]
    pub options: RenderOptions,
}

/// `lucent bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Samples per pixel per measured run.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Measured runs per kernel (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
}
