//! Command-line arguments (clap derive, with every render and display setting generated
//! from the parameter tables) and how they resolve into a view.

use crate::config::ViewFile;
use crate::film::tonemap::DISPLAY;
use crate::integrator::{Settings, settings::SETTINGS};
use crate::params::{Domain, Param, Value};
use crate::scene::instances::Instancing;
use clap::{Arg, ArgMatches, Args, FromArgMatches, Parser, Subcommand, ValueEnum};
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
    /// Measure: the kernel's and the robustness mechanisms' cost, error against time, throughput, adaptive sampling.
    Bench(BenchArgs),
    /// Add pieces of a render (`render --samples A..B --region X0,Y0,X1,Y1 --out X.part`) into its image.
    Merge(MergeArgs),
    /// Split a render into pieces for a cluster scheduler, and merge them there.
    #[command(subcommand)]
    Farm(FarmCommand),
}

/// `lucent farm`.
#[derive(Subcommand, Debug)]
pub enum FarmCommand {
    /// Write Slurm job scripts: a job array of pieces and a merge that runs after them.
    Slurm(FarmSlurmArgs),
}

/// How `lucent farm` cuts a render into pieces.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Sample ranges of the whole frame (each piece holds the whole frame's sums).
    Samples,
    /// Bands of rows with every sample (for frames too large for one machine's memory).
    Regions,
}

/// `lucent farm slurm`.
#[derive(Args, Debug)]
pub struct FarmSlurmArgs {
    /// glTF scene (.gltf or .glb) [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Number of pieces (tasks of the job array).
    #[arg(long)]
    pub pieces: u32,
    /// Cut the render by sample ranges or by bands of rows.
    #[arg(long, value_enum, default_value = "samples")]
    pub split: Split,
    /// Folder for the job scripts, the view file, the pieces and the logs (on a file
    /// system every node sees).
    #[arg(long)]
    pub dir: PathBuf,
    /// The merged image: .png or .exr.
    #[arg(long, short)]
    pub out: PathBuf,
    /// CPUs per piece (Slurm's --cpus-per-task; the piece's worker threads).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub cpus: u32,
    /// Memory per piece, as Slurm's --mem (e.g. 4G) [default: the partition's].
    #[arg(long)]
    pub mem: Option<String>,
    /// Slurm partition [default: the cluster's].
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each job, as Slurm's --time (e.g. 2:00:00) [default: the partition's].
    #[arg(long)]
    pub time_limit: Option<String>,
    /// The lucent binary the nodes run [default: this one].
    #[arg(long)]
    pub lucent: Option<PathBuf>,
    /// Shared render options (--spp is the whole render's).
    #[command(flatten)]
    pub options: RenderOptions,
}

/// `lucent merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Piece files written by `lucent render --samples A..B --out NAME.part`, or folders
    /// of them.
    #[arg(required = true)]
    pub pieces: Vec<PathBuf>,
    /// Output image: .png (tonemapped sRGB) or .exr (linear float).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Samples per pixel the pieces must add up to (missing ones are named) [default: what they hold].
    #[arg(long)]
    pub spp: Option<u32>,
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
    /// Every mechanism.
    pub const ALL: [Mechanism; 3] = [Mechanism::Watertight, Mechanism::Offsets, Mechanism::Terminator];

    /// `settings` with this mechanism switched off.
    pub fn disable(self, mut settings: Settings) -> Settings {
        match self {
            Mechanism::Watertight => settings.watertight = false,
            Mechanism::Offsets => settings.offset_origins = false,
            Mechanism::Terminator => settings.terminator = false,
        }
        settings
    }
}

/// Every parameter of the settings and display tables as a `--name VALUE` option, each
/// given one parsed and range-checked by its table entry.
#[derive(Debug, Clone, Default)]
pub struct ParamArgs {
    /// Render settings given on the command line.
    pub settings: Vec<(&'static str, Value)>,
    /// Display settings given on the command line.
    pub display: Vec<(&'static str, Value)>,
}

impl ParamArgs {
    /// Whether `--name` was given.
    pub fn given(&self, name: &str) -> bool {
        self.settings.iter().chain(&self.display).any(|(n, _)| *n == name)
    }
}

/// The clap option of one table entry: its help, range and default come from the table.
fn param_arg<T: Default>(p: &'static Param<T>) -> Arg {
    let choices = match p.domain {
        Domain::Choice(options) => {
            let list: Vec<String> = options.iter().map(|c| format!("{}: {}", c.name, c.help)).collect();
            format!(" ({})", list.join("; "))
        }
        _ => format!(" ({})", p.range()),
    };
    let arg = Arg::new(p.name)
        .long(p.name)
        .help(format!("{}{choices} [default: {}]", p.help, p.default_value()))
        .value_name("VALUE")
        .allow_negative_numbers(true)
        .allow_hyphen_values(true);
    match p.domain {
        // A bare switch means on: `--allow-expensive`.
        Domain::Switch => arg.num_args(0..=1).default_missing_value("on"),
        _ => arg,
    }
}

fn parsed<T>(table: &'static [Param<T>], m: &ArgMatches) -> Result<Vec<(&'static str, Value)>, clap::Error> {
    let mut out = Vec::new();
    for p in table {
        if let Some(text) = m.get_one::<String>(p.name) {
            let value = p
                .parse(text)
                .map_err(|e| clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("--{}: {e}", p.name)))?;
            out.push((p.name, value));
        }
    }
    Ok(out)
}

impl FromArgMatches for ParamArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(Self { settings: parsed(SETTINGS, m)?, display: parsed(DISPLAY, m)? })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl Args for ParamArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        let cmd = SETTINGS.iter().fold(cmd, |c, p| c.arg(param_arg(p)));
        DISPLAY.iter().fold(cmd, |c, p| c.arg(param_arg(p)))
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// Options shared by everything that renders. Each one given overrides the view file.
#[derive(Args, Debug, Clone, Default)]
pub struct RenderOptions {
    /// Camera and settings saved from the viewer (TOML); options given here override it.
    #[arg(long)]
    pub view: Option<PathBuf>,
    /// Look through the file's camera number N (0-based, in the viewer's list) [default: the first].
    #[arg(long)]
    pub camera: Option<usize>,
    /// Give every mesh its material in this KHR_materials_variants variant (by name).
    #[arg(long)]
    pub variant: Option<String>,
    /// Meshes placed many times: `auto` instances those whose copies add up to more than
    /// 65,536 triangles (stored once, traced through a BVH of placements) and flattens the rest,
    /// `always` instances every one, `never` flattens every one (memory then follows the
    /// placed triangles).
    #[arg(long, default_value = "auto", value_parser = ["auto", "always", "never"])]
    pub instancing: String,
    /// Every render and display setting (see the table in docs/cli.md).
    #[command(flatten)]
    pub params: ParamArgs,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Switch off robustness mechanisms, to see what they prevent (comma-separated; the
    /// same as --watertight off, --offsets off, --terminator off).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub without: Vec<Mechanism>,
    /// Equirectangular environment map (.hdr or .exr) lighting the scene from outside
    /// (+y up; the map's centre is seen looking along -z), `built-in` for the sunset sky
    /// embedded in the binary (Poly Haven's venice_sunset, 1024x512, CC0), or `none`. A
    /// scene without light of its own is lit by the built-in sky unless given `none`, a
    /// --background or a --view.
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

impl RenderOptions {
    /// Whether the setting named `name` (its command-line name) was given.
    pub fn settings_given(&self, name: &str) -> bool {
        self.params.settings.iter().any(|&(n, _)| n == name)
    }

    /// The view (settings, display, camera, environment) from the view file (or defaults),
    /// overridden by every option given; `default_spp` is the sample target when neither
    /// the command line nor the view file sets one.
    pub fn resolve(&self, default_spp: Option<u32>) -> Result<ViewFile, String> {
        let mut view = match &self.view {
            Some(path) => ViewFile::load(path)?,
            None => ViewFile::default(),
        };
        let s = &mut view.settings;
        for &(name, value) in &self.params.settings {
            let p = SETTINGS.iter().find(|p| p.name == name).expect("parsed from the table");
            (p.set)(s, value);
        }
        for &(name, value) in &self.params.display {
            let p = DISPLAY.iter().find(|p| p.name == name).expect("parsed from the table");
            (p.set)(&mut view.display, value);
        }
        for m in &self.without {
            *s = m.disable(*s);
        }
        s.target_spp = s.target_spp.or(default_spp);
        if self.view.is_none() && !self.params.given("strata") {
            // Without a view file, strata follow the sample count: about sqrt(spp) per axis.
            s.strata = s.target_spp.map_or(4, |n| ((n as f64).sqrt().floor() as u32).clamp(1, 16));
        }
        s.validate().map_err(|e| e.to_string())?;
        if self.threads == Some(0) {
            return Err("--threads must be at least 1".into());
        }
        let environment = &mut view.environment;
        if let Some(map) = &self.env {
            environment.map = (map.as_os_str() != NO_MAP).then(|| map.clone());
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
        Ok(view)
    }

    /// What `--instancing` says (auto where it was not given).
    pub fn instancing(&self) -> Instancing {
        self.instancing.parse().unwrap_or_default()
    }

    /// Whether a scene without light of its own stays dark: the environment was chosen
    /// (`--env none`, a background, or a view file), rather than left to the default.
    pub fn keeps_dark(&self) -> bool {
        self.env.as_ref().is_some_and(|m| m.as_os_str() == NO_MAP) || self.background.is_some() || self.view.is_some()
    }

    /// Whether the image size is fixed (given, or from a view file) rather than following
    /// the viewer's window.
    pub fn fixed_size(&self) -> bool {
        self.params.given("width") || self.params.given("height") || self.view.is_some()
    }
}

/// The `--env` value that asks for no map.
const NO_MAP: &str = "none";

/// `lucent render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// glTF scene (.gltf or .glb) [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Render for this many seconds instead of a sample count, ending with the last pass
    /// that fits (--spp then caps it; without --time, --spp defaults to 64).
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Output file: .png (tonemapped sRGB), .exr (linear float), or .part (a piece of the
    /// render's sums, for `lucent merge`).
    #[arg(long, short, required_unless_present = "save_gltf")]
    pub out: Option<PathBuf>,
    /// Write the scene with the view file's material and light edits applied as glTF
    /// (.gltf for a .gltf scene, .glb for a .glb); without --out, nothing is rendered.
    #[arg(long, value_name = "OUT.gltf")]
    pub save_gltf: Option<PathBuf>,
    /// Render only sample indices A to B-1 of every pixel (a piece; with --out NAME.part).
    #[arg(long, value_name = "A..B")]
    pub samples: Option<String>,
    /// Render only pixels X0..X1-1 by Y0..Y1-1 of the frame (a piece with --out NAME.part,
    /// or a cropped image).
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    pub region: Option<String>,
    /// Denoise with Intel Open Image Denoise (loaded where it is installed; see README.md):
    /// --out gets the denoised image, NAME.noisy.exr the noisy one beside it.
    #[arg(long)]
    pub denoise: bool,
    /// Also write the denoiser's albedo and normal images, NAME.albedo.exr and NAME.normal.exr.
    #[arg(long)]
    pub aovs: bool,
    /// Shared render options.
    #[command(flatten)]
    pub options: RenderOptions,
}

/// `lucent view`.
#[derive(Args, Debug, Default)]
pub struct ViewArgs {
    /// glTF scene (.gltf or .glb), or a folder of pieces to show merged as they arrive
    /// [default: the built-in Cornell box].
    pub scene: Option<PathBuf>,
    /// Render in the window until --spp is reached, save this PNG and an EXR beside it, and exit.
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Require Intel Open Image Denoise and start with the Denoise toggle on (the default
    /// wherever it is installed); a --screenshot is then the denoised PNG, the noisy EXR and
    /// NAME.denoised.exr.
    #[arg(long, conflicts_with = "no_denoise")]
    pub denoise: bool,
    /// Start with the Denoise toggle off, showing the accumulated image.
    #[arg(long)]
    pub no_denoise: bool,
    /// Pin this linear image (.exr or .hdr: a reference render, an earlier pin) and show
    /// it split with the live one, instead of the scene's last pinned image.
    #[arg(long, value_name = "IMAGE")]
    pub compare: Option<PathBuf>,
    /// Where "Save glTF" writes the scene with its edits (from --view, or made in the
    /// window); with --screenshot it is written beside the screenshot as the viewer exits.
    #[arg(long, value_name = "OUT")]
    pub save_gltf: Option<PathBuf>,
    /// Shared render options.
    #[command(flatten)]
    pub options: RenderOptions,
}

/// What `lucent bench` measures.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchKind {
    /// The scene's own feature switches against every switch on (Cornell box).
    Kernel,
    /// Each robustness mechanism switched off in turn, against all of them on.
    Robustness,
    /// Error against time for each estimator strategy: CSV, plot and table in --out.
    Convergence,
    /// Samples/s, rays/s, BVH build time and peak memory on a fixed suite of scenes, each a
    /// `lucent render` process (with --baseline, against another build, alternating).
    Throughput,
    /// Relative MSE at equal time of uniform sampling and noise thresholds, and what the
    /// threshold's checks cost: table, CSV and maps of samples per pixel in --out.
    Adaptive,
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
    /// Bidirectional path tracing: every connection of a camera and a light subpath, MIS.
    Bdpt,
    /// Vertex connection and merging: BDPT plus merging with every light subpath, MIS.
    Vcm,
}

impl StrategyName {
    /// Every strategy, in the study's order.
    pub const ALL: [StrategyName; 11] = [
        StrategyName::PtUniform,
        StrategyName::PtCosine,
        StrategyName::PtExplicit,
        StrategyName::PtMis,
        StrategyName::PtMisSobol,
        StrategyName::Drt4,
        StrategyName::Drt8,
        StrategyName::GridPixel,
        StrategyName::GridHemisphere,
        StrategyName::Bdpt,
        StrategyName::Vcm,
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
    /// Convergence and adaptive: seconds of rendering per strategy or variant.
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
    /// Adaptive: noise thresholds to compare with uniform sampling, comma-separated.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.05, 0.02])]
    pub thresholds: Vec<f32>,
    /// Adaptive: samples every pixel takes before it may stop [default: the render default].
    #[arg(long)]
    pub min_spp: Option<u32>,
    /// Convergence: maximum depth of every strategy (DRT costs branching^depth).
    #[arg(long, default_value_t = 3)]
    pub max_depth: u32,
    /// Convergence: seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Samples per pixel per measured run.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Measured runs per variant (the median is reported; for adaptive, rounds of one seed each).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Worker threads [default: one per core].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Throughput: another build of lucent to compare with, run in turn with this one.
    #[arg(long)]
    pub baseline: Option<PathBuf>,
    /// Throughput: the folder holding the suite's scenes [default: the repository's tests/assets].
    #[arg(long)]
    pub assets: Option<PathBuf>,
}
