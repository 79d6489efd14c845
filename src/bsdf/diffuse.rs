//! Lambertian reflection: f = albedo / pi.

use crate::spectrum::Spectrum;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// Ideal diffuse reflector.
#[derive(Clone, Copy, Debug)]
pub struct Lambert {
    /// Hemispherical reflectance.
    pub albedo: Spectrum,
}

impl Lambert {
    /// f |cos theta_i| for wi above the surface.
    pub fn eval(&self, wi: Vec3) -> Spectrum {
        self.albedo * (FRAC_1_PI * wi.z)
    }
}
