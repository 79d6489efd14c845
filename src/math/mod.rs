//! Shared maths: orthonormal frames, sample warps with their pdfs, samplers, discrete and
//! piecewise-constant distributions, and float error bounds.

pub mod distribution;
pub mod float;
pub mod frame;
pub mod sampler;
pub mod warp;

use glam::Vec3;

/// Luminance of a linear Rec. 709 colour (the weights of ITU-R BT.709).
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}
