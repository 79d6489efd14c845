//! Estimators of the rendering equation. The path tracer (`path`), the distribution ray
//! tracer (`drt`) and bidirectional path tracing with vertex connection and merging
//! (`bdpt`, whose merging finds the light vertices of `photons`) are leaves built from
//! shared parts: the pixel sample (`kernel`), the
//! surface vertex (`vertex`), direction sampling (`scatter`), next-event estimation
//! (`direct`), light found by BSDF rays (`emission`), the control variate for the edges of
//! emitters the camera sees (`edges`), MIS weights (`mis`), the volumes a
//! path is in (`media`) and the denoiser's albedo and normal of a sample (`aov`).

mod aov;
mod bdpt;
mod direct;
mod drt;
mod edges;
mod emission;
pub mod kernel;
pub mod media;
mod mis;
pub mod nan;
mod path;
pub mod photons;
pub mod scatter;
pub mod settings;
mod vertex;

use crate::scene::Scene;

/// What every part of an estimator reads: the scene and the render settings.
#[derive(Clone, Copy)]
pub(crate) struct Context<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// The render settings.
    pub settings: &'a Settings,
}

pub use aov::Aov;
pub use bdpt::MAX_DEPTH as MAX_BIDIRECTIONAL_DEPTH;
pub use drt::grid_shape;
pub use kernel::{PathOutput, View, is_spectral, sample_pixel, sample_pixels, simulated_effects};
pub use scatter::Sampling;
pub use settings::{Directions, Integrator, LightSampling, PixelSampling, SamplerKind, Settings, Spectral};
