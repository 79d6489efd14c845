//! Command-line arguments (clap derive) and how they resolve into render settings.

use crate::config::ViewFile;
use crate::film::tonemap::{Display, Tonemap};
use crate::integrator::{Directions, Integrator, LightSampling, PixelSampling, Robustness, SamplerKind, Settings};
use crate::scene::{camera::Camera, environment::EnvSettings};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Lucent: a physically based path tracer for glTF scenes. With no command, opens the
/// viewer on the built-in Cornell box.
#[derive(Parser, Debug)]
#[command(version, about)]
pub struct Cli {
    /// What to do [default: view].
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Open the interactive viewer and watch the scene converge.
    View(ViewArgs),
    /// Render a scene headless to a PNG (tonemapped sRGB) or OpenEXR (linear) file.
    Render(RenderArgs),
    /// Measure samples/s and rays/s: kernel specialisation, or robustness mechanisms.
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

/// A numerical-robustness mechanism that `--without` can switch off.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mechanism {
    /// The watertight ray/triangle test (falls back to obvhs's Moller-Trumbore test).
    Watertight,
    /// Ray origins offset by their floating-point error bound.
    Offsets,
    /// The shadow-terminator offset on smooth-shaded meshes.
    Terminator,
}

impl Mechanism {
    /// `robustness` with this mechanism switched off.
    pub fn disable(self, mut robustness: Robustness) -> Robustness {
        match self {
            Mechanism::Watertight => robustness.watertight = false,
            Mechanism::Offsets => robustness.offset_origins = false,
            Mechanism::Terminator => robustness.terminator = false,
        }
        robustness
    }
}

/// Options shared by everything that renders. Each one given overrides the view file.
#[derive(Args, Debug, Clone, Default)]
pub struct RenderOptions {
    /// Camera and settings saved from the viewer (TOML); options given here override it.
    #[arg(long)]
    pub view: Option<PathBuf>,
    /// Image width in pixels [default: 512; the viewer follows its window].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels [default: 512; the viewer follows its window].
    #[arg(long)]
    pub height: Option<u32>,
    /// Look through the file's camera number N (0-based, in the viewer's list) [default: the first].
    #[arg(long)]
    pub camera: Option<usize>,
    /// Seed of the random streams [default: 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Maximum bounces, as pbrt-v4's maxdepth: 0 emitters only, 1 direct light [default: 7].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Bounce from which Russian roulette may end paths [default: 3].
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// How camera rays sample the pixel area [default: random].
    #[arg(long, value_enum)]
    pub pixel_sampling: Option<PixelSampling>,
    /// Strata per pixel axis for stratified and grid sampling [default: sqrt(spp), at most 16, or 4].
    #[arg(long)]
    pub strata: Option<u32>,
    /// Importance sampling of BSDF directions; off draws uniform hemisphere directions [default: on].
    #[arg(long, value_enum)]
    pub importance: Option<Switch>,
    /// Light sampling strategy [default: mis].
    #[arg(long, value_enum)]
    pub lights: Option<LightSampling>,
    /// Estimator: path tracing, or distribution ray tracing (branching at every hit) [default: path].
    #[arg(long, value_enum)]
    pub integrator: Option<Integrator>,
    /// Directions per hit for distribution ray tracing [default: 8].
    #[arg(long)]
    pub branching: Option<u32>,
    /// How distribution ray tracing chooses directions [default: stratified].
    #[arg(long, value_enum)]
    pub directions: Option<Directions>,
    /// Let distribution ray tracing exceed its budget of rays per sample.
    #[arg(long)]
    pub allow_expensive: bool,
    /// Sequence of the sample numbers: independent, or Owen-scrambled Sobol [default: independent].
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerKind>,
    /// Firefly clamp on a sample's largest component (biased; off unless given).
    #[arg(long, allow_negative_numbers = true)]
    pub clamp: Option<f32>,
    /// Exposure in EV for display and PNG output [default: 0].
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Tone curve for display and PNG output [default: linear].
    #[arg(long, value_enum)]
    pub tonemap: Option<Tonemap>,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Switch off robustness mechanisms, to see what they prevent (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub without: Vec<Mechanism>,
    /// Equirectangular environment map (.hdr or .exr) lighting the scene from outside
    /// (+y up; the map's centre is seen looking along -z), or `built-in` for the sunset sky
    /// embedded in the binary (Poly Haven's venice_sunset, 1024x512, CC0).
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// Scale on the environment's radiance [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    pub env_intensity: Option<f32>,
    /// Rotation of the environment map about the up axis, in degrees [default: 0].
    #[arg(long, allow_negative_numbers = true)]
    pub env_rotation: Option<f32>,
    /// Uniform background radiance R,G,B (linear) where no --env map is given [default: 0,0,0].
    #[arg(long, value_delimiter = ',', num_args = 1, allow_negative_numbers = true)]
    pub background: Option<Vec<f32>>,
}

/// The camera `--camera` picks from `scene`, else `view` (from a view file); the error is one line.
pub fn pick_camera(
    index: Option<usize>,
    view: Option<Camera>,
    scene: &crate::scene::Scene,
) -> Result<Option<Camera>, String> {
    match index {
        None => Ok(view),
        Some(i) => match scene.cameras.get(i) {
            Some((_, c)) => Ok(Some(*c)),
            None => {
                let n = scene.cameras.len();
                Err(format!("--camera {i}: {} has {n} camera{}", scene.name, if n == 1 { "" } else { "s" }))
            }
        },
    }
}

/// A render setup resolved from a view file and the command line.
pub struct Resolved {
    /// Render settings.
    pub settings: Settings,
    /// Display settings.
    pub display: Display,
    /// The camera from the view file, if any.
    pub camera: Option<Camera>,
    /// What lights the scene from outside.
    pub environment: EnvSettings,
}

impl RenderOptions {
    /// Settings from the view file (or defaults), overridden by every option given.
    pub fn resolve(&self, target_spp: Option<u32>) -> Result<Resolved, String> {
        let view = match &self.view {
            Some(path) => ViewFile::load(path)?,
            None => ViewFile::default(),
        };
        let mut s = view.settings;
        let default_strata = target_spp.map_or(4, |n| ((n as f64).sqrt().floor() as u32).clamp(1, 16));
        s.strata = self.strata.unwrap_or(if self.view.is_some() { s.strata } else { default_strata });
        s.width = self.width.unwrap_or(s.width);
        s.height = self.height.unwrap_or(s.height);
        s.seed = self.seed.unwrap_or(s.seed);
        s.max_depth = self.max_depth.unwrap_or(s.max_depth);
        s.rr_depth = self.rr_depth.unwrap_or(s.rr_depth);
        s.pixel_sampling = self.pixel_sampling.unwrap_or(s.pixel_sampling);
        s.importance_sampling = self.importance.map_or(s.importance_sampling, |i| i == Switch::On);
        s.light_sampling = self.lights.unwrap_or(s.light_sampling);
        s.sampler = self.sampler.unwrap_or(s.sampler);
        s.integrator = self.integrator.unwrap_or(s.integrator);
        s.branching = self.branching.unwrap_or(s.branching);
        s.directions = self.directions.unwrap_or(s.directions);
        s.allow_expensive |= self.allow_expensive;
        s.firefly_clamp = self.clamp.or(s.firefly_clamp);
        if !self.without.is_empty() {
            s.robustness = self.without.iter().fold(Robustness::default(), |r, m| m.disable(r));
        }
        s.target_spp = target_spp;
        s.validate().map_err(|e| e.to_string())?;
        if self.threads == Some(0) {
            return Err("--threads must be at least 1".into());
        }
        let display = Display {
            exposure: self.exposure.unwrap_or(view.display.exposure),
            tonemap: self.tonemap.unwrap_or(view.display.tonemap),
        };
        if !display.exposure.is_finite() {
            return Err("--exposure must be finite".into());
        }
        let mut environment = view.environment;
        if let Some(map) = &self.env {
            environment.map = Some(map.clone());
        }
        environment.intensity = self.env_intensity.unwrap_or(environment.intensity);
        environment.rotation = self.env_rotation.unwrap_or(environment.rotation);
        if let Some(b) = &self.background {
            let [r, g, b] = b[..] else {
                return Err(format!("--background needs three values R,G,B, not {}", b.len()));
            };
            environment.background = glam::Vec3::new(r, g, b);
        }
        environment.validate()?;
        Ok(Resolved { settings: s, display, camera: view.camera, environment })
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
    /// Output file: .png (tonemapped sRGB) or .exr (linear float).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Shared render options.
    #[command(flatten)]
    pub options: RenderOptions,
}

/// `lucent view`.
#[derive(Args, Debug, Default)]
pub struct ViewArgs {
    /// glTF scene (.gltf or .glb) [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Stop refining at this many samples per pixel.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render in the window until --spp is reached, save this PNG and an EXR beside it, and exit.
    #[arg(long, requires = "spp")]
    pub screenshot: Option<PathBuf>,
    /// Shared render options.
    #[command(flatten)]
    pub options: RenderOptions,
}

/// What `lucent bench` measures.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchKind {
    /// The kernel specialised to the scene's features against the general kernel (Cornell box).
    Kernel,
    /// Each robustness mechanism switched off in turn, against all of them on.
    Robustness,
    /// Error against time for each estimator strategy: CSV, plot and table in --out.
    Convergence,
}

/// A strategy of the convergence study.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StrategyName {
    /// Path tracing, uniform hemisphere directions, no light sampling.
    PtUniform,
    /// Path tracing, BSDF (cosine) importance sampling, no light sampling.
    PtCosine,
    /// Path tracing with explicit light sampling.
    PtExplicit,
    /// Path tracing with MIS.
    PtMis,
    /// Path tracing with MIS and the Owen-scrambled Sobol sampler.
    PtMisSobol,
    /// Distribution ray tracing, 4 stratified directions per hit, MIS.
    Drt4,
    /// Distribution ray tracing, 8 stratified directions per hit, MIS.
    Drt8,
    /// Path tracing with MIS on the uniform 4x4 sub-pixel grid (biased).
    GridPixel,
    /// Distribution ray tracing on the 16-direction theta/phi grid (biased).
    GridHemisphere,
}

impl StrategyName {
    /// Every strategy, in the study's order.
    pub const ALL: [StrategyName; 9] = [
        StrategyName::PtUniform,
        StrategyName::PtCosine,
        StrategyName::PtExplicit,
        StrategyName::PtMis,
        StrategyName::PtMisSobol,
        StrategyName::Drt4,
        StrategyName::Drt8,
        StrategyName::GridPixel,
        StrategyName::GridHemisphere,
    ];
}

/// The options of `lucent bench convergence`, resolved.
pub struct ConvergenceArgs {
    /// Scene [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Seconds of rendering per strategy.
    pub budget: f64,
    /// Output folder.
    pub out: PathBuf,
    /// Reference EXR; rendered and cached in `out` when absent.
    pub reference: Option<PathBuf>,
    /// Seconds for rendering the reference.
    pub reference_budget: f64,
    /// Strategies to run (all when empty).
    pub strategies: Vec<StrategyName>,
    /// Image width and height.
    pub size: u32,
    /// Maximum depth of every strategy.
    pub max_depth: u32,
    /// Seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: Option<usize>,
}

/// `lucent bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// What to measure.
    #[arg(value_enum, default_value = "kernel")]
    pub kind: BenchKind,
    /// Scenes for `robustness`, or the one scene for `convergence` (.gltf or .glb) [default: the built-in Cornell box].
    pub scenes: Vec<PathBuf>,
    /// Image width and height in pixels [default: 256; 64 for convergence].
    #[arg(long)]
    pub size: Option<u32>,
    /// Convergence: seconds of rendering per strategy.
    #[arg(long)]
    pub budget: Option<f64>,
    /// Convergence: output folder for convergence.{csv,md,png,svg}.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Convergence: reference EXR [default: rendered with MIS + Sobol and cached in --out].
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Convergence: seconds for rendering the reference [default: 8 x --budget].
    #[arg(long)]
    pub reference_budget: Option<f64>,
    /// Convergence: strategies to run, comma-separated [default: all].
    #[arg(long, value_enum, value_delimiter = ',')]
    pub strategies: Vec<StrategyName>,
    /// Convergence: maximum depth of every strategy (DRT costs branching^depth).
    #[arg(long, default_value_t = 3)]
    pub max_depth: u32,
    /// Convergence: seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Samples per pixel per measured run.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Measured runs per variant (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
}
