//! Estimators of the rendering equation: render settings, the path tracer and the
//! distribution ray tracer.

mod drt;
pub mod media;
pub mod nan;
pub mod path;
pub mod settings;

pub use path::{PathOutput, SampleFn, kernel};
pub use settings::{Directions, Integrator, LightSampling, PixelSampling, Robustness, SamplerKind, Settings};
