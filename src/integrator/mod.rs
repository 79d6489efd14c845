//! Estimators of the rendering equation: render settings and the path tracer.

pub mod nan;
pub mod path;
pub mod settings;

pub use path::{PathOutput, SampleFn, kernel};
pub use settings::{LightSampling, PixelSampling, Robustness, SamplerKind, Settings};
