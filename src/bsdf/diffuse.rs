//! Lambertian reflection: f = albedo / pi.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// Ideal diffuse reflector.
#[derive(Clone, Copy, Debug)]
pub struct Lambert {
    /// Hemispherical reflectance (linear RGB).
    pub albedo: Vec3,
}

impl Lambert {
    /// f |cos theta_i| for wi above the surface.
    pub fn eval_cos(&self, wi: Vec3) -> Vec3 {
        self.albedo * (FRAC_1_PI * wi.z)
    }
}
