//! Render settings: a plain, comparable struct; any change restarts accumulation.

pub use crate::math::sampler::SamplerKind;
use serde::{Deserialize, Serialize};
use std::fmt;

/// How camera rays sample the pixel's area.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PixelSampling {
    /// Independent uniform positions in the pixel (Monte Carlo).
    #[default]
    Random,
    /// Jittered strata: each round of `strata`^2 samples puts one sample in every stratum.
    /// Every single sample is still uniform over the pixel, so partial rounds stay unbiased.
    Stratified,
    /// The textbook's uniform sub-pixel grid (section 10.3, eqs. 4 to 6), evaluated at the
    /// cell midpoints; deterministic, biased by discretisation, repeats after `strata`^2.
    Grid,
}

/// How light sources are found (the textbook's "explicit light sampling", section 10.9).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LightSampling {
    /// Only BSDF-sampled rays that happen to hit an emitter find light.
    Off,
    /// A shadow ray to one sampled light per hit; emitters hit by BSDF rays after the
    /// camera ray add nothing, so nothing is counted twice.
    Explicit,
    /// Both strategies, combined by multiple importance sampling (power heuristic, Veach 1997).
    #[default]
    Mis,
}

/// Which estimator of the rendering equation renders the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// Path tracing (section 10.7): one direction per bounce, Russian roulette.
    #[default]
    Path,
    /// Distribution ray tracing (sections 10.2 to 10.6): `branching` directions at every
    /// hit, recursively to `max_depth`; its cost grows as branching^depth.
    Distribution,
}

/// How distribution ray tracing chooses its hemisphere directions at a hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Directions {
    /// Stratified Monte Carlo: one BSDF sample (or uniform sample, with importance
    /// sampling off) per stratum of a grid over the unit square. Unbiased.
    #[default]
    Stratified,
    /// The textbook's uniform theta/phi grid (eqs. 8 to 10), at cell midpoints, weighted by
    /// sin(theta) dtheta dphi. Deterministic, biased by discretisation; a baseline.
    Grid,
}

/// Rays one distribution-ray-traced sample may trace before it needs confirmation.
pub const DRT_RAY_BUDGET: f64 = 2e5;

/// Numerical-robustness mechanisms, all on by default. Switching one off shows what it
/// prevents (light leaks, shadow acne, a faceted shadow terminator) and, with
/// `lucent bench robustness`, what it costs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Robustness {
    /// Watertight ray/triangle test (off: obvhs's Moller-Trumbore test, which leaks at edges).
    pub watertight: bool,
    /// Ray origins offset by the hit point's floating-point error bound (off: rays leave
    /// from the computed hit point itself).
    pub offset_origins: bool,
    /// Hanika's shadow-terminator offset for smooth-shaded meshes (off: rays leave the facet).
    pub terminator: bool,
}

impl Default for Robustness {
    fn default() -> Self {
        Self { watertight: true, offset_origins: true, terminator: true }
    }
}

/// Everything that determines the image, besides the scene and the camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Seed of every random stream.
    pub seed: u64,
    /// Maximum number of bounces (pbrt-v4's maxdepth: 0 = emitters seen directly, 1 = direct light).
    pub max_depth: u32,
    /// Bounce count from which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Pixel-area sampling mode.
    pub pixel_sampling: PixelSampling,
    /// Strata (and grid cells) per pixel axis for `Stratified` and `Grid`.
    pub strata: u32,
    /// Draw directions in proportion to the BSDF (on) or uniformly over the hemisphere (off).
    pub importance_sampling: bool,
    /// Light sampling strategy.
    pub light_sampling: LightSampling,
    /// Scale down samples whose largest component exceeds this (biased; off by default).
    pub firefly_clamp: Option<f32>,
    /// Stop accumulating at this many samples per pixel (None: keep refining).
    pub target_spp: Option<u32>,
    /// Numerical-robustness mechanisms.
    pub robustness: Robustness,
    /// Sequence the pixel samples draw from.
    pub sampler: SamplerKind,
    /// The estimator.
    pub integrator: Integrator,
    /// Directions per hit for distribution ray tracing.
    pub branching: u32,
    /// How distribution ray tracing chooses its directions.
    pub directions: Directions,
    /// Lets distribution ray tracing exceed `DRT_RAY_BUDGET` rays per sample.
    pub allow_expensive: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            seed: 0,
            max_depth: 7,
            rr_depth: 3,
            pixel_sampling: PixelSampling::default(),
            strata: 4,
            importance_sampling: true,
            light_sampling: LightSampling::default(),
            firefly_clamp: None,
            target_spp: None,
            robustness: Robustness::default(),
            sampler: SamplerKind::default(),
            integrator: Integrator::default(),
            branching: 8,
            directions: Directions::default(),
            allow_expensive: false,
        }
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

impl Settings {
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

    /// Checks ranges: a non-empty image of at most 16384 pixels a side, at least one
    /// stratum, a positive finite clamp.
    pub fn validate(&self) -> Result<(), InvalidSettings> {
        let bad = |m: String| Err(InvalidSettings(m));
        if !(1..=16384).contains(&self.width) || !(1..=16384).contains(&self.height) {
            return bad(format!("image size {}x{} is outside 1..=16384", self.width, self.height));
        }
        if !(1..=64).contains(&self.strata) {
            return bad(format!("strata {} is outside 1..=64", self.strata));
        }
        if let Some(c) = self.firefly_clamp
            && !(c > 0.0 && c.is_finite())
        {
            return bad(format!("firefly clamp {c} must be positive and finite"));
        }
        if !(1..=4096).contains(&self.branching) {
            return bad(format!("branching {} is outside 1..=4096", self.branching));
        }
        let rays = self.rays_per_sample_bound();
        if self.integrator == Integrator::Distribution && rays > DRT_RAY_BUDGET && !self.allow_expensive {
            return bad(format!(
                "distribution ray tracing with branching {} and depth {} traces up to {rays:.3e} rays per sample, over the budget of {DRT_RAY_BUDGET:.0e}: allow it explicitly (--allow-expensive)",
                self.branching, self.max_depth
            ));
        }
        if self.target_spp == Some(0) {
            return bad("target spp must be at least 1".into());
        }
        Ok(())
    }
}
