//! Render settings: a plain, comparable struct declared with its parameter table (name,
//! help, default, range), which the command line, the viewer and view files all read. Any
//! change restarts accumulation.

pub use crate::math::sampler::SamplerKind;
use crate::params::{Domain, Param};
use serde::{Deserialize, Serialize};
use std::fmt;

crate::choice_enum! {
    /// How camera rays sample the pixel's area. Stratified and grid sampling use `strata`^2
    /// cells; a stratified sample is still uniform over the pixel, so partial rounds stay
    /// unbiased, while the grid (the textbook's section 10.3, eqs. 4 to 6) is deterministic
    /// and repeats after `strata`^2 samples.
    pub enum PixelSampling {
        #[default]
        Random = "random": "independent uniform positions in the pixel",
        Stratified = "stratified": "jittered strata, one sample per stratum each round",
        Grid = "grid": "the textbook's uniform sub-pixel grid at cell midpoints (biased)",
    }
}

crate::choice_enum! {
    /// How light sources are found (the textbook's "explicit light sampling", section 10.9):
    /// without it only BSDF-sampled rays that happen to hit an emitter find light; with it a
    /// shadow ray goes to one sampled light per non-delta vertex, and emitters that BSDF rays
    /// hit add nothing unless the ray came from a delta lobe; MIS weights both (Veach 1997).
    pub enum LightSampling {
        Off = "off": "only BSDF-sampled rays find light",
        Explicit = "explicit": "a shadow ray per vertex, no double counting",
        #[default]
        Mis = "mis": "both, combined by MIS (power heuristic)",
    }
}

crate::choice_enum! {
    /// Which estimator of the rendering equation renders the image: path tracing (section
    /// 10.7, Russian roulette), or distribution ray tracing (sections 10.2 to 10.6:
    /// `branching` directions at every hit, recursively to `max_depth`, whose cost grows as
    /// branching^depth).
    pub enum Integrator {
        #[default]
        Path = "path": "path tracing, one direction per bounce",
        Distribution = "distribution": "distribution ray tracing, branching at every hit",
        Bdpt = "bdpt": "bidirectional path tracing: camera and light subpaths joined every way, by MIS",
        Vcm = "vcm": "vertex connection and merging: BDPT plus merging with every light path's vertices, by MIS",
    }
}

crate::choice_enum! {
    /// Whether paths carry RGB or sampled wavelengths (hero-wavelength sampling); in RGB,
    /// dispersive materials refract every wavelength alike, at their index n_d.
    pub enum Spectral {
        #[default]
        Auto = "auto": "spectral only for scenes with dispersive materials",
        On = "on": "always spectral (hero wavelengths)",
        Off = "off": "always RGB (dispersion ignored)",
    }
}

crate::choice_enum! {
    /// How distribution ray tracing chooses its hemisphere directions at a hit: one BSDF
    /// sample (or uniform one, without importance sampling) per stratum of a grid over the
    /// unit square, or the textbook's theta/phi grid (eqs. 8 to 10) weighted by
    /// sin(theta) dtheta dphi, deterministic and a baseline.
    pub enum Directions {
        #[default]
        Stratified = "stratified": "stratified Monte Carlo, one sample per stratum (unbiased)",
        Grid = "grid": "the textbook's theta/phi grid at cell midpoints (biased)",
    }
}

/// Rays one distribution-ray-traced sample may trace before it needs confirmation.
pub const DRT_RAY_BUDGET: f64 = 2e5;

pub use crate::params::MAX_SIDE;

const fn int(min: u64, max: u64) -> Domain {
    Domain::Int { min, max, optional: false }
}

fn always(_: &Settings) -> bool {
    true
}

/// Whether the estimator follows paths from the camera alone, where the importance and
/// light sampling switches apply (bidirectional estimators sample every BSDF by importance,
/// and sampling a light is one of their strategies, s = 1).
fn unidirectional(s: &Settings) -> bool {
    !s.integrator.is_bidirectional()
}

/// Whether paths are traced by the path tracer (which alone counts volume bounces apart).
fn path_tracing(s: &Settings) -> bool {
    s.integrator == Integrator::Path
}

fn distribution(s: &Settings) -> bool {
    s.integrator == Integrator::Distribution
}

crate::params! {
    /// Everything that determines the image, besides the scene and the camera.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    #[serde(default)]
    pub struct Settings, table SETTINGS {
        /// Image width in pixels (the viewer follows its window unless the size is fixed).
        width: u32 = 512, ["width", "width", Image, int(1, MAX_SIDE), always],
        /// Image height in pixels (the viewer follows its window unless the size is fixed).
        height: u32 = 512, ["height", "height", Image, int(1, MAX_SIDE), always],
        /// The estimator: path tracing, distribution ray tracing (branching at every hit), bidirectional path tracing, or vertex connection and merging.
        integrator: Integrator = Integrator::Path, ["integrator", "integrator", Estimator, Domain::Choice(Integrator::CHOICES), always],
        /// Directions per hit for distribution ray tracing.
        branching: u32 = 8, ["branching", "directions per hit", Estimator, int(1, 4096), distribution],
        /// How distribution ray tracing chooses its directions.
        directions: Directions = Directions::Stratified, ["directions", "direction scheme", Estimator, Domain::Choice(Directions::CHOICES), distribution],
        /// Let distribution ray tracing exceed its budget of rays per sample.
        allow_expensive: bool = false, ["allow-expensive", "render anyway (over the ray budget)", Estimator, Domain::Switch, |s| distribution(s) && s.rays_per_sample_bound() > DRT_RAY_BUDGET],
        /// Vertex merging's radius at the first iteration, as a share of the scene's bounding-sphere radius; it shrinks over iterations by `vcm-alpha`.
        vcm_radius: f32 = 0.002, ["vcm-radius", "merging radius (share of the scene's)", Estimator, Domain::Float { min: 1e-6, max: 1.0, optional: false }, |s| s.integrator == Integrator::Vcm],
        /// How fast the merging radius shrinks (Knaus and Zwicker's alpha): its square goes as i^(alpha - 1) over iterations i, so that merging's bias vanishes; 1 keeps the radius fixed (biased, for measuring the bias), smaller shrinks faster (less bias, more noise).
        vcm_alpha: f32 = 0.75, ["vcm-alpha", "radius shrink (alpha)", Estimator, Domain::Float { min: 0.01, max: 1.0, optional: false }, |s| s.integrator == Integrator::Vcm],
        /// Bidirectional path tracing with only the connections of this many light-subpath vertices, each unweighted: one strategy's own estimate (pbrt-v4's strategy images), for checking and teaching; off: every strategy, weighted.
        strategy: Option<u32> = None, ["strategy", "one strategy (light vertices)", Estimator, Domain::Int { min: 0, max: 33, optional: true }, |s| s.integrator == Integrator::Bdpt],
        /// Draw directions in proportion to the BSDF (on) or uniformly over the hemisphere (off).
        importance_sampling: bool = true, ["importance", "importance sampling", Estimator, Domain::Switch, unidirectional],
        /// Transport in RGB or at sampled wavelengths (auto: spectral for dispersive scenes).
        spectral: Spectral = Spectral::Auto, ["spectral", "spectral", Estimator, Domain::Choice(Spectral::CHOICES), always],
        /// Light sampling strategy: none, explicit (no double counting), or MIS.
        light_sampling: LightSampling = LightSampling::Mis, ["lights", "light sampling", Estimator, Domain::Choice(LightSampling::CHOICES), unidirectional],
        /// Sequence of the sample numbers: independent, or Owen-scrambled Sobol.
        sampler: SamplerKind = SamplerKind::Sobol, ["sampler", "sampler", Estimator, Domain::Choice(SamplerKind::CHOICES), always],
        /// Maximum surface bounces, as pbrt-v4's maxdepth: 0 emitters only, 1 direct light (bidirectional estimators count scattering in media here too).
        max_depth: u32 = 7, ["max-depth", "max depth", Estimator, int(0, u32::MAX as u64), always],
        /// Maximum scattering events in media per path, apart from surface bounces (Cycles' volume bounces): subsurface random walks take hundreds (off: they count toward max depth, as in pbrt-v4 and the bidirectional estimators).
        max_volume_depth: Option<u32> = Some(1024), ["max-volume-depth", "max volume bounces", Estimator, Domain::Int { min: 0, max: u32::MAX as u64, optional: true }, path_tracing],
        /// Bounce from which Russian roulette may end paths (4: the least error at equal time on the Cornell box).
        rr_depth: u32 = 4, ["rr-depth", "roulette from", Estimator, int(0, u32::MAX as u64), always],
        /// How camera rays sample the pixel area.
        pixel_sampling: PixelSampling = PixelSampling::Random, ["pixel-sampling", "pixel sampling", Estimator, Domain::Choice(PixelSampling::CHOICES), always],
        /// Strata (and grid cells) per pixel axis for stratified and grid pixel sampling.
        strata: u32 = 4, ["strata", "strata per axis", Estimator, int(1, 64), |s| s.pixel_sampling != PixelSampling::Random],
        /// Directly seen emitters' edges by their exact pixel coverage, a control variate (`integrator::edges`; path tracing, BDPT and VCM; random or stratified pixels, no clamp).
        light_edges: bool = true, ["light-edges", "seen lights' edges by exact coverage", Estimator, Domain::Switch, Settings::edges_fit],
        /// Firefly clamp on a sample's largest component (biased; off unless given).
        firefly_clamp: Option<f32> = None, ["clamp", "firefly clamp (biased)", Estimator, Domain::Float { min: 1e-6, max: f32::MAX, optional: true }, always],
        /// Stop accumulating at this many samples per pixel (off: keep refining).
        target_spp: Option<u32> = None, ["spp", "stop at spp", Estimator, Domain::Int { min: 1, max: u32::MAX as u64, optional: true }, always],
        /// Noise threshold: a pixel stops taking samples once the estimated relative standard error of its luminance is below this (0.01: 1%; 0: never, but estimated honestly).
        noise_threshold: Option<f32> = None, ["noise-threshold", "noise threshold", Convergence, Domain::Float { min: 0.0, max: 1.0, optional: true }, always],
        /// Samples every pixel takes before the noise threshold may stop it (fewer leave rare light paths unseen).
        min_spp: u32 = 64, ["min-spp", "min spp before stopping", Convergence, int(4, u32::MAX as u64), |s| s.noise_threshold.is_some()],
        /// Seed of every random stream.
        seed: u64 = 0, ["seed", "seed", Estimator, int(0, u64::MAX), always],
        /// Index of the first sample of every pixel (a piece of a render split by samples).
        first_sample: u32 = 0, ["first-sample", "first sample index", Estimator, int(0, u32::MAX as u64), |_| false],
        /// Watertight ray/triangle test (off: obvhs's Moller-Trumbore test, which leaks at edges).
        watertight: bool = true, ["watertight", "watertight triangle test (off: leaks at edges)", Robustness, Domain::Switch, always],
        /// Ray origins offset by the hit point's floating-point error bound (off: shadow acne).
        offset_origins: bool = true, ["offsets", "error-bound ray offsets (off: shadow acne)", Robustness, Domain::Switch, always],
        /// Hanika's shadow-terminator offset for smooth-shaded meshes (off: a faceted terminator).
        terminator: bool = true, ["terminator", "shadow-terminator offset (off: faceted terminator)", Robustness, Domain::Switch, always],
    }
}

/// A settings value outside its valid range.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidSettings(pub String);

impl fmt::Display for InvalidSettings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InvalidSettings {}

impl Integrator {
    /// Whether light subpaths add to other pixels than their sample's (light tracing), so
    /// that the film takes splats and a pixel's noise cannot stop its samples.
    pub fn is_bidirectional(self) -> bool {
        matches!(self, Integrator::Bdpt | Integrator::Vcm)
    }
}

impl Settings {
    /// Whether paths should carry wavelengths, in a scene with (`dispersion`) or without a
    /// dispersive material.
    pub fn wants_spectral(&self, dispersion: bool) -> bool {
        match self.spectral {
            Spectral::On => true,
            Spectral::Auto => dispersion,
            Spectral::Off => false,
        }
    }

    /// What decides the image's pixels: these settings with every parameter that has no
    /// effect on them (one the viewer hides, such as strata under random pixel sampling)
    /// at its default, and no sample range. Pieces of one render have the same.
    pub fn image_defining(&self) -> Settings {
        let mut s = Settings { first_sample: 0, target_spp: None, ..*self };
        for p in SETTINGS {
            if !(p.shown)(self) {
                (p.set)(&mut s, p.default_value());
            }
        }
        s
    }

    /// Independent randomisations each pixel's samples are split among (`Sampler::replicated`):
    /// two for Sobol renders with a noise threshold, whose error must be estimated honestly
    /// (`film::adaptive`); one otherwise, since two replicates cost more squared error
    /// (docs/accuracy.md).
    pub fn replicates(&self) -> u32 {
        if self.noise_threshold.is_some() && self.sampler == SamplerKind::Sobol { 2 } else { 1 }
    }

    /// Whether samples carry the control variate of directly seen emitters' edges: asked
    /// for, and where it fits (`edges_fit`).
    pub fn edge_control_variate(&self) -> bool {
        self.light_edges && self.edges_fit()
    }

    /// Whether the control variate of seen emitters' edges keeps the estimate unbiased
    /// (uniform pixel positions) and the estimator adds what camera rays find in full (no
    /// clamp; path tracing, or the bidirectional estimators, whose camera subpath finding an
    /// emitter from the camera is the one strategy for such a path, unless `--strategy`
    /// shows another alone): where its switch is shown.
    fn edges_fit(&self) -> bool {
        let full = match self.integrator {
            Integrator::Path | Integrator::Vcm => true,
            Integrator::Bdpt => self.strategy.is_none_or(|s| s == 0),
            Integrator::Distribution => false,
        };
        full && self.pixel_sampling != PixelSampling::Grid && self.firefly_clamp.is_none()
    }

    /// The parameter table.
    pub fn table() -> &'static [Param<Settings>] {
        SETTINGS
    }

    /// Most rays one sample of distribution ray tracing traces: branching^k rays reach
    /// depth k = 0..=max_depth, plus one shadow ray per hit below max_depth when lights
    /// are sampled. Reached exactly in a closed scene. Infinite for path tracing (unbounded).
    pub fn rays_per_sample_bound(&self) -> f64 {
        if self.integrator == Integrator::Path {
            return f64::INFINITY;
        }
        let n = self.branching as f64;
        let depth = self.max_depth.min(4096) as i32;
        let hits_below = (0..depth).map(|k| n.powi(k)).sum::<f64>();
        let shadow = if self.light_sampling == LightSampling::Off { 0.0 } else { hits_below };
        hits_below + n.powi(depth) + shadow
    }

    /// Checks every parameter against its table entry, and the distribution ray tracer's
    /// ray budget.
    pub fn validate(&self) -> Result<(), InvalidSettings> {
        crate::params::validate(SETTINGS, self).map_err(InvalidSettings)?;
        let rays = self.rays_per_sample_bound();
        if self.integrator == Integrator::Distribution && rays > DRT_RAY_BUDGET && !self.allow_expensive {
            return Err(InvalidSettings(format!(
                "distribution ray tracing with branching {} and depth {} traces up to {rays:.3e} rays per sample, over the budget of {DRT_RAY_BUDGET:.0e}: allow it explicitly (--allow-expensive on)",
                self.branching, self.max_depth
            )));
        }
        Ok(())
    }
}
